// Stage 4, mean shift: each joint's kept votes become up to max_proposals_per_joint proposals.
// Per joint: votes in casting order; starting points = the votes eligible to start, evenly strided
// down to the starts cap. The density climbed is that of the cell votes: the votes binned in cubic
// cells of kCellBandwidths bandwidths (cell (⌊x/c⌋, ⌊y/c⌋, ⌊z/c⌋)), each cell one vote at its
// weighted centroid carrying the cell's summed weight, in order of each cell's first vote. A start
// within kStartSkipBandwidths bandwidths of a known mode is not climbed; the others climb the
// weighted Gaussian density (bandwidth_mm) for at most the iteration cap, stopping at a 1 mm step or
// on reaching a known mode (within the merge tolerance); modes within merge_tolerance_mm merge;
// every cell vote then adds its weight to the nearest mode within 3 bandwidths (its confidence); the
// heaviest modes are the proposals, by decreasing confidence. The sums and the vote-to-mode
// assignment are kernels (kernels/mean_shift_kernel.h), so every ISA gives the same bits.
#pragma once
#include <stdint.h>

#include "forest_blob/blob_format.h"
#include "runtime/depthpose.h"
#include "runtime/kernels/mean_shift_kernel.h"
#include "runtime/vote_selection.h"

namespace dp {

// Mean-shift structure-of-arrays row: Nsub votes padded to a multiple of kMeanShiftLanes.
constexpr int32_t kSoaRow = blob::kMaxVotesCap + kernels::kMeanShiftLanes;

// Cell edge in bandwidths, range (0, 2]. Chosen on 200 held-out frames (synth --clips split:test
// --seed 9173, shipped OJR, Nsub 800): cells of 0.25 / 0.5 / 1 bandwidths leave 61 / 33 / 15 % of
// the votes for the climb at mAP 0.595 / 0.595 / 0.597 (0.595 with every vote); 1.5 gives 0.594 and
// starts to cost precision (mAP at D_tp 0.06 m: 0.393 against 0.402). docs/runtime_speed.md.
constexpr float kCellBandwidths = 1.0f;
// A start this close to a known mode (in bandwidths, range [0, 2]) is not climbed: it lies in that
// mode's basin. Same frames: 1 bandwidth, with the climb ending within the merge tolerance of a
// known mode (instead of half of it), takes 31 % fewer density sums at unchanged mAP (0.595).
constexpr float kStartSkipBandwidths = 1.0f;
// Cell hash slots: a power of two, at least twice Nsub, so a probe sequence always ends.
constexpr int32_t kCellSlots = 2 * blob::kMaxVotesCap;
static_assert((kCellSlots & (kCellSlots - 1)) == 0 && kCellSlots >= 2 * blob::kMaxVotesCap);

// Arena scratch of the stage.
struct MeanShiftScratch {
  Vote* starts;  // [kMaxStartsCap]
  float* modes;  // [kMaxStartsCap][4]: x, y, z, confidence
  float* soa;    // [4][kSoaRow]: x, y, z, weight rows (the cell votes)
  uint64_t* cell_keys;  // [kCellSlots]: the cell hash table's packed cell coordinates
  int32_t* cell_ids;    // [kCellSlots]: its cell vote index, −1 = free
};

struct MeanShiftKernels {
  kernels::MeanShiftSumsFn sums;
  kernels::ModeWeightsFn mode_weights;
};

// Aggregates every joint's votes in `sets` (≤ starts_per_joint_used starts, iterations_used
// iterations, from `result`) into result->proposals and proposal_count; sets kFlagStartsTruncated
// and kFlagProposalsTruncated in result->flags. Sorts each joint's votes into casting order.
void aggregate_proposals(const blob::RuntimeConfig& config, int joint_count, const VoteSets& sets,
                         const MeanShiftScratch& scratch, const MeanShiftKernels& kernels, FrameResult* result);

}  // namespace dp
