// AVX2 mean-shift sums: the 16 lanes of mean_shift_kernel.h in 2 registers (lanes 0–7, 8–15).
// Bit-exact with ref/mean_shift.cc (same operations per lane, same reduction tree, no FMA).
#include <immintrin.h>

#include "runtime/kernels/mean_shift_kernel.h"

namespace dp::kernels::avx2 {

namespace {
inline __m256 exp_neg8(__m256 t) {
  const __m256 live = _mm256_cmp_ps(t, _mm256_set1_ps(80.0f), _CMP_LT_OQ);
  t = _mm256_min_ps(t, _mm256_set1_ps(80.0f));
  const __m256 y = _mm256_mul_ps(t, _mm256_set1_ps(-1.44269504f));
  const __m256 fi = _mm256_floor_ps(y);
  const __m256 f = _mm256_sub_ps(y, fi);
  __m256 p = _mm256_add_ps(_mm256_set1_ps(0.05550411f), _mm256_mul_ps(f, _mm256_set1_ps(0.00961813f)));
  p = _mm256_add_ps(_mm256_set1_ps(0.24022650f), _mm256_mul_ps(f, p));
  p = _mm256_add_ps(_mm256_set1_ps(0.69314718f), _mm256_mul_ps(f, p));
  p = _mm256_add_ps(_mm256_set1_ps(1.0f), _mm256_mul_ps(f, p));
  const __m256i e = _mm256_slli_epi32(_mm256_add_epi32(_mm256_cvttps_epi32(fi), _mm256_set1_epi32(127)), 23);
  return _mm256_and_ps(live, _mm256_mul_ps(p, _mm256_castsi256_ps(e)));
}

inline float reduce16(__m256 lo, __m256 hi) {
  const __m256 s = _mm256_add_ps(lo, hi);  // l + (l+8)
  const __m128 h = _mm_add_ps(_mm256_castps256_ps128(s), _mm256_extractf128_ps(s, 1));  // + (l+4)
  const __m128 q = _mm_add_ps(h, _mm_movehl_ps(h, h));                                   // + (l+2)
  return _mm_cvtss_f32(_mm_add_ss(q, _mm_shuffle_ps(q, q, 1)));                           // + (l+1)
}
}  // namespace

void mean_shift_sums(const float* xs, const float* ys, const float* zs, const float* ws, int32_t padded, float mx,
                     float my, float mz, float inv_b2, float* out) {
  const __m256 mx8 = _mm256_set1_ps(mx), my8 = _mm256_set1_ps(my), mz8 = _mm256_set1_ps(mz), ib = _mm256_set1_ps(inv_b2);
  __m256 sw[2], sx[2], sy[2], sz[2];
  for (int r = 0; r < 2; ++r) sw[r] = sx[r] = sy[r] = sz[r] = _mm256_setzero_ps();
  for (int32_t i = 0; i < padded; i += 16) {
    for (int r = 0; r < 2; ++r) {
      const int32_t o = i + 8 * r;
      const __m256 x = _mm256_loadu_ps(xs + o), y = _mm256_loadu_ps(ys + o), z = _mm256_loadu_ps(zs + o);
      const __m256 dx = _mm256_sub_ps(x, mx8), dy = _mm256_sub_ps(y, my8), dz = _mm256_sub_ps(z, mz8);
      const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
      const __m256 k = _mm256_mul_ps(_mm256_loadu_ps(ws + o), exp_neg8(_mm256_mul_ps(d2, ib)));
      sw[r] = _mm256_add_ps(sw[r], k);
      sx[r] = _mm256_add_ps(sx[r], _mm256_mul_ps(k, x));
      sy[r] = _mm256_add_ps(sy[r], _mm256_mul_ps(k, y));
      sz[r] = _mm256_add_ps(sz[r], _mm256_mul_ps(k, z));
    }
  }
  out[0] = reduce16(sw[0], sw[1]);
  out[1] = reduce16(sx[0], sx[1]);
  out[2] = reduce16(sy[0], sy[1]);
  out[3] = reduce16(sz[0], sz[1]);
}

}  // namespace dp::kernels::avx2
