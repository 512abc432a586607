#include "runtime/bpc_votes.h"

#include <string.h>

#include "runtime/debug_check.h"

namespace dp {

void build_joint_mass(const blob::LoadedBlob& b, const blob::RuntimeConfig& config, uint16_t* table) {
  for (uint32_t l = 0; l < b.meta->leaf_count; ++l) {
    uint32_t p[blob::kMaxParts] = {};  // the record's distribution, 0 for the parts it lacks
    blob::add_bpc_leaf(b, l, p);
    uint16_t* out = table + size_t(l) * blob::kMaxJoints;
    for (int j = 0; j < blob::kMaxJoints; ++j) {
      uint32_t mass = 0;
      if (j < b.meta->joint_count)
        for (uint32_t m = config.joints[j].part_mask; m; m &= m - 1) mass += p[__builtin_ctz(m)];
      out[j] = uint16_t(mass);  // Σ ≤ 32768 (validated at load)
    }
  }
}

uint32_t cast_bpc_votes_reference(const CastInputs& in, const VoteSets& sets) {
  const blob::LoadedBlob& b = *in.blob;
  const blob::RuntimeConfig& cfg = *in.config;
  const int joints = b.meta->joint_count;
  const int trees = b.tree_count();
  const float inv_fx = 1.0f / in.intrinsics.fx, inv_fy = 1.0f / in.intrinsics.fy;
  const float inv_total = 1.0f / (32768.0f * float(trees));
  uint32_t flags = 0;
  // Lightest kept weight per joint once its top-N set is full: lighter votes are rejected before
  // any work (exactly push_top_n's own rejection), which is the common case on large frames.
  float floor_weight[blob::kMaxJoints];
  for (int j = 0; j < blob::kMaxJoints; ++j) floor_weight[j] = -1.0f;
  for (int32_t i = 0; i < in.count; ++i) {
    const EvaluatedPixel px = in.pixels[i];
    if (skipped_by_user_filter(in, px)) continue;
    uint32_t mass[blob::kMaxJoints] = {};
    if (in.joint_mass) {
      for (int t = 0; t < trees; ++t) {
        const uint16_t* m = in.joint_mass + size_t(in.leaves[size_t(t) * in.leaf_stride + i]) * blob::kMaxJoints;
        for (int j = 0; j < blob::kMaxJoints; ++j) mass[j] += m[j];
      }
    } else {
      uint32_t acc[blob::kMaxParts] = {};
      for (int t = 0; t < trees; ++t) blob::add_bpc_leaf(b, in.leaves[size_t(t) * in.leaf_stride + i], acc);
      for (int j = 0; j < joints; ++j)
        for (uint32_t m = cfg.joints[j].part_mask; m; m &= m - 1) mass[j] += acc[__builtin_ctz(m)];
    }
    const float z = float(px.z_mm) * 0.001f;
    const float x = (float(px.u) - in.intrinsics.cx) * z * inv_fx;
    const float y = -(float(px.v) - in.intrinsics.cy) * z * inv_fy;
    for (int j = 0; j < joints; ++j) {
      if (mass[j] == 0) continue;
      const float p = float(mass[j]) * inv_total;
      const float weight = p * z * z;
      if (weight < floor_weight[j]) {
        flags |= kFlagVotesTruncated;
        continue;
      }
      const blob::JointConfig& jc = cfg.joints[j];
      Vote v{x, y, z + float(jc.push_back_mm) * 0.001f, weight, uint32_t(i),
             uint32_t(uint64_t(mass[j]) > uint64_t(jc.prob_threshold_q15) * uint64_t(trees) ? 1 : 0)};
      Vote* heap = sets.votes + size_t(j) * kVoteSlots;
      if (push_top_n(heap, &sets.counts[j], in.cap, v)) flags |= kFlagVotesTruncated;
      if (sets.counts[j] == in.cap) floor_weight[j] = heap[0].weight;
    }
  }
  return flags;
}

namespace {

// A guess of each joint's final floor: about the weight that 2·cap candidates reach, estimated on
// every k-th pixel (k ≈ pixels / kFloorSamples) and rounded down to its 1/8-octave bucket. A guess
// may be wrong either way; too low costs appends, too high is caught by cast_bpc_votes_fast's check
// and rescanned. −1 = no guess.
void guess_bpc_floors(const CastInputs& in, float* floor) {
  for (int j = 0; j < blob::kMaxJoints; ++j) floor[j] = -1.0f;
  const int trees = in.blob->tree_count();
  const int joints = in.blob->meta->joint_count;
  const int32_t step = in.count / kFloorSamples > 1 ? in.count / kFloorSamples : 1;
  const int32_t rank = (2 * in.cap + step - 1) / step;  // sampled pixels at or above the guess
  if (rank >= in.count / step / 2) return;              // nearly everything is kept: no guess
  memset(in.guess_hist, 0, sizeof(uint16_t) * blob::kMaxJoints * kGuessBuckets);
  const float inv_total = 1.0f / (32768.0f * float(trees));
  auto row = [&](int32_t i, int t) {
    return in.joint_mass + size_t(in.leaves[size_t(t) * in.leaf_stride + i]) * blob::kMaxJoints;
  };
  int32_t taken = 0;
  for (int32_t i = 0; i < in.count && taken < kMaxFloorSamples; i += step) {
    const EvaluatedPixel px = in.pixels[i];
    if (skipped_by_user_filter(in, px)) continue;
    const int32_t ahead = i + kGuessPrefetchAhead * step;
    if (ahead < in.count)
      for (int t = 0; t < trees; ++t) __builtin_prefetch(row(ahead, t), 0, 3);
    uint32_t mass[blob::kMaxJoints] = {};
    for (int t = 0; t < trees; ++t) {
      const uint16_t* m = row(i, t);
      for (int j = 0; j < blob::kMaxJoints; ++j) mass[j] += m[j];
    }
    const float z = float(px.z_mm) * 0.001f;
    for (int j = 0; j < joints; ++j)
      ++in.guess_hist[j * kGuessBuckets + guess_bucket(float(mass[j]) * inv_total * z * z, kGuessLowestKey)];
    ++taken;
  }
  if (rank >= taken) return;
  for (int j = 0; j < joints; ++j) floor[j] = floor_at_rank(in.guess_hist + j * kGuessBuckets, rank, kGuessLowestKey);
}

}  // namespace

// The kept votes equal the reference's: a candidate's weight is computed by the same float
// operations in the same order (vote_kernel.h); the kept set is the top Nsub under the same total
// order, which is unique, so it does not matter that the reference finds it with a heap and this
// caster with buffered selection; a floor only pre-filters votes lighter than it, and the kept set
// is proven to lie at or above every floor used (the guess is verified after the scan). The buffers
// stay in casting order (every cut compacts stably), so mean shift needs no sort after them.
uint32_t cast_bpc_votes_fast(const CastInputs& in, kernels::BpcScanFn scan, const VoteSets& sets) {
  if (!in.joint_mass) return cast_bpc_votes_reference(in, sets);  // huge forests keep no table
  DP_DCHECK(scan != nullptr);
  const blob::RuntimeConfig& cfg = *in.config;
  const int joints = in.blob->meta->joint_count;
  const int trees = in.blob->tree_count();
  const int32_t cap = in.cap;
  alignas(64) float floor[blob::kMaxJoints];
  alignas(64) float push_back_m[blob::kMaxJoints] = {};
  alignas(64) uint32_t start_threshold[blob::kMaxJoints] = {};
  uint32_t candidates[blob::kMaxJoints] = {}, ignored[blob::kMaxJoints] = {};
  for (int j = 0; j < joints; ++j) {
    push_back_m[j] = float(cfg.joints[j].push_back_mm) * 0.001f;
    start_threshold[j] = uint32_t(cfg.joints[j].prob_threshold_q15) * uint32_t(trees);
  }
  guess_bpc_floors(in, floor);
  CutWhenFull ctx{&sets, cap};
  kernels::BpcScanArgs a{in.pixels, in.count, in.leaves, in.leaf_stride, trees, in.joint_mass,
                         1.0f / (32768.0f * float(trees)), in.intrinsics.cx, in.intrinsics.cy,
                         1.0f / in.intrinsics.fx, 1.0f / in.intrinsics.fy, push_back_m, start_threshold, floor,
                         in.user_filter, in.user_stride, in.user_id, sets.votes, kVoteSlots, sets.counts,
                         candidates, &cut_when_full, &ctx};
  scan(a);
  // The guess was too high for a joint when fewer than min(cap, candidates) votes reached it: the
  // reference keeps some lighter vote. Such joints are scanned again without a floor (the others
  // with an unreachable one), which is always exact.
  bool again = false;
  for (int j = 0; j < joints; ++j) {
    const bool short_of_votes = uint32_t(sets.counts[j]) < candidates[j] && sets.counts[j] < cap;
    floor[j] = short_of_votes ? -1.0f : __builtin_inff();
    if (short_of_votes) sets.counts[j] = 0;
    again = again || short_of_votes;
  }
  if (again) {
    a.candidates = ignored;
    scan(a);
  }
  bool dropped = false;
  for (int j = 0; j < joints; ++j) dropped = dropped || candidates[j] > uint32_t(cap);
  finish_votes(sets, cap);
  return dropped ? uint32_t(kFlagVotesTruncated) : 0u;
}

}  // namespace dp
