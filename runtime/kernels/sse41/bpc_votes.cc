// SSE4.1 BPC vote scan: the 16 joints of a pixel in four registers. Same votes as ref/bpc_votes.cc
// bit for bit (vote_kernel.h); the AVX2 and AVX-512 files are the same computation in wider registers.
#include <smmintrin.h>

#include "runtime/kernels/vote_kernel.h"

namespace dp::kernels::sse41 {

void bpc_scan(const BpcScanArgs& a) {
  const __m128 inv_total = _mm_set1_ps(a.inv_total);
  const __m128i zero = _mm_setzero_si128();
  __m128i cand[4] = {zero, zero, zero, zero};
  alignas(16) float w[kMaxJoints];
  alignas(16) uint32_t mass[kMaxJoints];
  for (int32_t i = 0; i < a.count; ++i) {
    const EvaluatedPixel px = a.pixels[i];
    if (skipped(a, px)) continue;
    prefetch_mass_rows_ahead(a, i);
    __m128i acc[4] = {zero, zero, zero, zero};
    for (int t = 0; t < a.trees; ++t) {
      const uint16_t* m = mass_row(a, t, i);
      const __m128i lo = _mm_loadu_si128(reinterpret_cast<const __m128i*>(m));
      const __m128i hi = _mm_loadu_si128(reinterpret_cast<const __m128i*>(m + 8));
      acc[0] = _mm_add_epi32(acc[0], _mm_cvtepu16_epi32(lo));
      acc[1] = _mm_add_epi32(acc[1], _mm_cvtepu16_epi32(_mm_srli_si128(lo, 8)));
      acc[2] = _mm_add_epi32(acc[2], _mm_cvtepu16_epi32(hi));
      acc[3] = _mm_add_epi32(acc[3], _mm_cvtepu16_epi32(_mm_srli_si128(hi, 8)));
    }
    const float z = float(px.z_mm) * 0.001f;
    const __m128 z4 = _mm_set1_ps(z);
    uint32_t keep = 0;
    __m128 wv[4];
    for (int g = 0; g < 4; ++g) {
      wv[g] = _mm_mul_ps(_mm_mul_ps(_mm_mul_ps(_mm_cvtepi32_ps(acc[g]), inv_total), z4), z4);
      const __m128i dead = _mm_cmpeq_epi32(acc[g], zero);
      cand[g] = _mm_sub_epi32(cand[g], _mm_xor_si128(dead, _mm_set1_epi32(-1)));  // live lanes: −(−1)
      const __m128 below = _mm_cmplt_ps(wv[g], _mm_load_ps(a.floor + 4 * g));
      keep |= uint32_t(_mm_movemask_ps(_mm_or_ps(below, _mm_castsi128_ps(dead))) ^ 0xF) << (4 * g);
    }
    if (!keep) continue;
    for (int g = 0; g < 4; ++g) {
      _mm_store_ps(w + 4 * g, wv[g]);
      _mm_store_si128(reinterpret_cast<__m128i*>(mass + 4 * g), acc[g]);
    }
    append_bpc_survivors(a, i, px, z, keep, w, mass);
  }
  alignas(16) uint32_t c[kMaxJoints];
  for (int g = 0; g < 4; ++g) _mm_store_si128(reinterpret_cast<__m128i*>(c + 4 * g), cand[g]);
  for (int j = 0; j < kMaxJoints; ++j) a.candidates[j] += c[j];
}

}  // namespace dp::kernels::sse41
