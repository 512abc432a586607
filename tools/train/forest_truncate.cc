#include "tools/train/forest_truncate.h"

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

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

namespace dp::train {
namespace {

// Training pixels below each node (positions in tree.nodes): children sit after their parent in
// heap order, so one backward sweep sums them.
std::vector<uint64_t> subtree_pixels(const TrainedTree& tree) {
  std::vector<uint64_t> pixels(tree.nodes.size(), 0);
  for (size_t i = tree.nodes.size(); i-- > 0;) {
    const TrainedNode& n = tree.nodes[i];
    pixels[i] = n.is_leaf() ? tree.leaf_pixel_counts[size_t(n.leaf)] : pixels[size_t(n.left)] + pixels[size_t(n.right)];
  }
  return pixels;
}

int deepest_leaf(const TrainedForest& forest) {
  int depth = 0;
  for (const TrainedTree& t : forest.trees) depth = std::max(depth, t.max_leaf_level());
  return depth;
}

}  // namespace

TrainedForest prune_forest(const TrainedForest& in, uint64_t min_pixels, PruneReport* report) {
  if (in.has_votes)
    tools::fail("cannot prune an OJR forest's leaves: its votes are mean-shift modes that do not merge; prune the "
                "structure before retro-fitting (depthpose train --structure F --structure-min-pixels N)");
  PruneReport rep;
  rep.depth_before = deepest_leaf(in);
  TrainedForest out = in;
  const size_t parts = in.has_part_distributions ? in.part_names.size() : 0;
  for (size_t t = 0; t < in.trees.size(); ++t) {
    const TrainedTree& tree = in.trees[t];
    const std::vector<uint64_t> pixels = subtree_pixels(tree);
    // owner[i]: position of the kept leaf that node i falls into, or -1 for a kept split node.
    std::vector<int64_t> owner(tree.nodes.size(), -1);
    auto place = [&](size_t i) {
      const TrainedNode& n = tree.nodes[i];
      const bool collapse = !n.is_leaf() && pixels[i] < min_pixels;
      if (collapse) ++rep.collapsed_splits;
      owner[i] = (n.is_leaf() || collapse) ? int64_t(i) : -1;
    };
    place(0);
    TrainedTree& pruned = out.trees[t];
    pruned.nodes.clear();
    std::vector<int32_t> record_of(tree.nodes.size(), -1);  // kept leaf position → new record
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
      const TrainedNode& n = tree.nodes[i];
      if (owner[i] == int64_t(i) || owner[i] == -1) {  // kept: a leaf (maybe collapsed) or a split
        pruned.nodes.push_back(n);
      }
      if (!n.is_leaf()) {
        for (const int32_t c : {n.left, n.right}) {
          if (owner[i] == -1) place(size_t(c));
          else owner[size_t(c)] = owner[i];
        }
      }
    }
    // Number the kept leaves in heap order and merge the trained leaves into them.
    int32_t records = 0;
    for (size_t i = 0, k = 0; i < tree.nodes.size(); ++i) {
      if (owner[i] != int64_t(i) && owner[i] != -1) continue;
      TrainedNode& kept = pruned.nodes[k++];
      if (owner[i] == int64_t(i)) {
        record_of[i] = records;
        if (!kept.is_leaf()) kept = TrainedNode{kept.heap_index};  // a collapsed split: no feature
        kept.leaf = records++;
      }
    }
    std::vector<uint64_t> counts(size_t(records), 0);
    std::vector<double> mass(size_t(records) * parts, 0.0);
    std::vector<int64_t> kept_leaf(size_t(records), -1);  // record → its trained leaf, if not merged
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
      const TrainedNode& n = tree.nodes[i];
      if (!n.is_leaf()) continue;
      const size_t r = size_t(record_of[size_t(owner[i])]);
      const uint32_t count = tree.leaf_pixel_counts[size_t(n.leaf)];
      counts[r] += count;
      if (owner[i] == int64_t(i)) {  // a trained leaf kept as it is: its distribution copied exactly
        kept_leaf[r] = int64_t(n.leaf);
        continue;
      }
      for (size_t c = 0; c < parts; ++c)
        mass[r * parts + c] += double(count) * double(tree.part_probabilities[size_t(n.leaf) * parts + c]);
    }
    pruned.leaf_pixel_counts.assign(size_t(records), 0);
    pruned.part_probabilities.assign(size_t(records) * parts, 0.0f);
    for (size_t r = 0; r < size_t(records); ++r) {
      if (counts[r] > UINT32_MAX)
        tools::fail("prune: tree " + std::to_string(t) + " has a subtree of " + std::to_string(counts[r]) +
                    " training pixels; a leaf counts at most 2^32 - 1");
      pruned.leaf_pixel_counts[r] = uint32_t(counts[r]);
      const double n = double(counts[r]);
      if (kept_leaf[r] >= 0)
        std::copy_n(tree.part_probabilities.begin() + kept_leaf[r] * int64_t(parts), parts,
                    pruned.part_probabilities.begin() + int64_t(r * parts));
      else if (n > 0)
        for (size_t c = 0; c < parts; ++c) pruned.part_probabilities[r * parts + c] = float(mass[r * parts + c] / n);
    }
    rep.leaves_before += tree.leaf_count();
    rep.leaves_after += size_t(records);
  }
  link_and_validate(out, "pruned forest");
  rep.depth_after = deepest_leaf(out);
  if (report) *report = rep;
  return out;
}

TrainedForest prune_structure(const TrainedForest& in, uint64_t min_pixels, PruneReport* report) {
  if (min_pixels < 1) tools::fail("structure min pixels must be >= 1, got " + std::to_string(min_pixels));
  TrainedForest counts_only = in;
  counts_only.has_votes = false;
  counts_only.votes_per_joint = 0;
  for (TrainedTree& t : counts_only.trees) t.votes.clear();
  const TrainedForest pruned = prune_forest(counts_only, min_pixels, report);
  return truncate_structure(pruned, std::max(1, pruned.depth));
}

uint64_t prune_everything_threshold(const TrainedForest& forest) {
  uint64_t most = 0;
  for (const TrainedTree& t : forest.trees) {
    uint64_t root = 0;
    for (uint32_t c : t.leaf_pixel_counts) root += c;
    most = std::max(most, root);
  }
  return most + 1;
}

}  // namespace dp::train
