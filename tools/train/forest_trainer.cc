#include "tools/train/forest_trainer.h"

#include <chrono>
#include <nlohmann/json.hpp>

#include "tools/common/error.h"

namespace dp::train {
using tools::fail;

TrainedForest train_forest(const TrainingSet& set, const ForestOptions& options, const ProgressFn& progress,
                           ForestStats* stats_out) {
  ForestStats stats;
  if (options.method != "bpc" && options.method != "ojr") fail("--method must be bpc or ojr");
  const bool ojr = options.method == "ojr";
  if (ojr && !set.has_joints) fail("--method ojr needs joints in every frame of the datasets");
  if (!ojr && !set.has_labels) fail("--method bpc needs part labels (datasets with parts/)");
  const size_t tree_count = options.structure ? options.structure->trees.size() : set.tree_pixels.size();
  if (set.tree_pixels.size() != tree_count)
    fail("training set holds pixels for " + std::to_string(set.tree_pixels.size()) + " trees, expected " +
         std::to_string(tree_count));

  TrainedForest forest;
  forest.method = options.method;
  forest.reference_focal_px = set.reference_focal_px;
  forest.depth = options.structure ? options.structure->depth : options.tree.max_depth;
  forest.part_names = set.part_names;
  forest.joint_names = set.joint_names;
  forest.has_part_distributions = set.has_labels && !set.part_names.empty();
  forest.has_votes = ojr;
  forest.votes_per_joint = ojr ? options.leaf.votes_per_joint : 0;
  if (options.structure && options.structure->reference_focal_px != set.reference_focal_px)
    fail("retro-fitting: the training set's reference focal length differs from the structure's");

  const size_t image_bytes = set.image_bytes();
  for (size_t t = 0; t < tree_count; ++t) {
    std::vector<TrainingPixel> pixels = set.tree_pixels[t];
    const size_t tree_pixels = pixels.size();
    stats.training_pixels += tree_pixels;
    LeafRanges ranges;
    TrainedTree tree;
    const auto t0 = std::chrono::steady_clock::now();
    if (options.structure) {
      tree = options.structure->trees[t];
      tree.part_probabilities.clear();
      tree.votes.clear();
      ranges = group_by_leaf(set, tree, pixels, options.tree.threads);
      stats.peak_bytes = std::max(stats.peak_bytes, tree_pixels * (sizeof(TrainingPixel) * 2 + 4));
    } else {
      GrownTree grown = grow_tree(set, std::move(pixels), static_cast<int>(t), options.tree, progress);
      tree = std::move(grown.tree);
      pixels = std::move(grown.pixels);
      ranges = std::move(grown.leaf_ranges);
      stats.feature_evaluations += grown.feature_evaluations;
      stats.peak_bytes = std::max(stats.peak_bytes, grown.peak_bytes);
    }
    const auto t1 = std::chrono::steady_clock::now();
    if (forest.has_part_distributions)
      fit_part_distributions(pixels, ranges, static_cast<int>(set.part_names.size()), tree);
    if (ojr) {
      LeafParams lp = options.leaf;
      lp.threads = options.tree.threads;
      fit_votes(set, pixels, ranges, lp, static_cast<int>(t), tree);
    }
    const auto t2 = std::chrono::steady_clock::now();
    stats.structure_seconds += std::chrono::duration<double>(t1 - t0).count();
    stats.leaf_seconds += std::chrono::duration<double>(t2 - t1).count();
    stats.bytes_per_pixel =
        std::max(stats.bytes_per_pixel, double(image_bytes + stats.peak_bytes) / double(std::max<size_t>(1, tree_pixels)));
    forest.trees.push_back(std::move(tree));
  }

  nlohmann::json cfg;
  cfg["method"] = options.method;
  cfg["objective"] = options.tree.objective == Objective::kClassification ? "classification" : "regression";
  cfg["retrofit"] = options.structure != nullptr;
  cfg["trees"] = tree_count;
  cfg["depth"] = forest.depth;
  cfg["offsets"] = options.tree.offset_candidates;
  cfg["thresholds"] = options.tree.threshold_candidates;
  cfg["max_offset_pxm"] = options.tree.max_offset_pxm;
  cfg["min_samples"] = options.tree.min_samples;
  cfg["rho_m"] = options.tree.rho_m;
  cfg["seed"] = options.tree.seed;
  cfg["proposal"] = options.tree.proposal != nullptr ? "mixture" : "uniform";
  cfg["pixels_per_image"] = options.pixels_per_image;
  cfg["images_per_tree"] = options.images_per_tree;
  cfg["training_pixels"] = stats.training_pixels;
  if (ojr) {
    cfg["nres"] = options.leaf.reservoir;
    cfg["bandwidth_m"] = options.leaf.bandwidth_m;
    cfg["votes_per_leaf"] = options.leaf.votes_per_joint;
    cfg["vote_length_m"] = options.leaf.vote_length_m;
  }
  forest.training_json = cfg.dump();
  forest.datasets_json = set.datasets_json;
  nlohmann::json timings;
  timings["load"] = set.load_seconds;
  timings["structure"] = stats.structure_seconds;
  timings["leaves"] = stats.leaf_seconds;
  timings["feature_evaluations"] = stats.feature_evaluations;
  timings["bytes_per_training_pixel"] = stats.bytes_per_pixel;
  forest.timings_json = timings.dump();
  link_and_validate(forest, "trained forest");
  if (stats_out) *stats_out = stats;
  return forest;
}

}  // namespace dp::train
