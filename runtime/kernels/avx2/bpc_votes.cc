// AVX2 BPC vote scan: the 16 joints of a pixel in two registers. Same weights as the reference
// caster bit for bit (vote_kernel.h: exact integer sums, then the same three float products).
#include <immintrin.h>

#include "runtime/kernels/vote_kernel.h"

namespace dp::kernels::avx2 {

void bpc_scan(const BpcScanArgs& a) {
  const __m256 inv_total = _mm256_set1_ps(a.inv_total);
  const __m256i zero = _mm256_setzero_si256();
  __m256i cand[2] = {zero, zero};
  alignas(32) float w[kMaxJoints];
  alignas(32) uint32_t mass[kMaxJoints];
  for (int32_t i = 0; i < a.count; ++i) {
    const EvaluatedPixel px = a.pixels[i];
    if (skipped(a, px)) continue;
    prefetch_mass_rows_ahead(a, i);
    __m256i acc[2] = {zero, zero};
    for (int t = 0; t < a.trees; ++t) {
      const uint16_t* m = mass_row(a, t, i);
      acc[0] = _mm256_add_epi32(acc[0], _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(m))));
      acc[1] = _mm256_add_epi32(acc[1], _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(m + 8))));
    }
    const float z = float(px.z_mm) * 0.001f;
    const __m256 z8 = _mm256_set1_ps(z);
    uint32_t keep = 0;
    __m256 wv[2];
    for (int h = 0; h < 2; ++h) {
      wv[h] = _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(_mm256_cvtepi32_ps(acc[h]), inv_total), z8), z8);
      const __m256i dead = _mm256_cmpeq_epi32(acc[h], zero);
      cand[h] = _mm256_sub_epi32(cand[h], _mm256_xor_si256(dead, _mm256_set1_epi32(-1)));  // live lanes: −(−1)
      const __m256 below = _mm256_cmp_ps(wv[h], _mm256_load_ps(a.floor + 8 * h), _CMP_LT_OQ);
      keep |= uint32_t(_mm256_movemask_ps(_mm256_or_ps(below, _mm256_castsi256_ps(dead))) ^ 0xFF) << (8 * h);
    }
    if (!keep) continue;
    _mm256_store_ps(w, wv[0]);
    _mm256_store_ps(w + 8, wv[1]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(mass), acc[0]);
    _mm256_store_si256(reinterpret_cast<__m256i*>(mass + 8), acc[1]);
    append_bpc_survivors(a, i, px, z, keep, w, mass);
  }
  alignas(32) uint32_t c[kMaxJoints];
  _mm256_store_si256(reinterpret_cast<__m256i*>(c), cand[0]);
  _mm256_store_si256(reinterpret_cast<__m256i*>(c + 8), cand[1]);
  for (int j = 0; j < kMaxJoints; ++j) a.candidates[j] += c[j];
}

}  // namespace dp::kernels::avx2
