// Vote-casting scans (stage 3), one entry point per ISA folder (ref: plain C++, the specification;
// sse41, avx2, avx512, neon: the same results bit for bit).
//
// BPC scan contract: for every evaluated pixel i in increasing order (skipping pixels whose
// user-filter value differs from user_id when user_filter is set), the scan computes each joint's
//     mass_j = Σ over trees of joint_mass[leaf(i, t)][j]            (uint32, exact)
//     weight_j = (float(mass_j) · inv_total · z) · z                 (z = z_mm · 0.001f, metres)
// as separately rounded IEEE single products in this order (the reference caster's arithmetic,
// runtime/bpc_votes.cc), counts every candidate (mass_j ≠ 0) in candidates[j], and appends the
// candidates whose weight is not below floor[j] to joint j's buffer votes[j · slots ...] as
//     Vote{x, y, z + push_back_m[j], weight_j, order = i, start = mass_j > start_threshold[j]}.
// A buffer that reaches `slots` votes is handed to on_full(ctx, j), which must cut it (keeping
// casting order) and return joint j's new floor; the scan reads floor[] again after the call.
//
// OJR scan contract: for every evaluated pixel i (same filter), tree t and stored vote of its leaf
// record (compact leaves, blob_format.h: in increasing lane order, lane l = j·K + k), a vote with
// weight ≠ 0 and squared length
// dx² + dy² + dz² ≤ lane_len2[l] is a candidate (counted in lane_candidates[l] when that pointer is
// set); it is appended when weight·z² (one IEEE single product) is not below lane_floor[l], as
//     Vote{x + dx·0.001f, y + dy·0.001f, z + dz·0.001f, weight·z², order = (i·trees + t)·K + k, 1}.
// A buffer reaching `full_at` votes goes to on_full(ctx, j); the returned floor is written to every
// lane of joint j.
//
// Both: on_full must return a floor no lower than the joint's floor before the call (the pipeline's
// cut does: it keeps the heaviest votes of a buffer that holds only votes at or above that floor).
// x = (u − cx)·z·inv_fx, y = −(v − cy)·z·inv_fy. Votes are appended in casting order. Loops
// are bounded by count ≤ the pixel budget, trees ≤ kMaxTrees, a record's votes ≤ lanes ≤ kMaxOjrLanes
// (validated at blob load). No allocation, no state between calls.
//
// Every helper below has internal linkage: each ISA folder compiles this header with its own
// instruction-set flags, and an externally visible inline copy could be the one the linker keeps
// for every caller (an illegal instruction on a CPU without that ISA, at -O0 where nothing inlines).
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "forest_blob/blob_format.h"
#include "runtime/depthpose.h"

