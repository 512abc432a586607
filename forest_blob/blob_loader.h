// Validating, zero-copy blob loader (runtime side: no heap, no exceptions).
// load_blob() checks every field before forming any pointer into the bytes; after it returns
// BlobStatus::kOk the LoadedBlob views may be used without further checks. The caller owns the
// bytes and must keep them alive and unchanged while the LoadedBlob is used. Bytes must be at
// least 8-byte aligned (kBadAlignment otherwise).
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "forest_blob/blob_format.h"

namespace dp::blob {

enum class BlobStatus : int32_t {
  kOk = 0,
  kNullInput,
  kBadAlignment,        // data pointer not 8-byte aligned
  kTooSmall,            // fewer bytes than a header
  kBadMagic,
  kWrongEndianness,     // endian tag byte-swapped: written on a big-endian host
  kBadEndianTag,        // neither order of the tag
  kVersionTooOld,       // major version below ours (v1, v2, v3; `depthpose convert --upgrade-blob`)
  kVersionTooNew,       // major version above ours
  kBadHeaderSize,
  kTruncated,           // total_bytes larger than the bytes given
  kTrailingBytes,       // total_bytes smaller than the bytes given
  kHeaderChecksum,
  kPayloadChecksum,
  kBadSectionCount,
  kSectionMisaligned,
  kSectionOutOfBounds,
  kSectionOverlap,
  kSectionMissing,
  kSectionDuplicate,
  kUnknownSection,
  kBadSectionSize,      // a section's size disagrees with the counts in ForestMeta
  kBadMethod,
  kBadTreeCount,
  kBadDepth,
  kBadPartCount,
  kBadJointCount,
  kBadVotesPerJoint,
  kBadFocalLength,
  kBadLeafCount,         // leaf_count not the forest's leaf-node count
  kBadEntryCount,       // entry_count above leaf_count · max_entries_per_leaf
  kBadFrameSize,
  kBadName,             // a name not NUL terminated / not printable
  kOffsetTooLarge,      // |du|,|dv| beyond kMaxProbeOffsetPxm or max_abs_offset_pxm
  kBadLeafDistribution, // BPC entry probability 0, or a record's probabilities summing above 32768
  kBadVote,             // OJR vote weight 0 or component outside ±kMaxVoteOffsetMm
  kBadPartMask,         // joint part mask names a part ≥ part_count
  kBadConfig,           // a runtime config value outside its documented range
  kReservedNotZero,
  kEmpty,               // zero bytes given
  kBadLeafOffsets,      // leaf offsets not starting at 0, decreasing, or not ending at entry_count
  kBadEntryTag,         // an entry's part/lane out of range or not strictly increasing in its record
  kBadNodeCount,        // a tree's node count even, 0 or above max_nodes_per_tree(depth), or a count past tree_count not 0
  kBadChildIndex,       // a split node's children (2k, 2k + 1 for the k-th) lie outside its tree
  kTreeTooDeep,         // a split node at level ≥ depth: a walk of `depth` steps would not end on a leaf
  kUnreachedNode,       // a node that is no split node's child (the tree is shorter than its node count)
};

// One line naming the problem, for messages ("payload checksum mismatch").
const char* blob_status_message(BlobStatus status);

// Which field a refusal is about and the range it must lie in. Filled (when a pointer is given)
// for the field checks of ForestMeta and RuntimeConfig; `field` stays nullptr for structural
// statuses, whose message says everything. Strings are static.
struct BlobProblem {
  const char* field = nullptr;  // e.g. "config.max_evaluated_pixels", "config.joints[j].bandwidth_mm"
  int32_t joint = -1;           // the joint j of a per-joint field, else −1
  int64_t value = 0;            // the value found
  int64_t min = 0, max = 0;     // the accepted range, inclusive
};

constexpr int kMaxVoteOffsetMm = 2000;
static_assert(kMaxVoteLengthMm == 2 * kMaxVoteOffsetMm, "a vote length covers two maximal offsets");

struct LoadedBlob {
  const BlobHeader* header = nullptr;
  const ForestMeta* meta = nullptr;
  const RuntimeConfig* config = nullptr;
  // Trees (blob_format.h kNodes, kSplitFlags): tree t's split nodes from split_nodes +
  // tree_first_split[t], its flags from split_flags + tree_first_flag[t], its first leaf node's record
  // tree_first_leaf[t]. for_each_tree_node (below) walks a tree with children and records derived.
  const TreeNode* split_nodes = nullptr;
  const uint8_t* split_flags = nullptr;
  uint32_t tree_first[kMaxTrees] = {};        // tree t's first node in forest order (Σ earlier node counts):
                                              // where per-node tables of the whole forest hold tree t
  uint32_t tree_first_split[kMaxTrees] = {};  // Σ earlier split-node counts
  uint32_t tree_first_flag[kMaxTrees] = {};   // Σ earlier ⌈node_count / 8⌉
  uint32_t tree_first_leaf[kMaxTrees] = {};   // Σ earlier leaf-node counts
  size_t total_nodes = 0;                     // Σ node_count (< 2^24)
  const uint32_t* leaf_offsets = nullptr;  // leaf_count + 1, validated (blob_format.h kLeafOffsets)
  const uint8_t* leaf_entries = nullptr;   // entry_count · leaf_entry_bytes(*meta)
  const uint8_t* entry_tags = nullptr;     // entry_count: part (BPC) or lane j·K + k (OJR)

