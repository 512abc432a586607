#include "runtime/ojr_votes.h"

#include <string.h>

#include "runtime/debug_check.h"

namespace dp {

namespace {
// Pixel i's leaf record in tree t.
inline uint32_t record_of(const CastInputs& in, int t, int32_t i) { return in.leaves[size_t(t) * in.leaf_stride + i]; }
}  // namespace

void ojr_lane_len2(const blob::LoadedBlob& b, const blob::RuntimeConfig& cfg, uint32_t* out) {
  const int k_votes = b.meta->votes_per_joint;
  const int lanes = b.meta->joint_count * k_votes;
  for (int l = 0; l < kernels::kMaxOjrLanes; ++l) {
    const uint32_t len = l < lanes ? cfg.joints[l / k_votes].vote_length_mm : 0;
    out[l] = len == 0 ? 0xFFFFFFFFu : len * len;
  }
}

void build_ojr_live_votes(const blob::LoadedBlob& b, const blob::RuntimeConfig& cfg, uint32_t* offsets,
                          blob::OjrVote* votes, uint8_t* lanes) {
  DP_DCHECK(use_ojr_live_votes(b));
  uint32_t len2[kernels::kMaxOjrLanes];
  ojr_lane_len2(b, cfg, len2);
  const blob::OjrVote* stored = b.ojr_votes();
  uint32_t n = 0;
  for (uint32_t r = 0; r < b.meta->leaf_count; ++r) {
    offsets[r] = n;
    for (uint32_t e = b.leaf_first(r); e < b.leaf_offsets[r + 1]; ++e) {
      if (!kernels::ojr_live(stored[e], len2[b.entry_tags[e]])) continue;
      votes[n] = stored[e];
      lanes[n++] = b.entry_tags[e];
    }
  }
  offsets[b.meta->leaf_count] = n;
}

uint32_t cast_ojr_votes_reference(const CastInputs& in, const VoteSets& sets) {
  const blob::LoadedBlob& b = *in.blob;
  const blob::RuntimeConfig& cfg = *in.config;
  const int trees = in.blob->tree_count();
  const int k_votes = in.blob->meta->votes_per_joint;
  const float inv_fx = 1.0f / in.intrinsics.fx, inv_fy = 1.0f / in.intrinsics.fy;
  uint32_t flags = 0;
  float floor_weight[blob::kMaxJoints];
  int64_t len2[blob::kMaxJoints];
  for (int j = 0; j < blob::kMaxJoints; ++j) {
    floor_weight[j] = -1.0f;
    const int64_t len = cfg.joints[j].vote_length_mm;
    len2[j] = len == 0 ? INT64_MAX : len * len;
  }
  for (int32_t i = 0; i < in.count; ++i) {
    const EvaluatedPixel px = in.pixels[i];
    if (skipped_by_user_filter(in, px)) continue;
    const float z = float(px.z_mm) * 0.001f;
    const float z2 = z * z;
    const float x = (float(px.u) - in.intrinsics.cx) * z * inv_fx;
    const float y = -(float(px.v) - in.intrinsics.cy) * z * inv_fy;
    for (int t = 0; t < trees; ++t) {
      const uint32_t r = record_of(in, t, i);
      // The record's votes in lane (joint, k) order: at most joints·K of them (validated at load).
      for (uint32_t e = b.leaf_first(r); e < b.leaf_offsets[r + 1]; ++e) {
        const int j = b.entry_tags[e] / k_votes, k = b.entry_tags[e] % k_votes;
        const blob::OjrVote& ov = b.ojr_votes()[e];
        const int64_t d2 = int64_t(ov.dx_mm) * ov.dx_mm + int64_t(ov.dy_mm) * ov.dy_mm + int64_t(ov.dz_mm) * ov.dz_mm;
        if (d2 > len2[j]) continue;
        const float weight = float(ov.weight) * z2;
        if (weight < floor_weight[j]) {
          flags |= kFlagVotesTruncated;
          continue;
        }
        const uint32_t order = (uint32_t(i) * uint32_t(trees) + uint32_t(t)) * uint32_t(k_votes) + uint32_t(k);
        Vote v{x + float(ov.dx_mm) * 0.001f, y + float(ov.dy_mm) * 0.001f, z + float(ov.dz_mm) * 0.001f, weight,
               order, 1};
        Vote* heap = sets.votes + size_t(j) * kVoteSlots;
        if (push_top_n(heap, &sets.counts[j], in.cap, v)) flags |= kFlagVotesTruncated;
        if (sets.counts[j] == in.cap) floor_weight[j] = heap[0].weight;
      }
    }
  }
  return flags;
}

namespace {

// The fast caster's floor guess: as the BPC guess (bpc_votes.cc), over each sampled pixel's live
// votes (trees × K per joint), aiming at kOjrGuessQuarterNsubs / 4 · Nsub votes per joint; a joint
// whose sampled votes are fewer than twice the rank gets no guess.
void guess_ojr_floors(const CastInputs& in, const OjrVoteTable& table, const uint32_t* lane_len2, float* floor) {
  for (int j = 0; j < blob::kMaxJoints; ++j) floor[j] = -1.0f;
  const int trees = in.blob->tree_count();
  const int joints = in.blob->meta->joint_count;
  const int k_votes = in.blob->meta->votes_per_joint;
  const int32_t step = in.count / kFloorSamples > 1 ? in.count / kFloorSamples : 1;
  // sampled votes at or above the guess
  const int32_t rank = (kOjrGuessQuarterNsubs * in.cap + 4 * step - 1) / (4 * step);
  memset(in.guess_hist, 0, sizeof(uint16_t) * blob::kMaxJoints * kGuessBuckets);
  int32_t sampled[blob::kMaxJoints] = {};
  int32_t taken = 0;
  for (int32_t i = 0; i < in.count && taken < kMaxFloorSamples; i += step) {
    const EvaluatedPixel px = in.pixels[i];
    if (skipped_by_user_filter(in, px)) continue;
    const int32_t ahead = i + kGuessPrefetchAhead * step;
    if (ahead < in.count)
      for (int t = 0; t < trees; ++t) {
        const uint32_t r = record_of(in, t, ahead);
        __builtin_prefetch(table.offsets + r, 0, 3);
        __builtin_prefetch(table.votes + table.offsets[r], 0, 3);
        __builtin_prefetch(table.lanes + table.offsets[r], 0, 3);
      }
    const float z = float(px.z_mm) * 0.001f;
    const float z2 = z * z;
    for (int t = 0; t < trees; ++t) {
      const uint32_t r = record_of(in, t, i);
      for (uint32_t e = table.offsets[r]; e < table.offsets[r + 1]; ++e) {
        const int l = table.lanes[e];
        const blob::OjrVote& ov = table.votes[e];
        if (!kernels::ojr_live(ov, lane_len2[l])) continue;
        const int j = l / k_votes;
        ++in.guess_hist[j * kGuessBuckets + guess_bucket(float(ov.weight) * z2, kGuessLowestKeyOjr)];
        ++sampled[j];
      }
    }
    ++taken;
  }
  for (int j = 0; j < joints; ++j)  // fewer than twice the rank: nearly everything is kept, no guess
    if (sampled[j] >= 2 * rank) floor[j] = floor_at_rank(in.guess_hist + j * kGuessBuckets, rank, kGuessLowestKeyOjr);
}

}  // namespace

// Exact for the reasons given at cast_bpc_votes_fast (bpc_votes.cc): same weights, same total order,
// floors that only pre-filter, a guess verified after the scan.
uint32_t cast_ojr_votes_fast(const CastInputs& in, kernels::OjrScanFn scan, const VoteSets& sets) {
  DP_DCHECK(scan != nullptr);
  const blob::RuntimeConfig& cfg = *in.config;
  const int joints = in.blob->meta->joint_count;
  const int k_votes = in.blob->meta->votes_per_joint;
  const int lanes = joints * k_votes;  // a leaf: votes in (joint, k) order, one lane each
  const int32_t cap = in.cap;
  float floor_weight[blob::kMaxJoints];
  alignas(16) float lane_floor[kernels::kMaxOjrLanes];
  alignas(16) int32_t lane_candidates[kernels::kMaxOjrLanes] = {};  // live votes per lane (first scan)
  uint32_t lane_len2[kernels::kMaxOjrLanes];
  ojr_lane_len2(*in.blob, cfg, lane_len2);
  const OjrVoteTable table = in.ojr_live.offsets
                                 ? in.ojr_live
                                 : OjrVoteTable{in.blob->leaf_offsets, in.blob->ojr_votes(), in.blob->entry_tags};
  // Each joint's floor starts at a guess; a guess above the reference's top-Nsub is caught after the
  // scan and that joint is scanned again without one.
  guess_ojr_floors(in, table, lane_len2, floor_weight);
  for (int l = 0; l < lanes; ++l) lane_floor[l] = floor_weight[l / k_votes];
  CutWhenFull ctx{&sets, cap};
  kernels::OjrScanArgs a{in.pixels, in.count, in.leaves, in.leaf_stride, in.blob->tree_count(), table.offsets, table.votes,
                         table.lanes, lanes, k_votes, in.intrinsics.cx, in.intrinsics.cy,
                         1.0f / in.intrinsics.fx, 1.0f / in.intrinsics.fy, lane_len2, lane_floor, in.user_filter,
                         in.user_stride, in.user_id, sets.votes, kVoteSlots, 2 * cap, sets.counts, lane_candidates,
                         &cut_when_full, &ctx};
  scan(a);
  int32_t candidates[blob::kMaxJoints] = {};
  for (int l = 0; l < lanes; ++l) candidates[l / k_votes] += lane_candidates[l];
  bool again = false;
  for (int j = 0; j < joints; ++j) {
    // Fewer than min(cap, candidates) kept: the guess was above the reference's top-Nsub.
    const bool short_of_votes = sets.counts[j] < candidates[j] && sets.counts[j] < cap;
    floor_weight[j] = short_of_votes ? -1.0f : __builtin_inff();
    if (short_of_votes) sets.counts[j] = 0;
    again = again || short_of_votes;
  }
  if (again) {
    for (int l = 0; l < lanes; ++l) lane_floor[l] = floor_weight[l / k_votes];
    a.lane_candidates = nullptr;
    scan(a);
  }
  bool dropped = false;
  for (int j = 0; j < joints; ++j) dropped = dropped || candidates[j] > cap;
  finish_votes(sets, cap);
  return dropped ? uint32_t(kFlagVotesTruncated) : 0u;
}

}  // namespace dp
