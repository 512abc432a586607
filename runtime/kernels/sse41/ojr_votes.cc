// SSE4.1 OJR vote scan: four lanes (votes) of a leaf per step — the length test by pmaddwd, the
// weight products in one register — then ref/ojr_votes.cc's scalar test for the last lanes. Same
// votes as the reference bit for bit (vote_kernel.h).
#include <smmintrin.h>

#include "runtime/kernels/vote_kernel.h"

namespace dp::kernels::sse41 {

void ojr_scan(const OjrScanArgs& a) {
  // Squared vote lengths biased by 2^31 so the signed compare of SSE orders them as unsigned.
  alignas(16) uint32_t lane_len2_biased[kMaxOjrLanes];
  for (int l = 0; l < a.lanes; ++l) lane_len2_biased[l] = a.lane_len2[l] ^ 0x80000000u;
  const int full = a.lanes & ~3;
  const __m128i xyz_only = _mm_setr_epi16(-1, -1, -1, 0, -1, -1, -1, 0);
  const __m128i bias = _mm_set1_epi32(int32_t(0x80000000u));
  const __m128i zero = _mm_setzero_si128();
  const __m128i all_ones = _mm_set1_epi32(-1);
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
      const blob::OjrVote* leaf = ojr_leaf_of(a, t, i);
      int l = 0;
      for (; l < full; l += 4) {
        const __m128i va = _mm_loadu_si128(reinterpret_cast<const __m128i*>(leaf + l));
        const __m128i vb = _mm_loadu_si128(reinterpret_cast<const __m128i*>(leaf + l + 2));
        const __m128i xa = _mm_and_si128(va, xyz_only), xb = _mm_and_si128(vb, xyz_only);
        // dx²+dy², dz² per vote (pmaddwd; its only wrap, 2·(−32768)², is 2^31 read as unsigned),
        // then summed modulo 2^32 — exact, as the true sum is below 2^32.
        const __m128i d2 = _mm_hadd_epi32(_mm_madd_epi16(xa, xa), _mm_madd_epi16(xb, xb));
        const __m128i too_long = _mm_cmpgt_epi32(_mm_xor_si128(d2, bias),
                                                 _mm_load_si128(reinterpret_cast<const __m128i*>(lane_len2_biased + l)));
        const __m128i wa = _mm_srli_epi64(va, 48), wb = _mm_srli_epi64(vb, 48);  // weights in dwords 0, 2
        const __m128i wq = _mm_castps_si128(
            _mm_shuffle_ps(_mm_castsi128_ps(wa), _mm_castsi128_ps(wb), _MM_SHUFFLE(2, 0, 2, 0)));
        const __m128i dead = _mm_or_si128(too_long, _mm_cmpeq_epi32(wq, zero));
        const __m128 w = _mm_mul_ps(_mm_cvtepi32_ps(wq), z2_4);
        const __m128 below = _mm_cmplt_ps(w, _mm_load_ps(a.lane_floor + l));
        const int dead_bits = _mm_movemask_ps(_mm_castsi128_ps(dead)), below_bits = _mm_movemask_ps(below);
        if (a.lane_candidates) {
          __m128i* counts = reinterpret_cast<__m128i*>(a.lane_candidates + l);
          _mm_store_si128(counts, _mm_sub_epi32(_mm_load_si128(counts), _mm_andnot_si128(dead, all_ones)));
        }
        int keep = ~(below_bits | dead_bits) & 15;
        if (!keep) continue;
        alignas(16) float wl[4];
        _mm_store_ps(wl, w);
        for (; keep; keep &= keep - 1) {
          const int lane = l + __builtin_ctz(unsigned(keep));
          // An append above may have cut this joint and raised its floor: test the lane again, as
          // the reference (testing one lane at a time) does.
          if (wl[lane - l] < a.lane_floor[lane]) continue;
          append_ojr_vote(a, i, t, lane, x, y, z, wl[lane - l], leaf[lane]);
        }
      }
      for (; l < a.lanes; ++l) scan_ojr_lane(a, i, t, l, x, y, z, z2, leaf[l]);  // the last lanes
    }
  }
}

}  // namespace dp::kernels::sse41
