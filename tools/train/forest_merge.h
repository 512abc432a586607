// Merging trained forests: the trees of independent training runs (other seeds, other machines,
// at other times) concatenated into one forest. A random forest's trees are trained independently
// of each other, so a forest of T trees can be grown as T one-tree runs of `depthpose train` (each
// resumable on its own, each within a batch system's time limit) and merged afterwards:
// `depthpose train --merge A.forest,B.forest --out AB.forest`.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "tools/train/forest_file.h"

namespace dp::train {

// A tree's identity: the seed of its run and its index in that run. Every random draw of a grown
// tree is keyed by (seed, tree index) (training_set.cc, tree_trainer.cc), so two trees with one key,
// trained on the same data with the same options, are the same tree.
struct TreeKey {
  uint64_t seed = 0;
  uint64_t tree = 0;
  bool operator==(const TreeKey& o) const { return seed == o.seed && tree == o.tree; }
};

// The keys of `forest`'s trees, in order, from its training configuration: "tree_keys" (a merged
// forest) or "seed" and "trees" (one run). Throws ToolError naming `what` when the configuration
// holds neither, or disagrees with the number of trees.
std::vector<TreeKey> tree_keys(const TrainedForest& forest, const std::string& what);

// The forest whose trees are inputs[0]'s, then inputs[1]'s, ... (each tree with its leaf data, as
// read). Its training configuration is the inputs' with "seed" replaced by "tree_keys" (one
// {"seed", "tree"} object per tree), "trees" the total and "training_pixels" the sum; its timings are
// the inputs' summed ("bytes_per_training_pixel": the largest). Throws ToolError, naming the inputs
// (`names`, one per input) and what differs, when fewer than two forests are given, when they differ
// in method, reference focal length, requested depth, part or joint names, leaf data (distributions,
// votes per joint), training data (the datasets' identity) or any training option but the seed, or
// when two trees have the same key (the same tree twice).
TrainedForest merge_forests(const std::vector<TrainedForest>& inputs, const std::vector<std::string>& names);

}  // namespace dp::train
