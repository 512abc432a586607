// Blob writer (tools side: may allocate, throws dp::tools::ToolError on invalid contents).
// Produces byte-identical output for identical input: fixed section order, zeroed padding and
// reserved fields, no timestamps. dp::blob::load_blob() always accepts the result.
// The contents are given dense (every part / every (joint, k) vote of every leaf); the writer stores
// them compactly, without loss: a BPC probability of 0 and an OJR vote of weight 0 are simply not
// stored (blob_format.h). Dropping small parts or long votes is the converter's choice, not the writer's.
// Trees are given with explicit child and record tables (v3's form, which tools edit); the writer
// stores what v4 keeps of them (split flags and split nodes) and numbers records by leaf node, so a
// record two leaf nodes read is stored twice and one no leaf node reads is dropped. Every pixel
// reaches the same leaf contents as the tables say.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "forest_blob/blob_format.h"
#include "forest_blob/blob_loader.h"

namespace dp::blob {

struct BlobContents {
  Method method = Method::kBpc;
  int depth = 1;
  float reference_focal_px = 525.0f;
  std::vector<std::string> part_names;   // ≤ kMaxParts, each < kNameBytes
  std::vector<std::string> joint_names;  // ≤ kMaxJoints
  int votes_per_joint = 0;               // OJR K
  // Per tree, sparse: the nodes in breadth-first order (the k-th split node's children at 2k, 2k + 1),
  // each node's leaf record (0 for a split node) and left child (itself for a leaf node, which is
  // kLeafNode); node m at [m − 1]. append_heap_tree builds them from a complete heap-order tree;
  // dense_contents from a loaded blob (for_each_tree_node).
  std::vector<std::vector<TreeNode>> tree_nodes;
  std::vector<std::vector<uint32_t>> tree_leaf_index;
  std::vector<std::vector<uint32_t>> tree_left_child;
  // Leaf table, dense: BPC: leaf_count × part_count Q15 probabilities; OJR: leaf_count × joints × K
  // votes (weight 0 = no vote).
  std::vector<uint16_t> bpc_leaves;
  std::vector<OjrVote> ojr_leaves;
  RuntimeConfig config{};
  uint32_t max_width = 640, max_height = 480;  // arena_bytes is computed for this frame size
};

// Appends a tree given complete, in implicit heap order (v2's layout: nodes_per_heap(depth) nodes,
// children of n at 2n+1, 2n+2; leaves_per_tree(depth) leaf slots, slot s = leaf of heap node
// 2^depth − 1 + s) to c's trees in sparse form, without loss: a node with threshold kPadThreshold
// always goes left, so it becomes a leaf node holding the record of the leftmost slot below it, and
// its subtree is dropped. Every pixel reaches the same record as in the heap tree.
void append_heap_tree(BlobContents* c, const std::vector<TreeNode>& heap_nodes, const std::vector<uint32_t>& slot_leaf_index);

// Serializes, computing header, CRCs, max_abs_offset_pxm, leaf_count and arena_bytes. ToolError when
// a tree is not breadth first (above) or a leaf node reads a record the table lacks.
std::vector<uint8_t> write_blob(const BlobContents& contents);

// The dense contents of a loaded blob (missing parts / votes as zeros): write_blob(dense_contents(b))
// reproduces b's bytes.
BlobContents dense_contents(const LoadedBlob& b);

// Sets c's dense leaf table (bpc_leaves or ojr_leaves, by m.method) from compact leaves: m.leaf_count
// records, offsets/entries/tags as blob_format.h kLeafOffsets/kLeafEntries/kEntryTags. The caller
// has checked offsets (non-decreasing, ending at m.entry_count) and tags (< max_entries_per_leaf(m)).
void add_dense_leaves(const ForestMeta& m, const uint32_t* offsets, const uint8_t* entries, const uint8_t* tags,
                      BlobContents* c);

// A RuntimeConfig with the documented defaults (docs/blob_format.md) for `joint_count` joints.
RuntimeConfig default_runtime_config(int joint_count);

// File helpers. save writes to a temporary file then renames (never leaves a half-written blob).
void save_blob_file(const std::string& path, const std::vector<uint8_t>& bytes);
std::vector<uint8_t> read_blob_file(const std::string& path);  // ToolError when unreadable

}  // namespace dp::blob
