// AVX-512 BPC vote scan: the 16 joints of a pixel in one register. Same weights as the reference
// caster bit for bit (vote_kernel.h: exact integer sums, then the same three float products).
// GCC 12's _mm512_undefined_*() (a self-initialised variable) trips -W(maybe-)uninitialized when
// inlined into masked intrinsics; the value is never read.
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>

#include "runtime/kernels/vote_kernel.h"

namespace dp::kernels::avx512 {

void bpc_scan(const BpcScanArgs& a) {
  const __m512 inv_total = _mm512_set1_ps(a.inv_total);
  __m512i cand = _mm512_setzero_si512();
  const __m512i one = _mm512_set1_epi32(1);
  alignas(64) float w[kMaxJoints];
  alignas(64) uint32_t mass[kMaxJoints];
  for (int32_t i = 0; i < a.count; ++i) {
    const EvaluatedPixel px = a.pixels[i];
    if (skipped(a, px)) continue;
    prefetch_mass_rows_ahead(a, i);
    __m512i acc = _mm512_setzero_si512();
    for (int t = 0; t < a.trees; ++t) {
      const uint16_t* m = mass_row(a, t, i);
      acc = _mm512_add_epi32(acc, _mm512_cvtepu16_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(m))));
    }
    const float z = float(px.z_mm) * 0.001f;
    const __m512 z16 = _mm512_set1_ps(z);
    const __m512 wv = _mm512_mul_ps(_mm512_mul_ps(_mm512_mul_ps(_mm512_cvtepi32_ps(acc), inv_total), z16), z16);
    const __mmask16 live = _mm512_test_epi32_mask(acc, acc);
    cand = _mm512_mask_add_epi32(cand, live, cand, one);
    const __mmask16 keep = _mm512_mask_cmp_ps_mask(live, wv, _mm512_load_ps(a.floor), _CMP_NLT_UQ);
    if (!keep) continue;
    _mm512_store_ps(w, wv);
    _mm512_store_si512(mass, acc);
    append_bpc_survivors(a, i, px, z, keep, w, mass);
  }
  alignas(64) uint32_t c[kMaxJoints];
  _mm512_store_si512(c, cand);
  for (int j = 0; j < kMaxJoints; ++j) a.candidates[j] += c[j];
}

}  // namespace dp::kernels::avx512
