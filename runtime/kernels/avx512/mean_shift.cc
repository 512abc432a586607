// AVX-512 mean-shift sums: the 16 lanes of mean_shift_kernel.h in one register.
// Bit-exact with ref/mean_shift.cc (same operations per lane, same reduction tree, no FMA).
// GCC 12's _mm512_undefined_*() (a self-initialised variable) trips -W(maybe-)uninitialized when
// inlined into masked intrinsics; the value is never read.
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>

#include "runtime/kernels/mean_shift_kernel.h"

namespace dp::kernels::avx512 {

namespace {
inline __m512 exp_neg16(__m512 t) {
  const __mmask16 live = _mm512_cmp_ps_mask(t, _mm512_set1_ps(80.0f), _CMP_LT_OQ);
  t = _mm512_min_ps(t, _mm512_set1_ps(80.0f));
  const __m512 y = _mm512_mul_ps(t, _mm512_set1_ps(-1.44269504f));
  const __m512 fi = _mm512_roundscale_ps(y, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  const __m512 f = _mm512_sub_ps(y, fi);
  __m512 p = _mm512_add_ps(_mm512_set1_ps(0.05550411f), _mm512_mul_ps(f, _mm512_set1_ps(0.00961813f)));
  p = _mm512_add_ps(_mm512_set1_ps(0.24022650f), _mm512_mul_ps(f, p));
  p = _mm512_add_ps(_mm512_set1_ps(0.69314718f), _mm512_mul_ps(f, p));
  p = _mm512_add_ps(_mm512_set1_ps(1.0f), _mm512_mul_ps(f, p));
  const __m512i e = _mm512_slli_epi32(_mm512_add_epi32(_mm512_cvttps_epi32(fi), _mm512_set1_epi32(127)), 23);
  return _mm512_maskz_mul_ps(live, p, _mm512_castsi512_ps(e));
}

inline float reduce16(__m512 v) {
  const __m256 s = _mm256_add_ps(_mm512_castps512_ps256(v), _mm512_extractf32x8_ps(v, 1));  // l + (l+8)
  const __m128 h = _mm_add_ps(_mm256_castps256_ps128(s), _mm256_extractf128_ps(s, 1));       // + (l+4)
  const __m128 q = _mm_add_ps(h, _mm_movehl_ps(h, h));                                        // + (l+2)
  return _mm_cvtss_f32(_mm_add_ss(q, _mm_shuffle_ps(q, q, 1)));                                // + (l+1)
}
}  // namespace

void mean_shift_sums(const float* xs, const float* ys, const float* zs, const float* ws, int32_t padded, float mx,
                     float my, float mz, float inv_b2, float* out) {
  const __m512 mx16 = _mm512_set1_ps(mx), my16 = _mm512_set1_ps(my), mz16 = _mm512_set1_ps(mz);
  const __m512 ib = _mm512_set1_ps(inv_b2);
  __m512 sw = _mm512_setzero_ps(), sx = sw, sy = sw, sz = sw;
  for (int32_t i = 0; i < padded; i += 16) {
    const __m512 x = _mm512_loadu_ps(xs + i), y = _mm512_loadu_ps(ys + i), z = _mm512_loadu_ps(zs + i);
    const __m512 dx = _mm512_sub_ps(x, mx16), dy = _mm512_sub_ps(y, my16), dz = _mm512_sub_ps(z, mz16);
    const __m512 d2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)), _mm512_mul_ps(dz, dz));
    const __m512 k = _mm512_mul_ps(_mm512_loadu_ps(ws + i), exp_neg16(_mm512_mul_ps(d2, ib)));
    sw = _mm512_add_ps(sw, k);
    sx = _mm512_add_ps(sx, _mm512_mul_ps(k, x));
    sy = _mm512_add_ps(sy, _mm512_mul_ps(k, y));
    sz = _mm512_add_ps(sz, _mm512_mul_ps(k, z));
  }
  out[0] = reduce16(sw);
  out[1] = reduce16(sx);
  out[2] = reduce16(sy);
  out[3] = reduce16(sz);
}

}  // namespace dp::kernels::avx512
