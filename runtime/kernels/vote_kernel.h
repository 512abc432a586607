// BPC vote casting scan (stage 3), one entry point per ISA (ref = SSE4.1 baseline, AVX2, AVX-512).
//
// Contract: for every evaluated pixel i in increasing order (skipping pixels whose user-filter value
// differs from user_id when user_filter is set), the scan computes each joint's
//     mass_j = Σ over trees of joint_mass[leaf(i, t)][j]            (uint32, exact)
//     weight_j = (float(mass_j) · inv_total · z) · z                 (z = z_mm · 0.001f, metres)
// exactly as Pipeline::cast_bpc_votes does (separately rounded IEEE single products, in this
// order), counts every candidate (mass_j ≠ 0) in candidates[j], and appends the candidates whose
// weight is not below floor[j] to joint j's buffer votes[j · slots ...] as
//     Vote{x, y, z + push_back_m[j], weight_j, order = i, start = mass_j > start_threshold[j]}.
// A buffer that reaches `slots` votes is handed to on_full(ctx, j), which must cut it (keeping
// casting order) and return joint j's new floor; the scan reads floor[] again after the call.
// Votes are thus appended in casting order. Loops are bounded by count ≤ the pixel budget and
// trees ≤ kMaxTrees (validated at blob load). No allocation.
#pragma once
#include <stdint.h>
#include <xmmintrin.h>

#include "runtime/depthpose.h"

namespace dp {

struct Vote {
  float x, y, z;   // metres
  float weight;    // p·z² (BPC) or w·z² (OJR)
  uint32_t order;  // casting order (canonical order for aggregation)
  uint32_t start;  // 1 when this vote may seed mean shift (BPC: p > λc)
};

namespace kernels {

struct BpcScanArgs {
  const EvaluatedPixel* pixels;
  int32_t count;
  const uint32_t* leaves;       // tree-major: tree t's leaf for pixel i at leaves[t · leaf_stride + i]
  int32_t leaf_stride;
  int32_t trees;
  const uint16_t* joint_mass;   // per leaf record: kMaxJoints Q15 masses (0 for joints ≥ joint_count)
  float inv_total;              // 1 / (32768 · trees)
  float cx, cy, inv_fx, inv_fy;
  const float* push_back_m;     // [kMaxJoints] float(push_back_mm) · 0.001f
  const uint32_t* start_threshold;  // [kMaxJoints] prob_threshold_q15 · trees
  float* floor;                 // [kMaxJoints], 64-byte aligned; updated by on_full
  const uint8_t* user_filter;   // nullptr: every pixel
  int32_t user_stride;
  uint8_t user_id;
  Vote* votes;                  // [kMaxJoints][slots]
  int32_t slots;
  int32_t* vote_counts;         // [kMaxJoints]
  uint32_t* candidates;         // [kMaxJoints], added to (callers zero it)
  float (*on_full)(void* ctx, int joint);
  void* ctx;
};

using BpcScanFn = void (*)(const BpcScanArgs& args);
namespace ref { void bpc_scan(const BpcScanArgs& args); }
namespace avx2 { void bpc_scan(const BpcScanArgs& args); }
namespace avx512 { void bpc_scan(const BpcScanArgs& args); }

// nullptr when the CPU lacks the ISA (kBest: the widest available).
BpcScanFn bpc_scan_kernel(KernelIsa isa);

constexpr int32_t kVotePrefetchAhead = 16;  // pixels: the joint-mass rows are random reads beyond L1

// The shared tail of every ISA's scan: x and y once per pixel with a survivor, then one append per
// surviving joint (`keep` bit j), lightest-first never matters because order = i is appended in turn.
inline void append_bpc_survivors(const BpcScanArgs& a, int32_t i, const EvaluatedPixel& px, float z, uint32_t keep,
                                 const float* w, const uint32_t* mass) {
  const float x = (float(px.u) - a.cx) * z * a.inv_fx;
  const float y = -(float(px.v) - a.cy) * z * a.inv_fy;
  for (; keep; keep &= keep - 1) {
    const int j = __builtin_ctz(keep);
    int32_t& n = a.vote_counts[j];
    a.votes[size_t(j) * size_t(a.slots) + size_t(n++)] =
        Vote{x, y, z + a.push_back_m[j], w[j], uint32_t(i), mass[j] > a.start_threshold[j] ? 1u : 0u};
    if (n == a.slots) a.floor[j] = a.on_full(a.ctx, j);
  }
}

// Pixel i's joint-mass row in tree t (kMaxJoints Q15 masses).
inline const uint16_t* mass_row(const BpcScanArgs& a, int t, int32_t i) {
  return a.joint_mass + size_t(a.leaves[size_t(t) * a.leaf_stride + i]) * kMaxJoints;
}

// The rows are random reads beyond L1: fetch those of the pixel kVotePrefetchAhead on.
inline void prefetch_mass_rows_ahead(const BpcScanArgs& a, int32_t i) {
  if (i + kVotePrefetchAhead < a.count)
    for (int t = 0; t < a.trees; ++t)
      _mm_prefetch(reinterpret_cast<const char*>(mass_row(a, t, i + kVotePrefetchAhead)), _MM_HINT_T0);
}

inline bool skipped(const BpcScanArgs& a, const EvaluatedPixel& px) {
  return a.user_filter && a.user_filter[size_t(px.v) * size_t(a.user_stride) + px.u] != a.user_id;
}

}  // namespace kernels
}  // namespace dp
