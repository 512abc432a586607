// Cutting a trained forest back: to a smaller depth (truncate_structure), or where its training data
// is sparse (prune_forest), so a deep forest's blob fits a size budget. A forest is trained deep once
// and its size is chosen afterwards: `depthpose convert --min-leaf-pixels/--max-bytes` prunes a BPC
// forest, `depthpose train --structure F --structure-min-pixels/--structure-depth` an OJR structure.
#pragma once
#include <cstdint>
#include <vector>

#include "tools/train/forest_file.h"

namespace dp::train {

// Returns `forest` with every split node at level `depth` turned into a leaf and all deeper nodes
// dropped. Leaf records are renumbered in heap order and carry no leaf data (pixel counts zero, no
// distributions, no votes): the result is a structure for retro-fitting. Throws ToolError when
// depth < 1. A depth at or beyond the forest's own returns the structure unchanged (data dropped).
TrainedForest truncate_structure(const TrainedForest& forest, int depth);

struct PruneReport {
  uint64_t collapsed_splits = 0;     // split nodes turned into leaves (their descendants dropped)
  uint64_t leaves_before = 0, leaves_after = 0;  // over all trees
  int depth_before = 0, depth_after = 0;         // deepest leaf's level over all trees
};

// Returns `forest` with every split node whose subtree holds fewer than `min_pixels` training
// pixels (the sum of its leaves' leaf_pixel_counts) turned into a leaf and its descendants dropped;
// splits at or above the threshold stay as trained, so a pixel whose path crosses no collapsed node
// reaches the same leaf. min_pixels ≤ 1 changes nothing but empty subtrees. The collapsed leaf gets
// the subtree's pixel count and, when the forest has part distributions, the pixel-count-weighted
// mean of its leaves' distributions: distributions are normalized counts (leaf_models.cc
// fit_part_distributions), so this is the distribution of the subtree's pixels, exact up to float
// rounding (a subtree without pixels gets the zero distribution its empty leaves had). Leaf records
// are renumbered in heap order; `depth` (the requested depth) is kept. Deterministic.
// Throws ToolError for a forest with votes: OJR votes are mean-shift modes that cannot be merged
// (retro-fit them on a pruned structure instead: train --structure-min-pixels).
TrainedForest prune_forest(const TrainedForest& forest, uint64_t min_pixels, PruneReport* report = nullptr);

// Pruning to a leaf count by information gain ("weakest link first"): the order in which a
// forest's splits are collapsed so that each collapse loses the least training information. A
// split may be collapsed once both its children are leaves (trained or collapsed); its gain is
// N·H(p) − N_l·H(p_l) − N_r·H(p_r) in bits, where N are training pixels and p part distributions
// of the subtrees taken as single leaves (the distribution prune_forest would store). The split of
// smallest gain over the whole forest goes first (ties: lower tree, then lower heap position), so
// leaves stay where they separate parts — in any tree, at any pixel count — and splits whose
// children carry the same distribution go before small but informative ones. Orders are nested:
// the forest pruned to k leaves is the one pruned to k + 1 with one more split collapsed, so a
// blob's size falls with k. Deterministic. Throws ToolError for a forest with votes or without
// part distributions.
class GainPruneOrder {
 public:
  explicit GainPruneOrder(const TrainedForest& forest);  // keeps a reference: outlive it
  // `forest` with the first leaf_count() − max_leaves splits of the order collapsed (prune_forest's
  // leaf merging and renumbering). max_leaves ≥ the number of trees (ToolError otherwise).
  TrainedForest prune_to(uint64_t max_leaves, PruneReport* report = nullptr) const;
  uint64_t leaf_count() const { return leaves_before_; }
  uint64_t min_leaves() const { return forest_->trees.size(); }

 private:
  struct Step {
    uint32_t tree, pos;  // the split collapsed: tree, position in its nodes
  };
  const TrainedForest* forest_;
  uint64_t leaves_before_ = 0;
  std::vector<Step> order_;
};

// prune_forest on a retro-fitting structure: the votes of an OJR forest are ignored (its pixel
// counts decide), and the result carries no leaf data, like truncate_structure's. Throws ToolError
// when min_pixels < 1.
TrainedForest prune_structure(const TrainedForest& forest, uint64_t min_pixels, PruneReport* report = nullptr);

// GainPruneOrder on a retro-fitting structure with part distributions (a BPC forest): pruned to
// max_leaves leaves over all trees, returned without leaf data like truncate_structure's. Throws
// ToolError for a forest without part distributions or max_leaves below the number of trees.
TrainedForest prune_structure_by_gain(const TrainedForest& forest, uint64_t max_leaves, PruneReport* report = nullptr);

// The largest subtree pixel count of any split node (+1: the min_pixels that collapses every tree
// to its root), i.e. the upper end of a search over prune_forest's min_pixels.
uint64_t prune_everything_threshold(const TrainedForest& forest);

}  // namespace dp::train
