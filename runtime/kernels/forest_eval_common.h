// The shared, instruction-set-free parts of the SIMD forest kernels: per-chunk pixel setup, node-layout
// policies, the level-by-level driver and the layout-study switch. Each ISA's forest_eval.cc includes
// it once (through forest_eval_simd.h on x86) and supplies its own level_of_chunk; everything here
// has internal linkage, so the ISA compilations never mix. Same results as ref/forest_eval.cc bit
// for bit; the exactness argument for the probe arithmetic every SIMD kernel uses, in int16 lanes
// (4 per pixel: du1, dv1, du2, dv2):
//   probe offset  (δ·s + 4096) >> 13  ==  pmulhrsw(4δ, s) = (4δ·s + 2^14) >> 15   (|4δ| ≤ 16384)
//                 (NEON: sqrdmulh(4δ, s) = (2·4δ·s + 2^15) >> 16, the same value, never saturating)
//   off-image     padded coordinates (u + 1 + offset, v + 1 + offset) are clamped as unsigned int16 to
//                 [0, width + 1] × [0, height + 1]: a negative coordinate wraps above 32767 and
//                 clamps to the far border. Every border pixel holds kBackgroundDepthMm — the value
//                 the rule gives any off-image probe, on whichever side it left the image;
//                 |u + 1 + offset| ≤ 4096 + 16384 keeps every coordinate inside int16.
//   address       (v + 1)·stride + (u + 1) by a widening multiply-add, stride ≤ 4098.
//   child         f > t  ⇔  t + p2 < p1 ⇔  t + e2 <u e1 for the biased elements e = p + kProbeBias
//                 (forest_kernel.h): t ≥ −32768 keeps t + e2 ≥ 0, so the unsigned compare is exact and
//                 its carry is the child bit. Node indices are 1-based (root 1; node m is array element
//                 m − 1, blob_format.h kNodes), so child = left_child[m − 1] + carry; a leaf node's left
//                 child is itself and its pad threshold never sets the carry.
// Speed (docs/runtime_speed.md): pixels are evaluated breadth-first, one tree level at a time over
// a chunk of pixels, so the visits of a level are independent and overlap in the core; on the deep
// levels (prefetch_from_level), a pixel's next node is prefetched as soon as the visit has chosen
// it, a whole sweep over the chunk before it is read (one instruction per visit; reading the index
// of a pixel some positions ahead and prefetching its node cost two, and measured 5–7 % slower).
#pragma once
#include <stddef.h>
#include <stdint.h>
#if defined(__BMI2__)
#include <immintrin.h>
#endif
#include <string.h>

#include "runtime/kernels/forest_kernel.h"

