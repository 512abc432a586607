// Stage 3, vote casting: every evaluated pixel's leaves become weighted 3D votes per joint, of which
// each joint keeps its top Nsub (vote_selection.h).
//   BPC (bpc_votes.h): one vote per pixel and joint at the pixel's 3D point pushed back by ζj, weight
//     p(j|pixel)·z² (paper Eq. 6–7), a mean-shift start when p > λj.
//   OJR (ojr_votes.h): the leaves' K offset votes per joint, weight w·z², within the vote length λj.
// Two casters per method give the same kept votes bit for bit: the reference (a scalar scan into a
// top-N heap, the specification) and the fast one (a floor guessed from a sample, an ISA vote scan
// from runtime/kernels/, buffered selection, a rescan when the guess was too high).
#pragma once
#include <stdint.h>

#include "forest_blob/blob_loader.h"
#include "runtime/depthpose.h"
#include "runtime/kernels/vote_kernel.h"
#include "runtime/vote_selection.h"

namespace dp {

// An OJR leaf table as the fast caster scans it: record r's votes are [offsets[r], offsets[r + 1]) of
// `votes`, each with its lane j·K + k in `lanes` (increasing within a record). Either the blob's own
// tables or the pipeline's live-vote copy (ojr_votes.h); offsets == nullptr means none.
struct OjrVoteTable {
  const uint32_t* offsets;
  const blob::OjrVote* votes;
  const uint8_t* lanes;
};

// What a caster reads. Pixels, their leaves (tree-major: tree t's leaf for pixel i at
// leaves[t · leaf_stride + i], each < leaf_count) and the frame's intrinsics (fx, fy > 0, finite).
struct CastInputs {
  const blob::LoadedBlob* blob;
  const blob::RuntimeConfig* config;
  const EvaluatedPixel* pixels;
  int32_t count;                // ≤ the pixel budget
  const uint32_t* leaves;
  int32_t leaf_stride;
  CameraIntrinsics intrinsics;
  const uint8_t* user_filter;   // nullptr: every pixel casts; else only pixels whose value is user_id
  int32_t user_stride;
  uint8_t user_id;
  int32_t cap;                  // Nsub, 1..kMaxVotesCap
  const uint16_t* joint_mass;   // BPC: the joint-mass table (bpc_votes.h), or nullptr when too large
  uint16_t* guess_hist;         // scratch: [kMaxJoints][kGuessBuckets]
  OjrVoteTable ojr_live;        // OJR fast caster: the live-vote copy for `config`, or offsets nullptr
};

// The vote-scan kernels a fast caster uses (runtime/kernels/vote_kernel.h).
struct VoteScanKernels {
  kernels::BpcScanFn bpc_scan;
  kernels::OjrScanFn ojr_scan;
};

// Casts the votes of `in` into `sets` (emptied first): the reference casters when `scan` is null,
// else the fast ones with those kernels. Returns kFlagVotesTruncated when a joint had more candidates
// than Nsub, else 0.
uint32_t cast_votes(const CastInputs& in, const VoteScanKernels* scan, const VoteSets& sets);

inline bool skipped_by_user_filter(const CastInputs& in, const EvaluatedPixel& px) {
  return in.user_filter && in.user_filter[size_t(px.v) * size_t(in.user_stride) + px.u] != in.user_id;
}

}  // namespace dp
