// The forest-evaluation seam. runtime/kernels/ref/ (plain C++) is the specification; per-ISA folders
// (runtime/kernels/avx2/, avx512/, neon/) hold files of the same names whose results must equal the
// reference bit for bit (tests/runtime_kernel_test.cc proves it).
// Kernels run on caller-provided memory only: no heap, no exceptions, no state between calls.
// The inline helpers below have internal linkage (an unnamed namespace): ISA folders compile this
// header with their own instruction-set flags, and no copy may stand in for another TU's.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "forest_blob/blob_format.h"
#include "runtime/depthpose.h"
#include "runtime/fixed_point.h"

namespace dp::kernels {

// The probe image with a one-pixel border: (width + 2) × (height + 2) uint16, row stride
// probe_stride = width + 2. Pixel (u, v) is at [(v + 1)·probe_stride + (u + 1)]; the border rows and
// columns hold the background, so a probe clamped to the border reads exactly what
// runtime/fixed_point.h prescribes for any probe off the image.
// Each element is a probe depth d (1 ≤ d ≤ kBackgroundDepthMm, the background itself included) plus
// kProbeBias, i.e. d with bit 15 set: probe_element(d) to write, probe_depth_of(e) to read. Why biased:
// the SIMD kernels take a visit's child bit (t + d2 − d1 < 0) as the carry of one unsigned compare of
// t + (d2 + bias) with d1 + bias, both sides then ≥ 0 for every int16 threshold t (one cmp and one adc
// instead of add, sub, shift and lea; docs/runtime_speed.md).
constexpr uint16_t kProbeBias = 0x8000;
static_assert(kBackgroundDepthMm < kProbeBias, "probe depths fit below the bias bit");
namespace {
// The element for depth_mm: the background for 0 (no reading) and for depth_mm ≥ kBackgroundDepthMm.
inline uint16_t probe_element(uint16_t depth_mm) {
  return uint16_t((depth_mm == 0 || depth_mm >= kBackgroundDepthMm ? kBackgroundDepthMm : depth_mm) | kProbeBias);
}
inline int32_t probe_depth_of(uint16_t element) { return int32_t(element) - kProbeBias; }
inline size_t padded_probe_elements(int32_t width, int32_t height) {
  return size_t(width + 2) * size_t(height + 2);
}
// Fills the border of a padded probe image with the background (interior untouched).
inline void fill_probe_border(uint16_t* padded, int32_t width, int32_t height) {
  const int32_t stride = width + 2;
  const uint16_t background = probe_element(kBackgroundDepthMm);
  for (int32_t u = 0; u < stride; ++u) {
    padded[u] = background;
    padded[size_t(height + 1) * stride + u] = background;
  }
  for (int32_t v = 1; v <= height; ++v) {
    padded[size_t(v) * stride] = background;
    padded[size_t(v) * stride + width + 1] = background;
  }
}
}  // namespace

// Compact 8-byte node, built at init from blob::TreeNode when every |offset| ≤ kPackedMaxOffset
// (PCL's trees: 395). Lane k (int16, k = du1, dv1, du2, dv2) holds offset_k·16 in bits 4..15 and
// bits 4k..4k+3 of the int16 threshold in bits 0..3:
//   offset_k·4   = (lane_k & ~15) >> 2      (what the SIMD probe arithmetic wants)
//   threshold_mm = int16(pext(node, 0x000F000F000F000F))
struct PackedNode {
  uint64_t bits;
};
static_assert(sizeof(PackedNode) == 8, "PackedNode is 8 bytes");
constexpr int32_t kPackedMaxOffset = 2047;

namespace {
inline PackedNode pack_node(const blob::TreeNode& n) {
  const int16_t offsets[4] = {n.du1, n.dv1, n.du2, n.dv2};
  const uint16_t t = uint16_t(n.threshold_mm);
  uint64_t bits = 0;
  for (int k = 0; k < 4; ++k) {
    const uint16_t lane = uint16_t(uint16_t(offsets[k]) << 4) | uint16_t((t >> (4 * k)) & 15u);
    bits |= uint64_t(lane) << (16 * k);
  }
  return PackedNode{bits};
}
}  // namespace

// Node layouts (the layout study, `make bench`; docs/runtime_speed.md), all read by the same kernel
// code. The pipeline builds kSplit at init from the blob (forest.h build_forest_tables); kBlob10 (the
// TreeNode tables of blob::expand_tree_tables), kPacked8 and kWide16 are kept for the study.
enum class NodeLayout : int32_t { kBlob10, kPacked8, kWide16, kSplit };
// kSplit: one tree's nodes as 16-byte SplitNodes, node m at [m − 1] (the blob's breadth-first order):
// offsets holds 4·du1, 4·dv1, 4·du2, 4·dv2 as 4 little-endian int16 (what one 8-byte load puts in a
// vector's lanes, already scaled for the kernels' pmulhrsw: |4δ| ≤ 4·blob::kMaxProbeOffsetPxm = 16384
// fits), then the node's left child (blob kLeftChild) and threshold, each one scalar load from the
// same line: a visit touches one cache line (the blob's nodes and left children are two).
struct alignas(16) SplitNode {
  uint64_t offsets;
  uint32_t left_child;
  int16_t threshold_mm;
  int16_t reserved;
};
static_assert(sizeof(SplitNode) == 16, "SplitNode is 16 bytes");
struct SplitTree {
  const SplitNode* nodes;
};
namespace {
inline uint64_t split_offsets_of(const blob::TreeNode& n) {
  static_assert(4 * blob::kMaxProbeOffsetPxm <= 32767, "4δ fits int16");
  return uint64_t(uint16_t(4 * n.du1)) | uint64_t(uint16_t(4 * n.dv1)) << 16 | uint64_t(uint16_t(4 * n.du2)) << 32 |
         uint64_t(uint16_t(4 * n.dv2)) << 48;
}
inline SplitNode split_node_of(const blob::TreeNode& n, uint32_t left_child) {
  return SplitNode{split_offsets_of(n), left_child, n.threshold_mm, 0};
}
}  // namespace
struct WideNode {  // kWide16: the blob node, aligned and padded to 16 bytes
  int16_t du1, dv1, du2, dv2;
  int16_t threshold_mm;
  int16_t pad[3];
};
static_assert(sizeof(WideNode) == 16, "WideNode is 16 bytes");

struct ForestKernelArgs {
  const uint16_t* probe_image;    // padded probe image (above): probe_element(foreground depth or background)
  int32_t probe_stride;           // width + 2
  int32_t width, height;
  int32_t focal_factor;           // runtime/fixed_point.h
  const EvaluatedPixel* pixels;   // pixels to classify; z_mm > 0, u < width, v < height
  int32_t pixel_count;
  // One tree in breadth-first node order (blob_format.h): node m (1-based, root 1) at [m − 1] of
  // nodes, left_child and leaf_index (blob::expand_tree_tables; a leaf node is blob::kLeafNode, its
  // own left child); node_count of each. A visit of node m goes to left_child[m − 1] +
  // [feature > threshold]; after `depth` visits the node reached is a leaf node whose record is
  // leaf_index[m − 1]. The pipeline gives only `split` and leaf_index (nodes and left_child nullptr).
  const blob::TreeNode* nodes;
  const PackedNode* packed_nodes; // the same tree packed (same order), or nullptr
  const uint32_t* left_child;
  const uint32_t* leaf_index;
  int32_t depth;                  // validated 1..kMaxDepth
  uint32_t node_count;            // validated 1..max_nodes_per_tree(depth)
  uint32_t* leaf_out;             // pixel_count outputs: leaf-record index reached
  const SplitTree* split;         // the same tree split (kSplit), or nullptr. The kernels read
                                  // split, else packed_nodes (SIMD), else nodes; the result is the same
  const WideNode* study_nodes;    // evaluate_trees_study(kWide16) only: the same tree, 16-byte nodes
};

using ForestKernelFn = void (*)(const ForestKernelArgs& args);
// Every tree of a forest over the same pixels, in one call: per_tree[0 .. tree_count) differ only in
// nodes, packed_nodes, left_child, leaf_index, node_count and leaf_out (the probe image, pixels, focal factor and depth are
// the same). Results equal tree_count calls of the single-tree kernel; the SIMD kernels make each
// pixel's setup once for all trees.
using ForestTreesKernelFn = void (*)(const ForestKernelArgs* per_tree, int32_t tree_count);

namespace ref {
void evaluate_tree(const ForestKernelArgs& args);
void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count);
}  // namespace ref
namespace avx2 {
void evaluate_tree(const ForestKernelArgs& args);
void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count);
// The layout study: every tree read in `layout` (kSplit from split, kPacked8 from packed_nodes,
// kWide16 from study_nodes, kBlob10 from nodes). Same results as evaluate_trees.
void evaluate_trees_study(const ForestKernelArgs* per_tree, int32_t tree_count, NodeLayout layout);
}  // namespace avx2
namespace avx512 {
void evaluate_tree(const ForestKernelArgs& args);
void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count);
void evaluate_trees_study(const ForestKernelArgs* per_tree, int32_t tree_count, NodeLayout layout);
}  // namespace avx512
namespace neon {
void evaluate_tree(const ForestKernelArgs& args);
void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count);
void evaluate_trees_study(const ForestKernelArgs* per_tree, int32_t tree_count, NodeLayout layout);
}  // namespace neon

// The kernel for `isa`, or nullptr when this build or this CPU lacks it (kBest never nullptr).
ForestKernelFn forest_kernel(KernelIsa isa);
ForestTreesKernelFn forest_trees_kernel(KernelIsa isa);

}  // namespace dp::kernels
