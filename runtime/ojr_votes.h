// OJR vote casting (stage 3 for offset-joint-regression forests; votes.h describes the stage).
// Each leaf record holds up to K votes per joint (offsets in mm, a uint16 weight ≥ 1), stored
// compactly in lane (joint, k) order (forest_blob/blob_format.h); a pixel's vote for joint j is its
// 3D point plus the offset, weight w·z², dropped when |offset| > vote_length_mm (0 = no limit). A vote's casting order depends on (pixel, tree, k) only, never on other joints'
// length filters, so each joint's proposals depend only on its own JointConfig (tune relies on this).
#pragma once
#include <stdint.h>

#include "runtime/kernels/vote_kernel.h"
#include "runtime/votes.h"

namespace dp {

// The reference caster: every pixel, tree, joint and k in order into a top-Nsub heap. Returns
// kFlagVotesTruncated or 0 (votes.h).
uint32_t cast_ojr_votes_reference(const CastInputs& in, const VoteSets& sets);
// The fast caster: the same kept votes (in casting order) by `scan`.
uint32_t cast_ojr_votes_fast(const CastInputs& in, kernels::OjrScanFn scan, const VoteSets& sets);

}  // namespace dp
