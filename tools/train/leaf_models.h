// Leaf prediction models (paper section 3.5.2), fitted after (or independently of) the structure:
//   BPC: the normalized histogram of the part labels of the training pixels that reached a leaf.
//   OJR: Algorithm 3 — per leaf and joint a reservoir sample of N_res relative offsets
//        Δ = p_j − x(u) (metres), mean shift with a Gaussian kernel of bandwidth b* (Eq. 12), the
//        modes longer than λ_j dropped, the K largest clusters kept; weight = cluster size.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "tools/train/forest_file.h"
#include "tools/train/training_set.h"

namespace dp::train {

// Algorithm R: keeps a uniform sample (without replacement) of at most `capacity` of the items
// offered so far. Every item offered has probability min(1, capacity/seen) of being kept.
template <class T>
class ReservoirSampler {
 public:
  explicit ReservoirSampler(size_t capacity) : capacity_(capacity) { items_.reserve(capacity); }
  void offer(const T& item, Rng& rng) {
    ++seen_;
    if (items_.size() < capacity_) {
      items_.push_back(item);
    } else {
      const uint64_t j = rng.below(seen_);
      if (j < capacity_) items_[j] = item;
    }
  }
  const std::vector<T>& items() const { return items_; }
  uint64_t seen() const { return seen_; }

 private:
  size_t capacity_;
  uint64_t seen_ = 0;
  std::vector<T> items_;
};

struct Mode {
  std::array<float, 3> position{};  // metres
  int weight = 0;                   // points whose mean-shift path converged here
};

// Mean shift from every point with kernel exp(−|Δ'−Δ|²/b²); converged points within b/2 of an
// earlier mode join it. Sorted by weight (descending; ties keep discovery order).
std::vector<Mode> mean_shift_modes(const std::vector<std::array<float, 3>>& points, float bandwidth_m);

// The K heaviest modes with |position| ≤ max_length_m (max_length_m ≤ 0: no limit), padded to
// exactly K with zero-weight votes.
std::vector<LeafVote> select_votes(const std::vector<Mode>& modes, float max_length_m, int k);

// Leaves are fitted in blocks of LeafParams::leaf_block leaves (a block's leaves run in parallel):
// after each block `LeavesDoneFn(leaves_done)` is called with the votes of leaves [0, leaves_done)
// final, which is when a retro-fit checkpoint may be written. The block size bounds the work lost by
// a kill and the hook's frequency; it does not change any vote.
constexpr size_t kVoteLeafBlock = 4096;  // leaves; a depth-20 tree (≤ 2^20 leaves) makes ≤ 256 blocks
using LeavesDoneFn = std::function<void(size_t leaves_done)>;

struct LeafParams {
  int reservoir = 100;              // N_res
  float bandwidth_m = 0.05f;        // b*
  int votes_per_joint = 2;          // K
  std::vector<float> vote_length_m = {0.5f};  // λ_j per joint, or one for all; empty/0 = no limit
  uint64_t seed = 1;
  int threads = 1;
  size_t leaf_block = kVoteLeafBlock;  // leaves per block (≥ 1): checkpoint granularity, not in the result
};

using LeafRanges = std::vector<std::pair<uint32_t, uint32_t>>;  // per leaf record: [begin, end)

// Fills tree.part_probabilities (leaf × part_count) from the labels of the pixels of each leaf.
void fit_part_distributions(const std::vector<TrainingPixel>& pixels, const LeafRanges& ranges,
                            int part_count, TrainedTree& tree);

// Throws ToolError naming the option when OJR leaf parameters are out of range.
void check_leaf_params(const LeafParams& params, int joints);

// Fills tree.votes (leaf × joints × K) by Algorithm 3; the reservoir of (leaf, joint) is keyed by
// (seed, tree_index, leaf, joint) and fed in pixel order, so the result is thread-count independent.
// first_leaf > 0 continues a fit (a resumed retro-fit): tree.votes must then hold leaf × joints × K
// votes whose first first_leaf leaves are final; only the later leaves are fitted.
void fit_votes(const TrainingSet& set, const std::vector<TrainingPixel>& pixels, const LeafRanges& ranges,
               const LeafParams& params, int tree_index, TrainedTree& tree, size_t first_leaf = 0,
               const LeavesDoneFn& leaves_done = {});

// Sizes tree.votes for `leaves` leaves (zeros) when first_leaf is 0; else checks that it holds
// them (a resumed fit). Throws ToolError otherwise.
void prepare_votes(TrainedTree& tree, size_t leaves, int joints, int k, size_t first_leaf);

// Runs fit(l) for leaves l in [first_leaf, leaves) in blocks of params.leaf_block on params.threads
// threads, calling leaves_done (if set) after each block.
void for_leaf_blocks(size_t first_leaf, size_t leaves, const LeafParams& params, const std::function<void(size_t)>& fit,
                     const LeavesDoneFn& leaves_done);

// The K votes of one (leaf, joint) from its reservoir sample: mean shift, modes longer than the
// joint's λ dropped, the K heaviest kept (the second half of Algorithm 3). Writes K votes.
void fill_leaf_votes(const std::vector<std::array<float, 3>>& reservoir, const LeafParams& params, int joint,
                     LeafVote* out);
// Δ = p_joint − x(u) of a training pixel, metres (what the reservoirs sample).
std::array<float, 3> joint_offset(const TrainingImage& image, const TrainingPixel& p, int joint);

// Retro-fitting onto an existing structure: sends every pixel down `tree` with the reference
// evaluator and reorders `pixels` stably by leaf record. Sets tree.leaf_pixel_counts.
LeafRanges group_by_leaf(const TrainingSet& set, TrainedTree& tree, std::vector<TrainingPixel>& pixels,
                         int threads);

}  // namespace dp::train
