// Whole-forest training: per tree, grow the structure (tree_trainer.h) or take it from an existing
// forest (retro-fitting), then fit the leaf models (leaf_models.h); record the configuration,
// dataset identity, memory and timings in the TrainedForest.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "tools/train/forest_file.h"
#include "tools/train/leaf_models.h"
#include "tools/train/training_set.h"
#include "tools/train/tree_trainer.h"

namespace dp::train {

struct ForestOptions {
  std::string method = "bpc";          // "bpc": part distributions; "ojr": votes (+ distributions when labelled)
  TreeParams tree;                     // structure growth (ignored for retro-fitting)
  LeafParams leaf;                     // OJR leaves
  const TrainedForest* structure = nullptr;  // retro-fit leaves onto this forest's trees
  int pixels_per_image = 0;            // recorded in the configuration only
  int images_per_tree = 0;             // recorded in the configuration only
  // Checkpoints (checkpoint.h), when checkpoint_path is set: a grown forest writes one after every
  // level of every tree; a retro-fit after a block of leaves (LeafParams::leaf_block) once
  // retrofit_checkpoint_seconds have passed since the last, and after every tree. With `resume` and
  // an existing checkpoint, training continues from it (refused when its options, structure or data
  // differ); a missing checkpoint starts from the beginning.
  std::string checkpoint_path;
  bool resume = false;
  double retrofit_checkpoint_seconds = 60;  // seconds, ≥ 0: a 2^20-leaf tree's votes take ~0.5 GB to write
  // Retro-fit progress: called after every block of leaves with the tree and its leaves done of all.
  std::function<void(int tree, size_t leaves_done, size_t leaves)> retrofit_progress;
  // Called after each checkpoint is written (tree, levels done; retro-fit: leaves done). Tests throw
  // from it to stop a run.
  std::function<void(int tree, int levels_done)> after_checkpoint;
};

// The options that determine the forest, as a JSON object (what a checkpoint must match):
// everything in ForestOptions except threads, checkpointing and hooks; the proposal and the
// retro-fit structure by digest.
std::string forest_options_json(const ForestOptions& options, size_t trees);

struct ForestStats {
  double structure_seconds = 0, leaf_seconds = 0;
  uint64_t feature_evaluations = 0;    // pixel × offset-pair evaluations over all trees
  size_t peak_bytes = 0;               // largest working set of one tree (excluding images)
  size_t training_pixels = 0;
  double bytes_per_pixel = 0;          // (images + per-tree working set) / training pixels of a tree
};

// Distributed (options.tree.comm): every rank calls this with its shard of the set
// (SamplingOptions::shard) and receives the same structure; rank 0 alone writes checkpoints and
// receives the OJR votes, so rank 0's forest is the one to write (identical to a one-process run).
// Trains set.tree_pixels.size() trees (or the structure's tree count when retro-fitting; then
// the set must have as many pixel lists). Throws ToolError on inconsistent inputs.
TrainedForest train_forest(const TrainingSet& set, const ForestOptions& options, const ProgressFn& progress,
                           ForestStats* stats = nullptr);

}  // namespace dp::train
