// forest_blob v4 — the on-disk (and in-memory) model of depthpose. This header is the single
// definition of the format; docs/blob_format.md mirrors it with a revision history.
//
// Layout (all integers little endian, all floats IEEE-754 binary32 little endian):
//
//   offset 0   BlobHeader (64 bytes)
//   offset 64  SectionEntry[section_count] (24 bytes each)
//   ...        sections, each starting at a multiple of kSectionAlignment (64) bytes, not
//              overlapping each other or the header, inside total_bytes; gaps are zero.
//
//   header_crc32  = CRC-32 (IEEE 802.3, reflected, poly 0xEDB88320) of bytes [0, header_bytes)
//                   computed with the header_crc32 field itself set to zero.
//   payload_crc32 = CRC-32 of bytes [header_bytes, total_bytes).
//
// Trees. Tree t has node_count[t] nodes (ForestMeta), numbered 1.. in breadth-first order, node 1 the
// root. A node is a split node (two children) or a leaf node; the tree is stored as one flag per
// node (kSplitFlags) and the split nodes' TreeNodes (kNodes). Everything else follows from the
// breadth-first order and is derived by the reader (for_each_tree_node in blob_loader.h):
//   - the k-th split node of a tree (in node order, k = 1..) has children 2k and 2k + 1;
//   - leaf node records are numbered in node order over the whole forest: the r-th leaf node met
//     (tree after tree, node order within a tree; r from 0) owns leaf record r;
//   - a traversal is exactly `depth` steps, child = left + [feature > threshold]; a walk that reaches
//     a leaf node above level `depth` stays on it (runtime copies give a leaf node its own index as
//     left child, the pad threshold and zero offsets, so the kernels need no branch).
// A valid tree: node_count odd (a full binary tree has 2S + 1 nodes for S split nodes), every node
// but the root is a split node's child, no split node at level ≥ depth (root level 0).
//
// Sections (each kind exactly once, kinds 1..7):
//   kMeta      ForestMeta: method, tree count, depth, per-tree node counts, part/joint counts and
//              names, reference focal length, leaf table shape, the maximum frame and arena size
//              computed by the converter.
//   kConfig    RuntimeConfig: per-joint aggregation parameters and the per-frame budget.
//   kNodes     Σ (node_count[t] − 1) / 2 TreeNode: tree t's split nodes in node order, after tree
//              t − 1's.
//   kSplitFlags Σ ⌈node_count[t] / 8⌉ bytes: tree t's flags from byte Σ_{s<t} ⌈node_count[s] / 8⌉;
//              node m's flag is bit (m − 1) % 8 of byte (m − 1) / 8, 1 = split node, 0 = leaf node;
//              the bits past node_count[t] in a tree's last byte are zero.
//   kLeafOffsets (leaf_count + 1) uint32: leaf record r owns entries [offsets[r], offsets[r + 1]);
//              offsets[0] = 0, non-decreasing, offsets[leaf_count] = entry_count. leaf_count is
//              the forest's leaf-node count, Σ (node_count[t] + 1) / 2.
//   kLeafEntries entry_count entries, leaf after leaf (compact leaves: only what a leaf holds):
//                BPC: uint16 probability_q15 (1..32768; a record's entries sum to ≤ 32768).
//                OJR: OjrVote (weight ≥ 1; |dx|,|dy|,|dz| ≤ kMaxVoteOffsetMm).
//   kEntryTags entry_count uint8, one per entry, strictly increasing within a record:
//                BPC: the entry's part (< part_count); OJR: its lane j·K + k (< joint_count·K),
//                i.e. joint j's k-th vote. A part or lane a record lacks has probability / weight 0.
//              So a record holds at most part_count (BPC) or joint_count·K (OJR) entries.
//
// Semantics of a node (runtime/fixed_point.h has the exact integer rule): feature =
// depth(probe 1) − depth(probe 2) with probe offsets du/dv in pixel·metres at
// ForestMeta::reference_focal_px; go right iff feature > threshold_mm.
#pragma once
#include <stddef.h>
#include <stdint.h>