namespace dp {

struct Vote {
  float x, y, z;   // metres
  float weight;    // p·z² (BPC) or w·z² (OJR)
  uint32_t order;  // casting order (canonical order for aggregation)
  uint32_t start;  // 1 when this vote may seed mean shift (BPC: p > λc)
};

namespace kernels {

using VoteBufferFullFn = float (*)(void* ctx, int joint);

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
  VoteBufferFullFn on_full;
  void* ctx;
};

constexpr int32_t kMaxOjrLanes = blob::kMaxJoints * blob::kMaxVotesPerLeafJoint;

struct OjrScanArgs {
  const EvaluatedPixel* pixels;
  int32_t count;
  const uint32_t* leaves;       // tree-major, as BpcScanArgs
  int32_t leaf_stride;
  int32_t trees;
  const uint32_t* leaf_offsets; // record r's votes are [leaf_offsets[r], leaf_offsets[r + 1]) (validated)
  const blob::OjrVote* leaf_votes;
  const uint8_t* vote_lanes;    // per vote its lane j·K + k < lanes, increasing within a record
  int32_t lanes;                // joint_count · K ≤ kMaxOjrLanes
  int32_t k_votes;              // K
  float cx, cy, inv_fx, inv_fy;
  const uint32_t* lane_len2;    // [lanes] squared vote length limit (mm²); 0xFFFFFFFF = no limit
  float* lane_floor;            // [kMaxOjrLanes], 16-byte aligned; joint j's lanes updated by on_full
  const uint8_t* user_filter;   // nullptr: every pixel
  int32_t user_stride;
  uint8_t user_id;
  Vote* votes;                  // [kMaxJoints][slots]
  int32_t slots;
  int32_t full_at;              // 1..slots: a buffer holding this many votes goes to on_full
  int32_t* vote_counts;         // [kMaxJoints]
  int32_t* lane_candidates;     // [kMaxOjrLanes] (16-byte aligned) added to, or nullptr
  VoteBufferFullFn on_full;
  void* ctx;
};

using BpcScanFn = void (*)(const BpcScanArgs& args);
using OjrScanFn = void (*)(const OjrScanArgs& args);
namespace ref { void bpc_scan(const BpcScanArgs& args); void ojr_scan(const OjrScanArgs& args); }
namespace sse41 { void bpc_scan(const BpcScanArgs& args); void ojr_scan(const OjrScanArgs& args); }
namespace avx2 { void bpc_scan(const BpcScanArgs& args); }
namespace avx512 { void bpc_scan(const BpcScanArgs& args); }
namespace neon { void bpc_scan(const BpcScanArgs& args); }

// nullptr when the CPU or this build lacks the ISA (kBest: the widest available).
BpcScanFn bpc_scan_kernel(KernelIsa isa);

// Pixels ahead whose joint-mass rows / OJR leaves are prefetched: they are random reads beyond L1.
constexpr int32_t kVotePrefetchAhead = 16;

namespace {

// The shared tail of every ISA's BPC scan: x and y once per pixel with a survivor, then one append
// per surviving joint (`keep` bit j), in joint order.
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

inline void prefetch_mass_rows_ahead(const BpcScanArgs& a, int32_t i) {
  if (i + kVotePrefetchAhead < a.count)
    for (int t = 0; t < a.trees; ++t) __builtin_prefetch(mass_row(a, t, i + kVotePrefetchAhead), 0, 3);
}

inline bool skipped(const uint8_t* filter, int32_t stride, uint8_t id, const EvaluatedPixel& px) {
  return filter && filter[size_t(px.v) * size_t(stride) + px.u] != id;
}
inline bool skipped(const BpcScanArgs& a, const EvaluatedPixel& px) {
  return skipped(a.user_filter, a.user_stride, a.user_id, px);
}
inline bool skipped(const OjrScanArgs& a, const EvaluatedPixel& px) {
  return skipped(a.user_filter, a.user_stride, a.user_id, px);
}

// Pixel i's OJR leaf record in tree t: its votes are [*first, *end) of leaf_votes / vote_lanes.
inline void ojr_leaf_range(const OjrScanArgs& a, int t, int32_t i, uint32_t* first, uint32_t* end) {
  const uint32_t r = a.leaves[size_t(t) * a.leaf_stride + i];
  *first = a.leaf_offsets[r];
  *end = a.leaf_offsets[r + 1];
}

// The votes and lanes of the pixel kVotePrefetchAhead ahead (its offsets are prefetched one step
// earlier, kVotePrefetchAhead further ahead, so they are usually in cache by now).
inline void prefetch_ojr_leaves_ahead(const OjrScanArgs& a, int32_t i) {
  if (i + 2 * kVotePrefetchAhead < a.count)
    for (int t = 0; t < a.trees; ++t)
      __builtin_prefetch(a.leaf_offsets + a.leaves[size_t(t) * a.leaf_stride + i + 2 * kVotePrefetchAhead], 0, 3);
  if (i + kVotePrefetchAhead < a.count)
    for (int t = 0; t < a.trees; ++t) {
      uint32_t first, end;
      ojr_leaf_range(a, t, i + kVotePrefetchAhead, &first, &end);
      const char* ahead = reinterpret_cast<const char*>(a.leaf_votes + first);
      for (size_t b = 0; b < size_t(end - first) * sizeof(blob::OjrVote); b += 64) __builtin_prefetch(ahead + b, 0, 3);
      __builtin_prefetch(a.vote_lanes + first, 0, 3);
    }
}

// Appends lane l's vote of pixel i, tree t (the OJR contract's Vote) and handles a full buffer.
inline void append_ojr_vote(const OjrScanArgs& a, int32_t i, int t, int l, float x, float y, float z, float weight,
                            const blob::OjrVote& ov) {
  const int j = l / a.k_votes, k = l - j * a.k_votes;
  const uint32_t order = (uint32_t(i) * uint32_t(a.trees) + uint32_t(t)) * uint32_t(a.k_votes) + uint32_t(k);
  int32_t& n = a.vote_counts[j];
  a.votes[size_t(j) * size_t(a.slots) + size_t(n++)] =
      Vote{x + float(ov.dx_mm) * 0.001f, y + float(ov.dy_mm) * 0.001f, z + float(ov.dz_mm) * 0.001f, weight, order, 1};
  if (n == a.full_at) {
    const float floor = a.on_full(a.ctx, j);
    for (int q = j * a.k_votes; q < (j + 1) * a.k_votes; ++q) a.lane_floor[q] = floor;
  }
}

// The OJR candidate test of one lane: weight ≠ 0 and squared length within the lane's limit
// (|offset|² ≤ 3·2^30 fits uint32, as does the limit).
inline bool ojr_live(const blob::OjrVote& ov, uint32_t len2) {
  const uint32_t d2 = uint32_t(int32_t(ov.dx_mm) * ov.dx_mm) + uint32_t(int32_t(ov.dy_mm) * ov.dy_mm) +
                      uint32_t(int32_t(ov.dz_mm) * ov.dz_mm);
  return ov.weight != 0 && d2 <= len2;
}

// The reference's handling of one lane of tree t's leaf for pixel i: the candidate test, the
// candidate count, the vote's weight (its weight times z², as float) against the lane's floor, and
// the append. The SIMD scans use it for the lanes that do not fill a vector.
inline void scan_ojr_lane(const OjrScanArgs& a, int32_t i, int t, int l, float x, float y, float z, float z2,
                          const blob::OjrVote& ov) {
  if (!ojr_live(ov, a.lane_len2[l])) return;
  if (a.lane_candidates) ++a.lane_candidates[l];
  const float weight = float(ov.weight) * z2;
  if (weight < a.lane_floor[l]) return;
  append_ojr_vote(a, i, t, l, x, y, z, weight, ov);
}

}  // namespace
}  // namespace kernels
}  // namespace dp
