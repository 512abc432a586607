#include "tools/train/forest_trainer.h"

#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tools/common/error.h"
#include "tools/train/checkpoint.h"
#include "tools/train/distributed_leaves.h"

namespace dp::train {
using tools::fail;

std::string forest_options_json(const ForestOptions& options, size_t trees) {
  const TreeParams& t = options.tree;
  nlohmann::json j;
  j["method"] = options.method;
  j["trees"] = trees;
  j["objective"] = t.objective == Objective::kClassification ? "classification" : "regression";
  j["depth"] = t.max_depth;
  j["offsets"] = t.offset_candidates;
  j["thresholds"] = t.threshold_candidates;
  j["max_offset_pxm"] = t.max_offset_pxm;
  j["min_samples"] = t.min_samples;
  j["rho_m"] = t.rho_m;
  j["seed"] = t.seed;
  j["pixels_per_image"] = options.pixels_per_image;
  j["images_per_tree"] = options.images_per_tree;
  uint64_t h = 0xCBF29CE484222325ull;
  auto mix = [&](int64_t v) { h = (h ^ static_cast<uint64_t>(v)) * 0x100000001B3ull; };
  auto hex = [&] {
    char b[20];
    std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(h));
    h = 0xCBF29CE484222325ull;
    return std::string(b);
  };
  if (t.proposal) {
    for (const auto* list : {&t.proposal->first, &t.proposal->second}) {
      mix(static_cast<int64_t>(list->size()));
      for (const auto& o : *list) mix(o[0] * 65536 + o[1]);
    }
    mix(static_cast<int64_t>(t.proposal->uniform_fraction * 1e9));
    mix(t.proposal->jitter_pxm);
    j["proposal"] = hex();
  } else {
    j["proposal"] = "uniform";
  }
  if (options.structure) {
    for (const TrainedTree& tree : options.structure->trees) {
      mix(static_cast<int64_t>(tree.nodes.size()));
      for (const TrainedNode& n : tree.nodes)
        for (int64_t v : {int64_t(n.heap_index), int64_t(n.leaf), int64_t(n.du1), int64_t(n.dv1), int64_t(n.du2),
                          int64_t(n.dv2), int64_t(n.threshold_mm)})
          mix(v);
    }
    j["structure"] = hex();
  }
  if (options.method == "ojr") {
    j["nres"] = options.leaf.reservoir;
    j["bandwidth_m"] = options.leaf.bandwidth_m;
    j["votes_per_leaf"] = options.leaf.votes_per_joint;
    j["vote_length_m"] = options.leaf.vote_length_m;
    j["leaf_seed"] = options.leaf.seed;
  }
  return j.dump();
}