namespace dp::blob {

constexpr uint32_t kMagic = 0x42465044u;      // "DPFB" read as little-endian bytes 'D''P''F''B'
constexpr uint32_t kEndianTag = 0x01020304u;  // reads 0x04030201 on a big-endian host
constexpr uint16_t kVersionMajor = 4;         // readers refuse any other major version (v1: dense leaves,
                                              // v2: complete heap-order trees, v3: stored child and
                                              // leaf indices and leaf nodes)
constexpr uint16_t kVersionMinor = 0;         // readers accept older and newer minors of their major
constexpr uint32_t kSectionAlignment = 64;

// Compile-time maxima; the loader refuses blobs beyond them, so the runtime can size arrays.
constexpr int kMaxTrees = 8;
constexpr int kMaxDepth = 20;
constexpr int kMaxParts = 32;
constexpr int kMaxJoints = 16;
constexpr int kMaxVotesPerLeafJoint = 4;      // K
constexpr int kMaxProbeOffsetPxm = 4096;      // |du|,|dv| bound (pixel·metres)
constexpr int kNameBytes = 24;                // NUL-padded ASCII names
constexpr int kMaxSections = 16;
constexpr int kMaxFrameDimension = 4096;

constexpr int16_t kPadThreshold = 32767;      // feature > 32767 is impossible: always left

enum class Method : uint8_t { kBpc = 1, kOjr = 2 };

enum class SectionKind : uint32_t {
  kMeta = 1,
  kConfig = 2,
  kNodes = 3,
  kSplitFlags = 4,
  kLeafOffsets = 5,
  kLeafEntries = 6,
  kEntryTags = 7,
};
constexpr uint32_t kSectionKinds = 7;  // kinds 1..kSectionKinds, each exactly once

struct BlobHeader {
  uint32_t magic;            // kMagic
  uint32_t endian_tag;       // kEndianTag
  uint16_t version_major;    // kVersionMajor
  uint16_t version_minor;    // kVersionMinor
  uint32_t header_bytes;     // 64 + 24 · section_count
  uint64_t total_bytes;      // whole blob
  uint32_t section_count;    // 1..kMaxSections
  uint32_t header_crc32;
  uint32_t payload_crc32;
  uint32_t flags;            // 0 in v4.0
  uint8_t reserved[24];      // zero
};
static_assert(sizeof(BlobHeader) == 64, "BlobHeader is 64 bytes on disk");

struct SectionEntry {
  uint32_t kind;             // SectionKind
  uint32_t reserved;         // zero
  uint64_t offset;           // from the start of the blob, multiple of kSectionAlignment
  uint64_t size;             // bytes
};
static_assert(sizeof(SectionEntry) == 24, "SectionEntry is 24 bytes on disk");

struct ForestMeta {
  uint8_t method;            // Method
  uint8_t tree_count;        // 1..kMaxTrees
  uint8_t depth;             // 1..kMaxDepth (number of split levels; leaves at level `depth`)
  uint8_t part_count;        // BPC: 1..kMaxParts; OJR: 0..kMaxParts (names only)
  uint8_t joint_count;       // 0..kMaxJoints (BPC ≥ 1 to produce proposals)
  uint8_t votes_per_joint;   // OJR: 1..kMaxVotesPerLeafJoint; BPC: 0
  uint16_t reserved0;
  float reference_focal_px;  // focal length the offsets are expressed for, > 0
  uint32_t leaf_count;       // leaf records = leaf nodes, Σ (node_count[t] + 1) / 2 (kLeafOffsets has
                             // leaf_count + 1 entries)
  uint32_t entry_count;      // kLeafEntries / kEntryTags length, ≤ leaf_count · max_entries_per_leaf
  uint32_t max_width;        // frame size the converter sized arena_bytes for
  uint32_t max_height;
  uint32_t max_abs_offset_pxm;  // largest |du|,|dv| in kNodes (≤ kMaxProbeOffsetPxm)
  uint64_t arena_bytes;      // required_arena_bytes(blob, max_width, max_height) at conversion
  uint32_t reserved1;        // zero
  uint32_t reserved2;        // zero
  char part_names[kMaxParts][kNameBytes];
  char joint_names[kMaxJoints][kNameBytes];
  // Nodes of tree t (odd, 1..max_nodes_per_tree(depth)) for t < tree_count; zero beyond. v1 and v2
  // metas end before this field (kLegacyMetaBytes).
  uint32_t node_count[kMaxTrees];
};
static_assert(sizeof(ForestMeta) == 48 + kMaxParts * kNameBytes + kMaxJoints * kNameBytes + 4 * kMaxTrees,
              "ForestMeta layout");
constexpr size_t kLegacyMetaBytes = offsetof(ForestMeta, node_count);  // a v1/v2 ForestMeta

struct TreeNode {
  int16_t du1, dv1, du2, dv2;  // probe offsets, pixel·metres at reference_focal_px
  int16_t threshold_mm;        // go right iff feature > threshold_mm
};
static_assert(sizeof(TreeNode) == 10, "TreeNode is 10 bytes on disk");

struct OjrVote {
  int16_t dx_mm, dy_mm, dz_mm;  // offset from the pixel's 3D point to the joint, camera frame
  uint16_t weight;              // relative vote weight (cluster size); 0 = no vote
};
static_assert(sizeof(OjrVote) == 8, "OjrVote is 8 bytes on disk");

struct JointConfig {
  uint32_t part_mask;           // BPC: bit c set ⇒ p(c|u) counts towards this joint
  uint16_t prob_threshold_q15;  // BPC λc: votes with p > λc are mean-shift starting points
  int16_t push_back_mm;         // BPC ζj: added to z of the pixel's 3D point
  uint16_t bandwidth_mm;        // mean-shift bandwidth b_j, > 0
  uint16_t vote_length_mm;      // OJR λj: votes with |offset| > λj are dropped (0 = no limit)
  uint32_t reserved;
};
static_assert(sizeof(JointConfig) == 16, "JointConfig layout");

struct RuntimeConfig {
  JointConfig joints[kMaxJoints];
  uint16_t near_mm;                // foreground band when no mask is given: near ≤ z ≤ far
  uint16_t far_mm;
  uint16_t max_votes_per_joint;    // Nsub: top-weighted votes kept per joint, 1..kMaxVotesCap
  uint16_t max_starts_per_joint;   // mean-shift starting points per joint, 1..kMaxStartsCap
  uint16_t mean_shift_iterations;  // per start, 1..kMaxMeanShiftIterations
  uint16_t max_proposals_per_joint;// 1..kMaxProposalsCap
  uint16_t merge_tolerance_mm;     // converged points closer than this form one proposal
  uint16_t reserved0;
  uint32_t max_evaluated_pixels;   // budget: above this, foreground pixels are strided
  uint32_t reserved1;
  uint64_t cycle_budget;           // per-frame budget in counter ticks (runtime/cycle_counter.h; 0 = none); overruns are flagged
};
static_assert(sizeof(RuntimeConfig) == 16 * kMaxJoints + 32, "RuntimeConfig layout");

constexpr int kMaxVotesCap = 1024;
constexpr int kMaxStartsCap = 256;
constexpr int kMaxMeanShiftIterations = 64;
constexpr int kMaxProposalsCap = 8;

// RuntimeConfig bounds: what the runtime can honour. The loader (validate_config) refuses a value
// outside them, so the runtime never checks them per frame.
constexpr uint32_t kProbabilityOneQ15 = 32768;  // prob_threshold_q15 ≤ 1.0
constexpr int kMaxPushBackMm = 500;             // |push_back_mm|: larger moves a joint out of the body
constexpr int kMaxBandwidthMm = 2000;           // bandwidth_mm 1..2000: a wider kernel spans the whole body
constexpr int kMaxVoteLengthMm = 4000;          // vote_length_mm 0..2·kMaxVoteOffsetMm (0 = no limit)
constexpr int kMaxMergeToleranceMm = 2000;      // merge_tolerance_mm 1..2000, as the bandwidth
// far_mm ≤ 32766: the runtime's background constant is 32767 mm (runtime/fixed_point.h), so a depth
// at or beyond it is never foreground whatever the band says.
constexpr int kMaxFarMm = 32766;
// max_evaluated_pixels 1..kMaxFrameDimension²: every pixel of the largest frame; the runtime
// counts and lists pixels in int32 and sizes its pixel arrays by min(frame, budget).
constexpr uint32_t kMaxEvaluatedPixels = uint32_t(kMaxFrameDimension) * uint32_t(kMaxFrameDimension);
// cycle_budget: any uint64 (0 = none); the budget model computes in uint64 with per-pixel costs
// ≥ 65 cycles, so no quotient it forms overflows int64.

// The most entries one leaf record can hold: its tags are strictly increasing below this.
inline constexpr int max_entries_per_leaf(const ForestMeta& m) {
  return m.method == uint8_t(Method::kBpc) ? int(m.part_count) : int(m.joint_count) * int(m.votes_per_joint);
}
// Bytes of one kLeafEntries entry.
inline constexpr size_t leaf_entry_bytes(const ForestMeta& m) {
  return m.method == uint8_t(Method::kBpc) ? sizeof(uint16_t) : sizeof(OjrVote);
}

// A tree of `depth` split levels has at most 2^depth leaf nodes and 2^(depth+1) − 1 nodes in all.
inline constexpr size_t leaves_per_tree(int depth) { return size_t(1) << depth; }
inline constexpr size_t max_nodes_per_tree(int depth) { return (size_t(2) << depth) - 1; }
// v1/v2 trees (and PCL's) are complete and in implicit heap order: nodes_per_heap(depth) split nodes
// (children of n at 2n+1, 2n+2), then leaves_per_tree(depth) leaf slots. Tools read them to upgrade.
inline constexpr size_t nodes_per_heap(int depth) { return (size_t(1) << depth) - 1; }

// A full binary tree of n (odd) nodes has (n − 1) / 2 split nodes and (n + 1) / 2 leaf nodes; its
// kSplitFlags take ⌈n / 8⌉ bytes.
inline constexpr uint32_t split_nodes_of(uint32_t node_count) { return (node_count - 1) / 2; }
inline constexpr uint32_t leaf_nodes_of(uint32_t node_count) { return (node_count + 1) / 2; }
inline constexpr uint32_t split_flag_bytes_of(uint32_t node_count) { return (node_count + 7) / 8; }

}  // namespace dp::blob
