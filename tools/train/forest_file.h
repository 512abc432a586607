// The trained-forest file (*.forest): the full-precision output of `depthpose train`, the input
// of `depthpose convert` (which packs it into the runtime blob) and of `depthpose info`.
// docs/forest_file.md is the byte-level specification; this header is its in-memory model.
//
// Layout (little endian; floats IEEE-754 binary32):
//   0   char[4]  magic "DPTF"
//   4   uint32   endian tag 0x01020304
//   8   uint16   version major (1), uint16 version minor (0)
//   12  uint32   J = header JSON bytes
//   16  J bytes  UTF-8 JSON object: method, reference_focal_px, depth, parts, joints,
//                votes_per_joint, has_part_distributions, has_votes, tree_count, training (the
//                configuration), datasets (identity), timings
//   then tree_count times:
//       uint32 node_count, uint32 leaf_count
//       node_count × 20-byte node: uint32 heap_index, int16 du1 dv1 du2 dv2, float threshold_mm,
//                                  uint32 leaf (0xFFFFFFFF = split node)
//       leaf_count × uint32 pixel_count (training pixels that reached the leaf)
//       if has_part_distributions: leaf_count × part_count float   (each row sums to 1)
//       if has_votes: leaf_count × joint_count × votes_per_joint × {float dx, dy, dz, weight}
//   last 4 bytes: uint32 CRC-32 (zlib) of every byte before it.
//
// Semantics of a split node (runtime/fixed_point.h is the exact rule): the probe offsets are
// pixel·metres at reference_focal_px; a pixel goes to the right child (heap 2n+2) iff
// feature_mm > threshold_mm, else to the left child (2n+1). Thresholds are whole numbers in
// [-32768, 32767], so the float comparison and the runtime's int16 comparison agree exactly.
#pragma once
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace dp::train {

constexpr char kForestMagic[4] = {'D', 'P', 'T', 'F'};
constexpr uint32_t kForestEndianTag = 0x01020304u;
constexpr uint16_t kForestVersionMajor = 1;
constexpr uint16_t kForestVersionMinor = 0;
constexpr uint32_t kSplitMarker = 0xFFFFFFFFu;
constexpr int kMaxForestDepth = 24;  // heap indices stay below 2^25

// A relative vote: offset from the pixel's 3D point to the joint, metres, camera frame
// (x right, y up, z forward). weight = size of the mean-shift cluster; 0 = no vote.
struct LeafVote {
  float dx = 0, dy = 0, dz = 0, weight = 0;
};

struct TrainedNode {
  uint32_t heap_index = 0;           // root 0; children of n are 2n+1 (left), 2n+2 (right)
  int16_t du1 = 0, dv1 = 0, du2 = 0, dv2 = 0;  // pixel·metres at the reference focal length
  float threshold_mm = 0;            // whole number in int16 range
  int32_t leaf = -1;                 // leaf record index; -1 for a split node
  int32_t left = -1, right = -1;     // positions in TrainedTree::nodes; -1 for a leaf
  bool is_leaf() const { return leaf >= 0; }
};

struct TrainedTree {
  std::vector<TrainedNode> nodes;             // sorted by heap_index; nodes[0] is the root
  std::vector<uint32_t> leaf_pixel_counts;    // per leaf record
  std::vector<float> part_probabilities;      // leaf × part_count, when has_part_distributions
  std::vector<LeafVote> votes;                // leaf × joint_count × votes_per_joint, when has_votes
  size_t leaf_count() const { return leaf_pixel_counts.size(); }
  int max_leaf_level() const;                 // deepest leaf's level (root = 0)
};

struct TrainedForest {
  std::string method = "bpc";                 // "bpc" or "ojr"
  float reference_focal_px = 0;               // focal length the offsets are expressed for
  int depth = 0;                              // requested maximum depth: leaves at level ≤ depth
  std::vector<std::string> part_names;
  std::vector<std::string> joint_names;
  int votes_per_joint = 0;                    // K, > 0 iff has_votes
  bool has_part_distributions = false;
  bool has_votes = false;
  std::string training_json = "{}";           // configuration (JSON object text)
  std::string datasets_json = "[]";           // dataset identity (JSON array text)
  std::string timings_json = "{}";            // seconds per phase (JSON object text)
  std::vector<TrainedTree> trees;
};

// Recomputes TrainedNode::left/right from heap indices and checks the structure: heap indices
// strictly increasing from 0, every split node has both children, every other node has a split
// parent, leaf records used exactly once, levels ≤ depth, thresholds whole and in int16 range,
// leaf data sizes consistent. Throws ToolError naming `what` (a file name) and the tree.
void link_and_validate(TrainedForest& forest, const std::string& what);

// Serialization. write_forest throws ToolError when the file cannot be written. read_forest
// throws ToolError naming the file for a missing, truncated, corrupt (CRC), wrong-version or
// inconsistent file. The in-memory forms are for tests and tools that keep it in memory.
std::vector<uint8_t> serialize_forest(const TrainedForest& forest);
TrainedForest parse_forest(const uint8_t* data, size_t size, const std::string& what);
void write_forest(const std::string& path, const TrainedForest& forest);
TrainedForest read_forest(const std::string& path);

// Human-readable summary (for `depthpose info`): method, trees, nodes, leaves, depths, names,
// configuration, datasets and timings.
void describe_forest(const TrainedForest& forest, std::ostream& out);

// ---- Reference evaluation (scalar, exact runtime rule) -----------------------------------------
// The probe image of a frame: the depth (mm) of foreground pixels, kBackgroundDepthMm elsewhere.
// Foreground = 0 < depth < kBackgroundDepthMm and, when `parts` is given, parts != 255.
std::vector<uint16_t> make_probe_image(const uint16_t* depth, const uint8_t* parts_or_null,
                                       int width, int height);

// Walks `tree` for foreground pixel (u, v) of a probe image (its own probe value is its depth) in a
// frame whose focal_factor is dp::focal_factor_mm(frame_focal, reference_focal). Returns the
// position in tree.nodes of the leaf reached.
int leaf_node_for_pixel(const TrainedTree& tree, const uint16_t* probe_image, int width,
                        int height, int u, int v, int32_t focal_factor);

// The blob pads every leaf above `depth` with always-left nodes; this is the heap slot at level
// `depth` (0-based among the 2^depth slots of that level) that such a traversal ends in.
uint32_t padded_leaf_slot(uint32_t heap_index, int depth);

// Level of a heap index (root 0).
int heap_level(uint32_t heap_index);

}  // namespace dp::train