namespace dp::kernels {
namespace {

constexpr int32_t kChunkPixels = 2048;
// Children are prefetched only on the levels whose nodes do not stay in L2 from one frame (or tree
// sweep) to the next: from the first level at which the nodes of all trees down to that level exceed
// kCachedNodeBytes (a quarter of the Intel host's 2 MB L2, half of Zen 4's 1 MB). Above it a prefetch is an op
// per visit for a line that is already cached: prefetching from level 6 instead measured 4–6 %
// slower on the PCL trees (level 14 by this rule; levels 12–15 all measured alike). The nodes down
// to level L are at most min(2^(L+1) − 1, node_count) per tree (node_count: the tree's real count),
// so a forest that fits the budget whole is never prefetched.
constexpr size_t kCachedNodeBytes = size_t(512) << 10;
inline int32_t prefetch_from_level(int32_t tree_count, int32_t node_bytes, uint32_t node_count) {
  int32_t level = 0;
  auto nodes_down_to = [&](int32_t l) {
    const size_t full = (size_t(2) << l) - 1;
    return full < node_count ? full : size_t(node_count);
  };
  while (level < 30 && size_t(tree_count) * size_t(node_bytes) * nodes_down_to(level) <= kCachedNodeBytes) ++level;
  return level;
}

// Per pixel of a chunk, in two arrays so that consecutive pixels' setups are one vector load:
// scale_q13 (s in 4 int16 lanes) and origin (u + 1, v + 1, u + 1, v + 1, padded coordinates).
// 64-byte aligned: the AVX-512 kernel reads 8 pixels' setups (one cache line) at a time.
struct ChunkSetup {
  alignas(64) int16_t scale_q13[kChunkPixels][4];
  alignas(64) int16_t origin[kChunkPixels][4];
};

inline int32_t scale_q13_of(int32_t focal_factor, int32_t z_mm) {  // = dp::scale_q13
  const int32_t s = (focal_factor * 8192 + z_mm / 2) / z_mm;
  return s < 32767 ? s : 32767;
}

// Where a kernel reads node m (policies; the level loops are templates over them): its four offsets
// as 4 int16 lanes of 64 bits (`bits`: δ, or 4·δ when kOffsetsTimesFour), its left child
// (`left_child`: the blob's kLeftChild, or the split node's copy), its threshold (`threshold`;
// when kThresholdInLanes, the low nibbles of the lanes carry it, kernels::pack_node's layout, `bits`
// holds δ·16 above them, and a kernel may decode the threshold in lanes instead), and the prefetch
// of its line(s) (the left child's included).
// An array of node structs with fields du1, dv1, du2, dv2, threshold_mm (offsets first: the 8-byte
// load is unaligned for the blob's 10-byte nodes), taken from ForestKernelArgs::*kNodes.
template <class Node, const Node* ForestKernelArgs::*kNodes>
struct ArrayNodes {
  static constexpr bool kThresholdInLanes = false;
  static constexpr bool kOffsetsTimesFour = false;
  static constexpr int32_t kBytes = sizeof(Node) + sizeof(uint32_t);  // and the left child
  const Node* nodes;
  explicit ArrayNodes(const ForestKernelArgs& a) : nodes(a.*kNodes), left(a.left_child) {}
  long long bits(uint32_t m) const {
    long long b;
    memcpy(&b, nodes + (size_t(m) - 1), sizeof b);
    return b;
  }
  int32_t threshold(uint32_t m) const { return nodes[size_t(m) - 1].threshold_mm; }
  uint32_t left_child(uint32_t m) const { return left[size_t(m) - 1]; }
  void prefetch(uint32_t m) const {
    __builtin_prefetch(nodes + (size_t(m) - 1), 0, 3);
    __builtin_prefetch(left + (size_t(m) - 1), 0, 3);
  }
  const uint32_t* left;
};
using BlobNodes = ArrayNodes<blob::TreeNode, &ForestKernelArgs::nodes>;  // the blob's 10-byte nodes
using WideNodes = ArrayNodes<WideNode, &ForestKernelArgs::study_nodes>;  // layout study: 16-byte nodes
struct PackedNodes {  // layout study: 8-byte nodes
  static constexpr bool kThresholdInLanes = true;
  static constexpr bool kOffsetsTimesFour = false;
  static constexpr int32_t kBytes = sizeof(PackedNode) + sizeof(uint32_t);  // and the left child
  const PackedNode* nodes;
  const uint32_t* left;
  explicit PackedNodes(const ForestKernelArgs& a) : nodes(a.packed_nodes), left(a.left_child) {}
  uint32_t left_child(uint32_t m) const { return left[size_t(m) - 1]; }
  long long bits(uint32_t m) const { return static_cast<long long>(nodes[size_t(m) - 1].bits); }
  // The lanes' low nibbles joined (kernels::pack_node); the AVX-512 kernel decodes them in lanes instead.
  int32_t threshold(uint32_t m) const {
#if defined(__BMI2__)
    return int16_t(_pext_u64(nodes[size_t(m) - 1].bits, 0x000F000F000F000Full));
#else
    const uint64_t b = nodes[size_t(m) - 1].bits;
    return int16_t(uint16_t((b & 15u) | ((b >> 12) & 0xF0u) | ((b >> 24) & 0xF00u) | ((b >> 36) & 0xF000u)));
#endif
  }
  void prefetch(uint32_t m) const {
    __builtin_prefetch(nodes + (size_t(m) - 1), 0, 3);
    __builtin_prefetch(left + (size_t(m) - 1), 0, 3);
  }
};
struct SplitNodes {  // what the pipeline evaluates: 16-byte nodes, offsets (4·δ), left child, threshold
  static constexpr bool kThresholdInLanes = false;
  static constexpr bool kOffsetsTimesFour = true;
  static constexpr int32_t kBytes = sizeof(SplitNode);
  const SplitNode* nodes;
  explicit SplitNodes(const ForestKernelArgs& a) : nodes(a.split->nodes) {}
  long long bits(uint32_t m) const { return static_cast<long long>(nodes[size_t(m) - 1].offsets); }
  int32_t threshold(uint32_t m) const { return nodes[size_t(m) - 1].threshold_mm; }
  uint32_t left_child(uint32_t m) const { return nodes[size_t(m) - 1].left_child; }
  void prefetch(uint32_t m) const { __builtin_prefetch(nodes + (size_t(m) - 1), 0, 3); }
};

// One level of one tree over a chunk whose setups are filled for `padded` pixels: node[i] holds each
// pixel's node index (1-based) and becomes its child's; when kPrefetchChildren, each child's node and
// left-child entry are prefetched.
using LevelFn = void (*)(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t padded);

// All levels of one tree (of a forest of tree_count trees whose nodes take kNodeBytes) over a
// chunk; writes the first `count` leaf-record indices to a.leaf_out + base.
template <LevelFn kLevel, LevelFn kLevelPrefetchingChildren, int32_t kNodeBytes>
void evaluate_chunk_by_levels(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t base,
                              int32_t count, int32_t padded, int32_t tree_count) {
  const int32_t prefetch_from = prefetch_from_level(tree_count, kNodeBytes, a.node_count);
  for (int32_t i = 0; i < padded; ++i) node[i] = 1;  // the root, 1-based
  for (int32_t level = 0; level < a.depth; ++level) {
    if (level + 1 >= prefetch_from && level + 1 < a.depth)
      kLevelPrefetchingChildren(a, setup, node, padded);
    else
      kLevel(a, setup, node, padded);
  }
  for (int32_t i = 0; i < count; ++i) a.leaf_out[base + i] = a.leaf_index[node[i] - 1];
}

using ChunkFn = void (*)(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t base,
                         int32_t count, int32_t padded, int32_t tree_count);

// Every tree over the same pixels, chunk by chunk: a chunk's per-pixel setup (a division per pixel)
// is made once for all trees, then each tree runs its levels over it (kSplitChunk when the tree has
// split nodes, else kPackedChunk when it has packed nodes, else kBlobChunk). A chunk is padded to a multiple of kPixelsPerStep with copies of
// its last pixel, whose results are discarded.
// (The layout study gives one ChunkFn for all three.)
template <int32_t kPixelsPerStep, ChunkFn kSplitChunk, ChunkFn kPackedChunk, ChunkFn kBlobChunk>
inline void evaluate_trees_simd(const ForestKernelArgs* per_tree, int32_t tree_count) {
  static_assert(kChunkPixels % kPixelsPerStep == 0, "steps tile the chunk");
  if (tree_count <= 0) return;
  const ForestKernelArgs& a = per_tree[0];
  ChunkSetup setup;
  alignas(64) uint32_t node[kChunkPixels];
  for (int32_t base = 0; base < a.pixel_count; base += kChunkPixels) {
    const int32_t count = a.pixel_count - base < kChunkPixels ? a.pixel_count - base : kChunkPixels;
    const int32_t padded = (count + kPixelsPerStep - 1) / kPixelsPerStep * kPixelsPerStep;
    for (int32_t i = 0; i < padded; ++i) {
      const EvaluatedPixel px = a.pixels[base + (i < count ? i : count - 1)];
      const int16_t s = int16_t(scale_q13_of(a.focal_factor, px.z_mm));
      const int16_t u = int16_t(px.u + 1), v = int16_t(px.v + 1);
      for (int k = 0; k < 4; ++k) setup.scale_q13[i][k] = s;
      setup.origin[i][0] = setup.origin[i][2] = u;
      setup.origin[i][1] = setup.origin[i][3] = v;
    }
    for (int32_t t = 0; t < tree_count; ++t) {
      if (per_tree[t].split)
        kSplitChunk(per_tree[t], setup, node, base, count, padded, tree_count);
      else if (per_tree[t].packed_nodes)
        kPackedChunk(per_tree[t], setup, node, base, count, padded, tree_count);
      else
        kBlobChunk(per_tree[t], setup, node, base, count, padded, tree_count);
    }
  }
}

// Every tree read by one chunk function (the layout study).
template <int32_t kPixelsPerStep, ChunkFn kChunk>
void evaluate_trees_with(const ForestKernelArgs* per_tree, int32_t tree_count) {
  evaluate_trees_simd<kPixelsPerStep, kChunk, kChunk, kChunk>(per_tree, tree_count);
}

// The layout study for an ISA whose chunk function for a node policy is Chunk<Nodes>::kFn: every
// tree read as `layout`.
template <int32_t kPixelsPerStep, template <class> class Chunk>
void evaluate_trees_study_simd(const ForestKernelArgs* per_tree, int32_t tree_count, NodeLayout layout) {
  switch (layout) {
    case NodeLayout::kBlob10: return evaluate_trees_with<kPixelsPerStep, Chunk<BlobNodes>::kFn>(per_tree, tree_count);
    case NodeLayout::kPacked8: return evaluate_trees_with<kPixelsPerStep, Chunk<PackedNodes>::kFn>(per_tree, tree_count);
    case NodeLayout::kWide16: return evaluate_trees_with<kPixelsPerStep, Chunk<WideNodes>::kFn>(per_tree, tree_count);
    case NodeLayout::kSplit: return evaluate_trees_with<kPixelsPerStep, Chunk<SplitNodes>::kFn>(per_tree, tree_count);
  }
}

}  // namespace
}  // namespace dp::kernels
