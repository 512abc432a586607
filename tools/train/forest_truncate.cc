#include "tools/train/forest_truncate.h"

#include <string>

#include "tools/common/error.h"

namespace dp::train {

TrainedForest truncate_structure(const TrainedForest& in, int depth) {
  if (depth < 1) tools::fail("structure depth must be >= 1, got " + std::to_string(depth));
  TrainedForest out = in;
  out.depth = depth < in.depth ? depth : in.depth;
  out.has_part_distributions = false;
  out.has_votes = false;
  out.votes_per_joint = 0;
  for (TrainedTree& tree : out.trees) {
    std::vector<TrainedNode> kept;
    kept.reserve(tree.nodes.size());
    uint32_t leaves = 0;
    for (TrainedNode n : tree.nodes) {  // heap order: parents before children
      const int level = heap_level(n.heap_index);
      if (level > out.depth) continue;
      if (level == out.depth || n.is_leaf()) n.leaf = static_cast<int32_t>(leaves++);
      kept.push_back(n);
    }
    tree.nodes = std::move(kept);
    tree.leaf_pixel_counts.assign(leaves, 0);
    tree.part_probabilities.clear();
    tree.votes.clear();
  }
  link_and_validate(out, "truncated structure");
  return out;
}

}  // namespace dp::train
