// Tree-structure training (paper section 3.5.1): greedy, breadth first. Each level evaluates,
// for every frontier node, |offsets| candidate offset pairs × up to |thresholds| thresholds over
// all the node's pixels (pixel-major: each pixel's features for a whole group of candidates at
// once, docs/training.md "Throughput"), picks the candidate that minimizes Eq. 7, and partitions
// the pixels (stable) into the children.
//
// Determinism: every random choice is keyed by (seed, tree, node heap index, candidate),
// classification histograms are integer counts (partial histograms over pixel ranges sum exactly
// in any order), regression sums run in a fixed pixel order per candidate, and ties go to the
// lowest candidate and threshold. The grown tree is therefore identical for any thread count and
// any division of the work into items.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "tools/train/communicator.h"
#include "tools/train/forest_file.h"
#include "tools/train/training_set.h"

namespace dp::train {

enum class Objective { kClassification, kRegression };

// Distributed growth: frontier nodes with fewer pixels than this (over all ranks) are searched
// node-parallel (one rank owns the node and receives its pixels' features) instead of by summing
// histograms over the ranks (docs/training.md "What is communicated per level"). Pixels, 0..2^24
// (0: histogram sums at every level). Chosen with `make bench-mpi` (120 frames, 1000 px/image,
// depth 12, 200 × 20 candidates, 2 ranks, two runs): CPU seconds 6.6–7.1 at 0, 4.6 at 300,
// 3.7–4.0 at 1000, 4.9 at 2000, 3.8–4.6 at 3000, 4.8 at 10 000, 5.8 at 30 000 (±20 % noise);
// payload per rank 568, 235, 135, 111, 105, 107, 124 MB. 2000 is the middle of the flat
// 1000–3000 valley; the traffic break-even ≈ 4N·((T+1)·k + T) grows with the rank count N.
constexpr uint32_t kDefaultNodeParallelPixels = 2000;
constexpr uint32_t kMaxNodeParallelPixels = uint32_t(1) << 24;

// Proposal distribution over offsets learnt from a trained forest's chosen splits (section 3.5.1,
// Fig. 8): δ1 and non-zero δ2 are drawn from the chosen ones with a uniform jitter of ±jitter,
// mixed with `uniform_fraction` of the uniform box.
struct OffsetProposal {
  std::vector<std::array<int16_t, 2>> first;   // chosen δ1
  std::vector<std::array<int16_t, 2>> second;  // chosen non-zero δ2
  double uniform_fraction = 0.1;
  int jitter_pxm = 2;
  static OffsetProposal from_forest(const TrainedForest& forest);
};

struct TreeParams {
  int max_depth = 20;               // leaves at level ≤ max_depth (root level 0)
  int offset_candidates = 2000;     // offset pairs per node
  int threshold_candidates = 50;    // thresholds per offset pair (1..255)
  int max_offset_pxm = 65;          // |du|,|dv| ≤ this, pixel·metres at the reference focal
  int min_samples = 10;             // nodes with fewer pixels become leaves
  Objective objective = Objective::kClassification;
  float rho_m = 0.5f;               // regression: offsets with |Δ| ≥ ρ are ignored (Eq. 11)
  uint64_t seed = 1;
  int threads = 1;
  const OffsetProposal* proposal = nullptr;
  // Deep levels search their nodes in batches whose features (int16, pixels × candidates padded
  // to 16) take at most this many bytes; 0 = the default, 1 GiB (tree_trainer.cc,
  // kLevelFeatureBytes). Memory only: the forest is the same for any value.
  size_t level_feature_bytes = 0;
  // Data-parallel growth over the ranks of `comm` (docs/training.md "Distributed training"): the
  // pixels given to grow_tree are this rank's share (its images' pixels, a contiguous range of
  // the tree's global pixel list, ranks in order); every rank grows the same tree. Null: one
  // process, the pixels are all of them.
  Communicator* comm = nullptr;
  // With comm: nodes with fewer pixels (all ranks) are searched node-parallel. Any value grows the
  // same tree; it only moves the work and the traffic.
  uint32_t node_parallel_pixels = kDefaultNodeParallelPixels;
};

struct LevelReport {
  int tree = 0, level = 0;
  size_t frontier_nodes = 0, split_nodes = 0, active_pixels = 0;
  uint64_t feature_evaluations = 0;  // pixel × offset-pair evaluations this level (all ranks)
  uint64_t bytes_reduced = 0;        // distributed: payload bytes this rank contributed to sums this level
  uint64_t bytes_exchanged = 0;      // distributed: bytes this rank sent to node owners this level
  size_t node_parallel_nodes = 0;    // distributed: nodes searched node-parallel this level
  double seconds = 0;                // this level
  double tree_seconds = 0;           // since the tree started
  bool partial = false;              // a heartbeat within a long level: only `done` is meaningful
  double done = 1;                   // fraction of the level's split search finished
  bool resumed = false;              // levels 0..level were replayed from a checkpoint (only
                                     // tree, level and tree_seconds are meaningful)
};
// Called on the calling thread after each level, and every ~10 s within a long level (partial).
using ProgressFn = std::function<void(const LevelReport&)>;

struct GrownTree {
  TrainedTree tree;                  // structure and leaf_pixel_counts; no leaf models yet
  std::vector<TrainingPixel> pixels; // reordered so that each leaf's pixels are contiguous
  std::vector<std::pair<uint32_t, uint32_t>> leaf_ranges;  // per leaf record: [begin, end) in pixels
  uint64_t feature_evaluations = 0;
  double seconds = 0;
  size_t peak_bytes = 0;             // working memory of the growth (pixels, buffers, scratch)
};

// A node whose fate is decided: split with the given feature and threshold, or a leaf.
struct DecidedNode {
  uint32_t heap = 0;
  bool leaf = true;
  int32_t du1 = 0, dv1 = 0, du2 = 0, dv2 = 0, threshold = 0;
};

// What a tree's growth has decided after its first `levels_done` levels (breadth first): every
// node at a level < levels_done, in heap order. Together with the tree's initial pixels this
// determines the rest of the growth (the pixel order is recomputed by replaying the splits), so it
// is all a checkpoint needs. `complete` = nothing is left to grow.
struct GrowthState {
  int levels_done = 0;
  bool complete = false;
  std::vector<DecidedNode> nodes;
  uint64_t feature_evaluations = 0;  // spent so far (statistics only)
};
// Called on the calling thread after each level with the state so far (for checkpoints). It may
// throw; the exception leaves grow_tree.
using LevelDoneFn = std::function<void(const GrowthState&)>;

// Grows one tree on `pixels` (which it takes) of `set`. For kRegression the images need joints.
// With `resume`, the decisions of its first resume->levels_done levels are replayed (pixels are
// partitioned, no split search) and growth continues from there: the result equals an
// uninterrupted growth with the same inputs. `resume` must come from the same set, pixels and
// params; a decision that does not fit the replayed tree is refused (ToolError).
GrownTree grow_tree(const TrainingSet& set, std::vector<TrainingPixel> pixels, int tree_index,
                    const TreeParams& params, const ProgressFn& progress = {}, const GrowthState* resume = nullptr,
                    const LevelDoneFn& level_done = {});

// Objective pieces, exposed for tests. Natural logarithms.
// n·log n − Σ_c n_c·log n_c = |S|·H(S) of Eq. 8 for label counts n_c (n = Σ n_c).
double weighted_entropy(const uint32_t* counts, int count);
// Eq. 7 with Eq. 8: (|L|·H(L) + |R|·H(R)) / (|L| + |R|).
double classification_objective(const uint32_t* left, const uint32_t* right, int count);

// Per joint sufficient statistics of the offsets Δ (metres) with |Δ| < ρ.
struct JointOffsetStats {
  double n = 0, sx = 0, sy = 0, sz = 0, sq = 0;
};
// Eq. 9: Σ_j Σ_{u∈S_j} |Δ_uj − μ_j|² from per-joint statistics.
double sum_squared_deviation(const JointOffsetStats* stats, int joints);
// Eq. 7 with Eq. 9: (I_reg(L) + I_reg(R)) / (|L| + |R|); I_reg/|S| is the per-pixel deviation, so
// weighting it by |S_d|/|S| as Eq. 7 does gives this sum.
double regression_objective(const JointOffsetStats* left, const JointOffsetStats* right, int joints,
                            double left_pixels, double right_pixels);

// The split-search kernels this process uses, chosen from the CPU and the environment
// (DEPTHPOSE_TRAIN_NO_AVX512, DEPTHPOSE_TRAIN_NO_AVX2): "avx512", "avx2" or "portable". All grow
// the same forests; they differ in speed (docs/training.md "Throughput").
const char* training_kernel_name();

// Sorts the `lanes` columns of an int16 table with `n` rows (row r at rows + r × stride) each
// ascending, independently: the threshold samples of a candidate group, 16 columns per AVX2
// instruction with AVX2 (Batcher's odd–even merge network, the same comparators for every
// column; one column at a time without AVX2). Needs stride ≥ lanes rounded up to a multiple of 16
// (the AVX2 sweep sorts those padding columns too) and n ≤ 255.
// `network` is the caller's scratch for the comparator pairs (kept between calls of one n).
void sort_int16_columns(int16_t* rows, int n, size_t stride, int lanes, std::vector<uint16_t>& network);

// Runs fn(i, thread) for i in [0, n) on `threads` threads (thread 0 is the caller), items taken in
// increasing order. An exception stops the loop and the one of the lowest item is rethrown.
void parallel_for(size_t n, int threads, const std::function<void(size_t, int)>& fn);

}  // namespace dp::train
