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
  kVersionTooOld,       // major version below ours (v1, v2; `depthpose convert --upgrade-blob`)
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
  kBadLeafCount,
  kBadEntryCount,       // entry_count above leaf_count · max_entries_per_leaf
  kBadFrameSize,
  kBadName,             // a name not NUL terminated / not printable
  kOffsetTooLarge,      // |du|,|dv| beyond kMaxProbeOffsetPxm or max_abs_offset_pxm
  kBadLeafIndex,        // a leaf-index entry ≥ leaf_count
  kBadLeafDistribution, // BPC entry probability 0, or a record's probabilities summing above 32768
  kBadVote,             // OJR vote weight 0 or component outside ±kMaxVoteOffsetMm
  kBadPartMask,         // joint part mask names a part ≥ part_count
  kBadConfig,           // a runtime config value outside its documented range
  kReservedNotZero,
  kEmpty,               // zero bytes given
  kBadLeafOffsets,      // leaf offsets not starting at 0, decreasing, or not ending at entry_count
  kBadEntryTag,         // an entry's part/lane out of range or not strictly increasing in its record
  kBadNodeCount,        // a tree's node count 0 or above max_nodes_per_tree(depth), or a count past tree_count not 0
  kBadChildIndex,       // a left child index ≥ the tree's node count (its right child would lie outside)
  kChildBeforeParent,   // a split node's left child index not above its own (a cycle)
  kNotBreadthFirst,     // the k-th split node's children are not nodes 2k, 2k + 1
  kTreeTooDeep,         // a split node at level ≥ depth: a walk of `depth` steps would not end on a leaf
  kUnreachedNode,       // a node that is no split node's child (the tree is shorter than its node count)
  kBadLeafNode,         // a leaf node (left child = itself) without the pad threshold or with nonzero offsets
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
  // Tree t's nodes (blob_format.h kNodes), its leaf-record and left-child indices, node m at [m − 1]
  // of tree_nodes(t), tree_leaf_index(t), tree_left_child(t); tree_node_count(t) of each.
  const TreeNode* nodes = nullptr;
  const uint32_t* leaf_index = nullptr;
  const uint32_t* left_child = nullptr;
  uint32_t tree_first[kMaxTrees] = {};   // tree t's first node in the three arrays
  size_t total_nodes = 0;                // Σ node_count
  const uint32_t* leaf_offsets = nullptr;  // leaf_count + 1, validated (blob_format.h kLeafOffsets)
  const uint8_t* leaf_entries = nullptr;   // entry_count · leaf_entry_bytes(*meta)
  const uint8_t* entry_tags = nullptr;     // entry_count: part (BPC) or lane j·K + k (OJR)

  Method method() const { return static_cast<Method>(meta->method); }
  int tree_count() const { return meta->tree_count; }
  int depth() const { return meta->depth; }
  uint32_t tree_node_count(int t) const { return meta->node_count[t]; }
  const TreeNode* tree_nodes(int t) const { return nodes + tree_first[t]; }
  const uint32_t* tree_leaf_index(int t) const { return leaf_index + tree_first[t]; }
  const uint32_t* tree_left_child(int t) const { return left_child + tree_first[t]; }
  // Record `leaf` (< leaf_count) owns entries [leaf_first(leaf), leaf_first(leaf) + leaf_size(leaf)),
  // leaf_size ≤ max_entries_per_leaf(*meta) ≤ 64 (validated at load).
  uint32_t leaf_first(uint32_t leaf) const { return leaf_offsets[leaf]; }
  uint32_t leaf_size(uint32_t leaf) const { return leaf_offsets[leaf + 1] - leaf_offsets[leaf]; }
  const uint16_t* bpc_probabilities() const { return reinterpret_cast<const uint16_t*>(leaf_entries); }
  const OjrVote* ojr_votes() const { return reinterpret_cast<const OjrVote*>(leaf_entries); }
};

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