  Method method() const { return static_cast<Method>(meta->method); }
  int tree_count() const { return meta->tree_count; }
  int depth() const { return meta->depth; }
  uint32_t tree_node_count(int t) const { return meta->node_count[t]; }
  // Record `leaf` (< leaf_count) owns entries [leaf_first(leaf), leaf_first(leaf) + leaf_size(leaf)),
  // leaf_size ≤ max_entries_per_leaf(*meta) ≤ 64 (validated at load).
  uint32_t leaf_first(uint32_t leaf) const { return leaf_offsets[leaf]; }
  uint32_t leaf_size(uint32_t leaf) const { return leaf_offsets[leaf + 1] - leaf_offsets[leaf]; }
  const uint16_t* bpc_probabilities() const { return reinterpret_cast<const uint16_t*>(leaf_entries); }
  const OjrVote* ojr_votes() const { return reinterpret_cast<const OjrVote*>(leaf_entries); }
};

// A leaf node as traversal tables hold it: zero offsets and the pad threshold (always left), so a
// walk that reaches it stays on it.
constexpr TreeNode kLeafNode = {0, 0, 0, 0, kPadThreshold};

// Walks tree t of a loaded blob in node order, calling fn(m, node, left_child, record) for node
// m = 1..node_count: a split node with its TreeNode, its left child 2k (the k-th split node; right
// child 2k + 1) and record 0; a leaf node with kLeafNode, left child m itself and its leaf record.
// Bounded by the validated node count; every index it passes is in range.
template <class Fn>
inline void for_each_tree_node(const LoadedBlob& b, int t, Fn&& fn) {
  const uint8_t* flags = b.split_flags + b.tree_first_flag[t];
  const TreeNode* splits = b.split_nodes + b.tree_first_split[t];
  uint32_t k = 0, record = b.tree_first_leaf[t];
  const uint32_t count = b.meta->node_count[t];
  for (uint32_t m = 1; m <= count; ++m) {
    if ((flags[(m - 1) >> 3] >> ((m - 1) & 7)) & 1u) {
      fn(m, splits[k], 2 * (k + 1), uint32_t(0));
      ++k;
    } else {
      fn(m, kLeafNode, m, record++);
    }
  }
}

// The per-node tables of the whole forest (v3's stored form): node m of tree t at
// [tree_first[t] + m − 1] of nodes (kLeafNode for a leaf node), left_child (1-based within the
// tree; a leaf node's own index) and leaf_index (a leaf node's record, 0 for a split node). Each
// array holds total_nodes elements (caller-owned). Any of them may be nullptr (not filled).
void expand_tree_tables(const LoadedBlob& b, TreeNode* nodes, uint32_t* left_child, uint32_t* leaf_index);

// Adds BPC record `leaf`'s Q15 probabilities to acc[part] (acc: part_count counters). At most
// part_count additions, parts < part_count (validated at load).
inline void add_bpc_leaf(const LoadedBlob& b, uint32_t leaf, uint32_t* acc) {
  const uint32_t first = b.leaf_first(leaf), end = b.leaf_offsets[leaf + 1];
  const uint16_t* p = b.bpc_probabilities();
  for (uint32_t e = first; e < end; ++e) acc[b.entry_tags[e]] += p[e];
}

// Validates `size` bytes at `data` and fills `out` (untouched unless kOk). On a field refusal
// `problem` (optional) names the field, its value and its range.
BlobStatus load_blob(const void* data, size_t size, LoadedBlob* out, BlobProblem* problem = nullptr);

// Validates a RuntimeConfig against the meta (used by load_blob and by tools that edit configs):
// every field within the bounds in blob_format.h, which are what the runtime can honour.
BlobStatus validate_config(const ForestMeta& meta, const RuntimeConfig& config, BlobProblem* problem = nullptr);

uint32_t crc32(const void* data, size_t size, uint32_t crc = 0);

}  // namespace dp::blob
