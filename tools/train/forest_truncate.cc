#include "tools/train/forest_truncate.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <queue>
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

// The pruning itself: every split node i of tree t with collapse[t][i] set, reached from the root
// through kept splits only, becomes a leaf holding its subtree's pixels (see prune_forest).
static TrainedForest prune_where(const TrainedForest& in, const std::vector<std::vector<uint8_t>>& collapse,
                                 PruneReport* report) {
  if (in.has_votes)
    tools::fail("cannot prune an OJR forest's leaves: its votes are mean-shift modes that do not merge; prune the "
                "structure before retro-fitting (depthpose train --structure F --structure-min-pixels N)");
  PruneReport rep;
  rep.depth_before = deepest_leaf(in);
  TrainedForest out = in;
  const size_t parts = in.has_part_distributions ? in.part_names.size() : 0;
  for (size_t t = 0; t < in.trees.size(); ++t) {
    const TrainedTree& tree = in.trees[t];
    // owner[i]: position of the kept leaf that node i falls into, or -1 for a kept split node.
    std::vector<int64_t> owner(tree.nodes.size(), -1);
    auto place = [&](size_t i) {
      const TrainedNode& n = tree.nodes[i];
      const bool collapsed = !n.is_leaf() && collapse[t][i];
      if (collapsed) ++rep.collapsed_splits;
      owner[i] = (n.is_leaf() || collapsed) ? int64_t(i) : -1;
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

TrainedForest prune_forest(const TrainedForest& in, uint64_t min_pixels, PruneReport* report) {
  std::vector<std::vector<uint8_t>> collapse(in.trees.size());
  for (size_t t = 0; t < in.trees.size(); ++t) {
    const std::vector<uint64_t> pixels = subtree_pixels(in.trees[t]);
    collapse[t].resize(pixels.size());
    for (size_t i = 0; i < pixels.size(); ++i) collapse[t][i] = pixels[i] < min_pixels;
  }
  return prune_where(in, collapse, report);
}

GainPruneOrder::GainPruneOrder(const TrainedForest& forest) : forest_(&forest) {
  if (forest.has_votes)
    tools::fail("cannot prune an OJR forest's leaves by gain: its votes are mean-shift modes that do not merge; "
                "prune the structure before retro-fitting (depthpose train --structure F --structure-min-pixels N)");
  if (!forest.has_part_distributions)
    tools::fail("pruning by gain needs the leaves' part distributions (a BPC forest or an OJR structure with them)");
  const size_t parts = forest.part_names.size();
  // cost[t][i] = N·H(p) in bits for node i's whole subtree taken as one leaf: N its training pixels,
  // p their part distribution (the pixel-weighted mean of its leaves' distributions, exactly what
  // prune_where stores in a collapsed leaf).
  std::vector<std::vector<double>> cost(forest.trees.size());
  for (size_t t = 0; t < forest.trees.size(); ++t) {
    const TrainedTree& tree = forest.trees[t];
    leaves_before_ += tree.leaf_count();
    std::vector<double> mass(tree.nodes.size() * parts, 0.0);  // per node: pixels of each part
    cost[t].assign(tree.nodes.size(), 0.0);
    for (size_t i = tree.nodes.size(); i-- > 0;) {  // children sit after their parent in heap order
      const TrainedNode& n = tree.nodes[i];
      double* m = &mass[i * parts];
      if (n.is_leaf()) {
        const double count = tree.leaf_pixel_counts[size_t(n.leaf)];
        for (size_t c = 0; c < parts; ++c) m[c] = count * double(tree.part_probabilities[size_t(n.leaf) * parts + c]);
      } else {
        for (size_t c = 0; c < parts; ++c) m[c] = mass[size_t(n.left) * parts + c] + mass[size_t(n.right) * parts + c];
      }
      double total = 0, h = 0;
      for (size_t c = 0; c < parts; ++c) total += m[c];
      for (size_t c = 0; c < parts; ++c)
        if (m[c] > 0) h -= m[c] * std::log2(m[c] / total);
      cost[t][i] = h;  // Σ_c m_c·log2(total/m_c) = N·H(p) when Σ m = N
    }
  }
  // Weakest link first: a split can go once both children are leaves; each collapse removes one
  // leaf record. Greedy over the whole forest, so the budget goes to whichever tree gains most.
  struct Candidate {
    double gain;
    uint32_t tree;
    uint32_t pos;
    bool operator>(const Candidate& o) const {
      if (gain != o.gain) return gain > o.gain;
      if (tree != o.tree) return tree > o.tree;
      return pos > o.pos;
    }
  };
  std::priority_queue<Candidate, std::vector<Candidate>, std::greater<Candidate>> queue;
  std::vector<std::vector<int32_t>> parent(forest.trees.size());
  std::vector<std::vector<uint8_t>> is_leaf_now(forest.trees.size());
  const auto gain_of = [&](size_t t, size_t i) {
    const TrainedNode& n = forest.trees[t].nodes[i];
    return cost[t][i] - cost[t][size_t(n.left)] - cost[t][size_t(n.right)];
  };
  for (size_t t = 0; t < forest.trees.size(); ++t) {
    const TrainedTree& tree = forest.trees[t];
    parent[t].assign(tree.nodes.size(), -1);
    is_leaf_now[t].assign(tree.nodes.size(), 0);
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
      const TrainedNode& n = tree.nodes[i];
      is_leaf_now[t][i] = n.is_leaf();
      if (!n.is_leaf()) parent[t][size_t(n.left)] = parent[t][size_t(n.right)] = int32_t(i);
    }
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
      const TrainedNode& n = tree.nodes[i];
      if (!n.is_leaf() && tree.nodes[size_t(n.left)].is_leaf() && tree.nodes[size_t(n.right)].is_leaf())
        queue.push(Candidate{gain_of(t, i), uint32_t(t), uint32_t(i)});
    }
  }
  order_.reserve(leaves_before_);
  while (!queue.empty()) {
    const Candidate c = queue.top();
    queue.pop();
    order_.push_back({c.tree, c.pos});
    is_leaf_now[c.tree][c.pos] = 1;
    const int32_t p = parent[c.tree][c.pos];
    if (p < 0) continue;
    const TrainedNode& pn = forest.trees[c.tree].nodes[size_t(p)];
    if (is_leaf_now[c.tree][size_t(pn.left)] && is_leaf_now[c.tree][size_t(pn.right)])
      queue.push(Candidate{gain_of(c.tree, size_t(p)), c.tree, uint32_t(p)});
  }
}

TrainedForest GainPruneOrder::prune_to(uint64_t max_leaves, PruneReport* report) const {
  const TrainedForest& in = *forest_;
  const uint64_t floor_leaves = in.trees.size();
  if (max_leaves < floor_leaves)
    tools::fail("cannot prune to " + std::to_string(max_leaves) + " leaves: each of the " +
                std::to_string(in.trees.size()) + " trees keeps at least its root");
  std::vector<std::vector<uint8_t>> collapse(in.trees.size());
  for (size_t t = 0; t < in.trees.size(); ++t) collapse[t].assign(in.trees[t].nodes.size(), 0);
  const uint64_t steps = max_leaves >= leaves_before_ ? 0 : std::min<uint64_t>(leaves_before_ - max_leaves, order_.size());
  for (uint64_t s = 0; s < steps; ++s) collapse[order_[s].tree][order_[s].pos] = 1;
  return prune_where(in, collapse, report);
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

TrainedForest prune_structure_by_gain(const TrainedForest& in, uint64_t max_leaves, PruneReport* report) {
  if (in.has_votes)
    tools::fail("--structure-max-leaves prunes by the part distributions of a BPC forest; this structure is an OJR "
                "forest (use --structure-min-pixels)");
  const GainPruneOrder order(in);
  const TrainedForest pruned = order.prune_to(max_leaves, report);
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
