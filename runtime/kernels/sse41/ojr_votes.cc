// SSE4.1 OJR vote scan: four stored votes of a leaf record per step — the length test by pmaddwd,
// the weight products in one register, each vote's lane limits gathered by its lane tag — then
// ref/ojr_votes.cc's scalar test for the record's last votes. Same votes as the reference bit for
// bit (vote_kernel.h).
#include <smmintrin.h>

#include "runtime/kernels/vote_kernel.h"

namespace dp::kernels::sse41 {

void ojr_scan(const OjrScanArgs& a) {
  // Squared vote lengths biased by 2^31 so the signed compare of SSE orders them as unsigned.
  alignas(16) uint32_t lane_len2_biased[kMaxOjrLanes];
  for (int l = 0; l < a.lanes; ++l) lane_len2_biased[l] = a.lane_len2[l] ^ 0x80000000u;
  const __m128i xyz_only = _mm_setr_epi16(-1, -1, -1, 0, -1, -1, -1, 0);
  const __m128i bias = _mm_set1_epi32(int32_t(0x80000000u));
  const __m128i zero = _mm_setzero_si128();
  for (int32_t i = 0; i < a.count; ++i) {
    const EvaluatedPixel px = a.pixels[i];
    if (skipped(a, px)) continue;
    const float z = float(px.z_mm) * 0.001f;
    const float z2 = z * z;
    const float x = (float(px.u) - a.cx) * z * a.inv_fx;
    const float y = -(float(px.v) - a.cy) * z * a.inv_fy;
    const __m128 z2_4 = _mm_set1_ps(z2);
    prefetch_ojr_leaves_ahead(a, i);
    for (int t = 0; t < a.trees; ++t) {
      uint32_t e, end;
      ojr_leaf_range(a, t, i, &e, &end);
      for (; e + 4 <= end; e += 4) {
        const uint8_t* lane = a.vote_lanes + e;
        const __m128i va = _mm_loadu_si128(reinterpret_cast<const __m128i*>(a.leaf_votes + e));
        const __m128i vb = _mm_loadu_si128(reinterpret_cast<const __m128i*>(a.leaf_votes + e + 2));
        const __m128i xa = _mm_and_si128(va, xyz_only), xb = _mm_and_si128(vb, xyz_only);
        // dx²+dy², dz² per vote (pmaddwd; its only wrap, 2·(−32768)², is 2^31 read as unsigned),
        // then summed modulo 2^32 — exact, as the true sum is below 2^32.
        const __m128i d2 = _mm_hadd_epi32(_mm_madd_epi16(xa, xa), _mm_madd_epi16(xb, xb));
        const __m128i len2 = _mm_setr_epi32(int32_t(lane_len2_biased[lane[0]]), int32_t(lane_len2_biased[lane[1]]),
                                            int32_t(lane_len2_biased[lane[2]]), int32_t(lane_len2_biased[lane[3]]));
        const __m128i too_long = _mm_cmpgt_epi32(_mm_xor_si128(d2, bias), len2);
        const __m128i wa = _mm_srli_epi64(va, 48), wb = _mm_srli_epi64(vb, 48);  // weights in dwords 0, 2
        const __m128i wq = _mm_castps_si128(
            _mm_shuffle_ps(_mm_castsi128_ps(wa), _mm_castsi128_ps(wb), _MM_SHUFFLE(2, 0, 2, 0)));
        const __m128i dead = _mm_or_si128(too_long, _mm_cmpeq_epi32(wq, zero));
        const __m128 w = _mm_mul_ps(_mm_cvtepi32_ps(wq), z2_4);
        const __m128 floor = _mm_setr_ps(a.lane_floor[lane[0]], a.lane_floor[lane[1]], a.lane_floor[lane[2]],
                                         a.lane_floor[lane[3]]);
        const int dead_bits = _mm_movemask_ps(_mm_castsi128_ps(dead));
        const int below_bits = _mm_movemask_ps(_mm_cmplt_ps(w, floor));
        if (a.lane_candidates)
          for (int live = ~dead_bits & 15; live; live &= live - 1) ++a.lane_candidates[lane[__builtin_ctz(unsigned(live))]];
        int keep = ~(below_bits | dead_bits) & 15;
        if (!keep) continue;
        alignas(16) float wl[4];
        _mm_store_ps(wl, w);
        for (; keep; keep &= keep - 1) {
          const int q = __builtin_ctz(unsigned(keep));
          // An append above may have cut this joint and raised its floor: test the vote again, as
          // the reference (testing one vote at a time) does.
          if (wl[q] < a.lane_floor[lane[q]]) continue;
          append_ojr_vote(a, i, t, lane[q], x, y, z, wl[q], a.leaf_votes[e + q]);
        }
      }
      for (; e < end; ++e) scan_ojr_lane(a, i, t, a.vote_lanes[e], x, y, z, z2, a.leaf_votes[e]);  // the last votes
    }
  }
}

}  // namespace dp::kernels::sse41