TrainedForest train_forest(const TrainingSet& set, const ForestOptions& options, const ProgressFn& progress,
                           ForestStats* stats_out) {
  ForestStats stats;
  if (options.method != "bpc" && options.method != "ojr") fail("--method must be bpc or ojr");
  const bool ojr = options.method == "ojr";
  if (ojr && !set.has_joints) fail("--method ojr needs joints in every frame of the datasets");
  if (!ojr && !set.has_labels) fail("--method bpc needs part labels (datasets with parts/)");
  if (ojr) check_leaf_params(options.leaf, static_cast<int>(set.joint_names.size()));
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

  Communicator* comm = options.tree.comm;
  const bool writes_files = !comm || comm->rank() == 0;
  TrainingCheckpoint checkpoint;
  const bool checkpointing = !options.checkpoint_path.empty();
  if (checkpointing) {
    checkpoint.options_json = forest_options_json(options, tree_count);
    checkpoint.data_digest = training_data_digest(set, comm);
    if (options.resume && std::ifstream(options.checkpoint_path).good()) {
      TrainingCheckpoint found = read_checkpoint(options.checkpoint_path);
      check_checkpoint_matches(found, checkpoint.options_json, checkpoint.data_digest, options.checkpoint_path);
      if (found.trees.size() > tree_count || found.retrofit.size() > tree_count)
        fail("checkpoint " + options.checkpoint_path + " holds more trees than the run");
      if (options.structure ? !found.trees.empty() : !found.retrofit.empty())
        fail("checkpoint " + options.checkpoint_path + " is of a " + (options.structure ? "grown forest" : "retro-fit") +
             ", this run " + (options.structure ? "retro-fits leaves" : "grows a forest"));
      checkpoint.trees = std::move(found.trees);
      checkpoint.retrofit = std::move(found.retrofit);
    }
  }

  const size_t image_bytes = set.image_bytes();
  for (size_t t = 0; t < tree_count; ++t) {
    std::vector<TrainingPixel> pixels = set.tree_pixels[t];
    const size_t tree_pixels = pixels.size();
    int64_t all_pixels = static_cast<int64_t>(tree_pixels);
    if (comm) comm->sum(&all_pixels, 1);
    stats.training_pixels += static_cast<size_t>(all_pixels);
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
      // A copy: level_done overwrites checkpoint.trees[t] while grow_tree still reads the resume state.
      const GrowthState resume_state = t < checkpoint.trees.size() ? checkpoint.trees[t] : GrowthState{};
      const GrowthState* resume = t < checkpoint.trees.size() ? &resume_state : nullptr;
      LevelDoneFn level_done;
      if (checkpointing)
        level_done = [&](const GrowthState& state) {
          checkpoint.trees.resize(t + 1);
          checkpoint.trees[t] = state;
          if (writes_files) write_checkpoint(options.checkpoint_path, checkpoint);
          if (options.after_checkpoint) options.after_checkpoint(static_cast<int>(t), state.levels_done);
        };
      GrownTree grown =
          grow_tree(set, std::move(pixels), static_cast<int>(t), options.tree, progress, resume, level_done);
      tree = std::move(grown.tree);
      pixels = std::move(grown.pixels);
      ranges = std::move(grown.leaf_ranges);
      stats.feature_evaluations += grown.feature_evaluations;
      stats.peak_bytes = std::max(stats.peak_bytes, grown.peak_bytes);
    }
    const auto t1 = std::chrono::steady_clock::now();
    LeafParams lp = options.leaf;
    lp.threads = options.tree.threads;
    const int part_count = static_cast<int>(set.part_names.size());
    // A retro-fit resumes its votes at the checkpoint's leaf (the votes before it are final) and
    // checkpoints them after blocks of leaves.
    size_t first_leaf = 0;
    LeavesDoneFn leaves_done;
    // Declared beside leaves_done, which refers to it after the block below.
    auto last_write = std::chrono::steady_clock::now();
    if (options.structure && ojr) {
      const size_t per_leaf = set.joint_names.size() * size_t(lp.votes_per_joint);
      if (checkpointing && t < checkpoint.retrofit.size()) {
        RetrofitState& r = checkpoint.retrofit[t];
        if (r.leaves_done > tree.leaf_count() || r.votes.size() != r.leaves_done * per_leaf ||
            r.complete != (r.leaves_done == tree.leaf_count()))
          fail("checkpoint " + options.checkpoint_path + ": retro-fit tree " + std::to_string(t) + " holds " +
               std::to_string(r.votes.size()) + " votes for " + std::to_string(r.leaves_done) + " of " +
               std::to_string(tree.leaf_count()) + " leaves");
        first_leaf = r.leaves_done;
        tree.votes = r.votes;
        tree.votes.resize(tree.leaf_count() * per_leaf);
      }
      last_write = std::chrono::steady_clock::now();
      leaves_done = [&, t, per_leaf](size_t done) {
        if (options.retrofit_progress) options.retrofit_progress(static_cast<int>(t), done, tree.leaf_count());
        const bool complete = done == tree.leaf_count();
        const auto now = std::chrono::steady_clock::now();
        if (!checkpointing ||
            (!complete && std::chrono::duration<double>(now - last_write).count() < options.retrofit_checkpoint_seconds))
          return;
        checkpoint.retrofit.resize(t + 1);
        checkpoint.retrofit[t] = {done, complete, std::vector<LeafVote>(tree.votes.begin(), tree.votes.begin() + done * per_leaf)};
        if (writes_files) write_checkpoint(options.checkpoint_path, checkpoint);
        last_write = std::chrono::steady_clock::now();
        if (options.after_checkpoint) options.after_checkpoint(static_cast<int>(t), static_cast<int>(done));
      };
    }
    if (comm) {
      sum_leaf_pixel_counts(tree, *comm);
      if (forest.has_part_distributions) fit_part_distributions_distributed(pixels, ranges, part_count, tree, *comm);
      if (ojr) fit_votes_distributed(set, pixels, ranges, lp, static_cast<int>(t), tree, *comm, first_leaf, leaves_done);
    } else {
      if (forest.has_part_distributions) fit_part_distributions(pixels, ranges, part_count, tree);
      if (ojr) fit_votes(set, pixels, ranges, lp, static_cast<int>(t), tree, first_leaf, leaves_done);
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
