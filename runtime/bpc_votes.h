// BPC vote casting (stage 3 for body-part classification forests; votes.h describes the stage).
// A pixel's vote for joint j has weight p·z² where p = Σ over the joint's parts (part_mask) of the
// tree-averaged Q15 leaf probabilities / 32768, at the pixel's 3D point with z pushed back by
// push_back_mm; it may seed mean shift when p > prob_threshold_q15 / 32768.
#pragma once
#include <stdint.h>

#include "forest_blob/blob_loader.h"
#include "runtime/kernels/vote_kernel.h"
#include "runtime/votes.h"

namespace dp {

// The joint-mass table: per leaf record, kMaxJoints uint16 = Σ of its Q15 probabilities over each
// joint's part mask (0 for joints ≥ joint_count; ≤ 32768, validated at load). It replaces 3·parts
// additions per pixel by 3 loads of 16 lanes, and is kept up to kMaxJointMassLeaves records
// (32 bytes per record in the arena, at most 32 MB; PCL: 25 records, a depth-20 blob pruned to
// 16 MB in format v4 about 630 000 records, a 20 MB table). Without it
// the fast caster falls back to the reference: on a depth-20 blob of 313 064 records, bench_runtime's rendered
// people at 320×240 spend 2.8–3.3 M cycles per frame in votes without the table (a cap of 2^18)
// against 0.76–0.88 M with it (BPC 504–523 → 848–966 frames/s, two alternated runs).
constexpr uint32_t kMaxJointMassLeaves = 1u << 20;  // leaf records
inline bool use_joint_mass(const blob::LoadedBlob& b) {
  return b.method() == blob::Method::kBpc && b.meta->leaf_count <= kMaxJointMassLeaves;
}
// Fills `table` (leaf_count × kMaxJoints) for `config`'s part masks.
void build_joint_mass(const blob::LoadedBlob& b, const blob::RuntimeConfig& config, uint16_t* table);

// The reference caster: every pixel and joint in order into a top-Nsub heap. Returns
// kFlagVotesTruncated or 0 (votes.h).
uint32_t cast_bpc_votes_reference(const CastInputs& in, const VoteSets& sets);
// The fast caster: the same kept votes (in casting order) by `scan`; falls back to the reference when
// there is no joint-mass table.
uint32_t cast_bpc_votes_fast(const CastInputs& in, kernels::BpcScanFn scan, const VoteSets& sets);

}  // namespace dp
