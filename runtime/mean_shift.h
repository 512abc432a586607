// Stage 4, mean shift: each joint's kept votes become up to max_proposals_per_joint proposals.
// Per joint: votes in casting order; starting points = the votes eligible to start, evenly strided
// down to the starts cap; each start climbs the weighted Gaussian density (bandwidth_mm) for at most
// the iteration cap, stopping at a 1 mm step or on reaching a known mode (within half the merge
// tolerance); modes within merge_tolerance_mm merge; every vote then adds its weight to the nearest
// mode within 3 bandwidths (its confidence); the heaviest modes are the proposals, by decreasing
// confidence. The sums and the vote-to-mode assignment are kernels (kernels/mean_shift_kernel.h), so
// every ISA gives the same bits.
#pragma once
#include <stdint.h>

#include "forest_blob/blob_format.h"
#include "runtime/depthpose.h"
#include "runtime/kernels/mean_shift_kernel.h"
#include "runtime/vote_selection.h"

namespace dp {

// Mean-shift structure-of-arrays row: Nsub votes padded to a multiple of kMeanShiftLanes.
constexpr int32_t kSoaRow = blob::kMaxVotesCap + kernels::kMeanShiftLanes;

// Arena scratch of the stage.
struct MeanShiftScratch {
  Vote* starts;  // [kMaxStartsCap]
  float* modes;  // [kMaxStartsCap][4]: x, y, z, confidence
  float* soa;    // [4][kSoaRow]: x, y, z, weight rows
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
