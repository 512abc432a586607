#include "runtime/mean_shift.h"

#include <algorithm>

#include "runtime/debug_check.h"

namespace dp {

namespace {

// A cell coordinate ⌊q⌋ clamped to ±2^20 (NaN to the low end), 21 bits of a packed key. Floor by
// truncation and a correction (no libm call): q is within ±2^20, where every integer is a float.
inline uint64_t cell_coordinate(float q) {
  const float lim = 1048575.0f;
  q = !(q >= -lim) ? -lim : (q > lim ? lim : q);
  int64_t t = int64_t(q);
  if (float(t) > q) --t;
  return uint64_t(t + 1048576) & 0x1FFFFF;
}

// Joint j's cell votes (mean_shift.h) into the SoA rows; returns their count (≤ nv).
int32_t bin_votes(const Vote* votes, int32_t nv, float cell_m, const MeanShiftScratch& s, float* xr, float* yr,
                  float* zr, float* wr) {
  const float inv_c = 1.0f / cell_m;
  for (int32_t h = 0; h < kCellSlots; ++h) s.cell_ids[h] = -1;
  int32_t n = 0;
  for (int32_t i = 0; i < nv; ++i) {
    const Vote& v = votes[i];
    const uint64_t key = cell_coordinate(v.x * inv_c) << 42 | cell_coordinate(v.y * inv_c) << 21 |
                         cell_coordinate(v.z * inv_c);
    uint32_t h = uint32_t((key * 0x9E3779B97F4A7C15ull) >> 53) & (kCellSlots - 1);
    // At most nv < kCellSlots slots are taken, so a free or matching slot comes within kCellSlots probes.
    for (int32_t probe = 0; probe < kCellSlots; ++probe, h = (h + 1) & (kCellSlots - 1)) {
      if (s.cell_ids[h] < 0) {
        s.cell_ids[h] = n;
        s.cell_keys[h] = key;
        xr[n] = yr[n] = zr[n] = wr[n] = 0.0f;
        ++n;
        break;
      }
      if (s.cell_keys[h] == key) break;
    }
    const int32_t c = s.cell_ids[h];
    wr[c] = wr[c] + v.weight;
    xr[c] = xr[c] + v.weight * v.x;
    yr[c] = yr[c] + v.weight * v.y;
    zr[c] = zr[c] + v.weight * v.z;
  }
  for (int32_t c = 0; c < n; ++c) {
    const float inv_w = wr[c] > 0.0f ? 1.0f / wr[c] : 0.0f;
    xr[c] = xr[c] * inv_w;
    yr[c] = yr[c] * inv_w;
    zr[c] = zr[c] * inv_w;
  }
  return n;
}

inline float distance2(const float* q, float x, float y, float z) {
  return (q[0] - x) * (q[0] - x) + (q[1] - y) * (q[1] - y) + (q[2] - z) * (q[2] - z);
}

}  // namespace

void aggregate_proposals(const blob::RuntimeConfig& cfg, int joints, const VoteSets& sets, const MeanShiftScratch& scratch,
                         const MeanShiftKernels& k, FrameResult* r) {
  DP_DCHECK(k.sums != nullptr && k.mode_weights != nullptr);
  DP_DCHECK(r->starts_per_joint_used >= 1 && r->starts_per_joint_used <= blob::kMaxStartsCap);
  float* const sx_row = scratch.soa;
  float* const sy_row = scratch.soa + kSoaRow;
  float* const sz_row = scratch.soa + 2 * kSoaRow;
  float* const sw_row = scratch.soa + 3 * kSoaRow;
  float* const modes = scratch.modes;
  for (int j = 0; j < joints; ++j) {
    Vote* votes = sets.votes + size_t(j) * kVoteSlots;
    const int32_t nv = sets.counts[j];
    DP_DCHECK(nv >= 0 && nv <= blob::kMaxVotesCap);
    if (nv == 0) continue;
    // Canonical order (casting order, unique) so results do not depend on heap internals. The fast
    // casters keep their votes in casting order already; the reference's heap does not.
    auto by_order = [](const Vote& a, const Vote& b) { return a.order < b.order; };
    if (!std::is_sorted(votes, votes + nv, by_order)) std::sort(votes, votes + nv, by_order);
    // Starting points: eligible votes, evenly strided down to the cap.
    int32_t eligible = 0;
    for (int32_t i = 0; i < nv; ++i) eligible += votes[i].start ? 1 : 0;
    if (eligible == 0) continue;
    const int32_t cap = r->starts_per_joint_used;
    const int32_t step = (eligible + cap - 1) / cap;
    if (step > 1) r->flags |= kFlagStartsTruncated;
    int32_t ns = 0, e = 0;
    for (int32_t i = 0; i < nv && ns < cap; ++i)
      if (votes[i].start && (e++ % step) == 0) scratch.starts[ns++] = votes[i];
    const float b = float(cfg.joints[j].bandwidth_mm) * 0.001f;
    // Cell votes as structure of arrays, padded to a multiple of 16 lanes with weightless votes.
    const int32_t nc = bin_votes(votes, nv, kCellBandwidths * b, scratch, sx_row, sy_row, sz_row, sw_row);
    const int32_t padded = (nc + kernels::kMeanShiftLanes - 1) & ~(kernels::kMeanShiftLanes - 1);
    for (int32_t i = nc; i < padded; ++i) sx_row[i] = sy_row[i] = sz_row[i] = sw_row[i] = 0.0f;

    const float inv_b2 = 1.0f / (b * b);
    const float tol = float(cfg.merge_tolerance_mm) * 0.001f;
    const float tol2 = tol * tol;
    const float stop2 = 1e-6f;  // (1 mm)²
    const float skip2 = (kStartSkipBandwidths * b) * (kStartSkipBandwidths * b);
    int32_t nm = 0;             // modes: x, y, z, confidence
    for (int32_t s = 0; s < ns; ++s) {
      float mx = scratch.starts[s].x, my = scratch.starts[s].y, mz = scratch.starts[s].z;
      bool known = false;
      for (int32_t m = 0; m < nm && !known; ++m) known = distance2(modes + 4 * m, mx, my, mz) < skip2;
      if (known) continue;
      for (int it = 0; it < r->iterations_used; ++it) {
        float sum[4];
        k.sums(sx_row, sy_row, sz_row, sw_row, padded, mx, my, mz, inv_b2, sum);
        const float sw = sum[0];
        if (!(sw > 0.0f)) break;
        const float nx = sum[1] / sw, ny = sum[2] / sw, nz = sum[3] / sw;
        const float d2 = (nx - mx) * (nx - mx) + (ny - my) * (ny - my) + (nz - mz) * (nz - mz);
        mx = nx; my = ny; mz = nz;
        if (d2 < stop2) break;
        // A path that reaches a known mode ends there (it merges into it below): saves most iterations.
        bool joined = false;
        for (int32_t m = 0; m < nm && !joined; ++m) joined = distance2(modes + 4 * m, mx, my, mz) < tol2;
        if (joined) break;
      }
      int32_t m = 0;
      while (m < nm && !(distance2(modes + 4 * m, mx, my, mz) < tol2)) ++m;
      if (m == nm) {
        float* q = modes + 4 * nm++;
        q[0] = mx; q[1] = my; q[2] = mz; q[3] = 0.0f;
      }
    }
    // Confidence: every cell vote adds its weight to the nearest mode within 3 bandwidths.
    k.mode_weights(sx_row, sy_row, sz_row, sw_row, nc, modes, nm, 9.0f * b * b);
    // Top proposals by confidence (selection: nm ≤ kMaxStartsCap, output ≤ kMaxProposals).
    const int32_t out_cap = cfg.max_proposals_per_joint;
    int32_t out = 0;
    int32_t nonzero = 0;
    for (int32_t m = 0; m < nm; ++m) nonzero += modes[4 * m + 3] > 0.0f;
    if (nonzero > out_cap) r->flags |= kFlagProposalsTruncated;
    while (out < out_cap) {
      int32_t best = -1;
      for (int32_t m = 0; m < nm; ++m)
        if (modes[4 * m + 3] > 0.0f && (best < 0 || modes[4 * m + 3] > modes[4 * best + 3])) best = m;
      if (best < 0) break;
      r->proposals[j][out++] = JointProposal{modes[4 * best], modes[4 * best + 1], modes[4 * best + 2], modes[4 * best + 3]};
      modes[4 * best + 3] = -1.0f;
    }
    r->proposal_count[j] = out;
  }
}

}  // namespace dp
