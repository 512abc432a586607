// SSE4.1 mean-shift sums: the 16 lanes of mean_shift_kernel.h in 4 registers (lanes 0–3, 4–7,
// 8–11, 12–15). Bit-exact with ref/mean_shift.cc (same operations per lane, same reduction tree).
#include <smmintrin.h>

#include "runtime/kernels/mean_shift_kernel.h"

namespace dp::kernels::sse41 {

namespace {
// e^(−t) for t ≥ 0 (fast_math.h's exp_neg polynomial, branch-free); 0 for t ≥ 80.
inline __m128 exp_neg4(__m128 t) {
  const __m128 live = _mm_cmplt_ps(t, _mm_set1_ps(80.0f));
  t = _mm_min_ps(t, _mm_set1_ps(80.0f));
  const __m128 y = _mm_mul_ps(t, _mm_set1_ps(-1.44269504f));
  const __m128 fi = _mm_floor_ps(y);
  const __m128 f = _mm_sub_ps(y, fi);
  __m128 p = _mm_add_ps(_mm_set1_ps(0.05550411f), _mm_mul_ps(f, _mm_set1_ps(0.00961813f)));
  p = _mm_add_ps(_mm_set1_ps(0.24022650f), _mm_mul_ps(f, p));
  p = _mm_add_ps(_mm_set1_ps(0.69314718f), _mm_mul_ps(f, p));
  p = _mm_add_ps(_mm_set1_ps(1.0f), _mm_mul_ps(f, p));
  const __m128i e = _mm_slli_epi32(_mm_add_epi32(_mm_cvttps_epi32(fi), _mm_set1_epi32(127)), 23);
  return _mm_and_ps(live, _mm_mul_ps(p, _mm_castsi128_ps(e)));
}

// Lanes (l, l+4, l+8, l+12) held as r[0..3][l]: the fixed tree of the header.
inline float reduce16(const __m128 r[4]) {
  const __m128 h = _mm_add_ps(_mm_add_ps(r[0], r[2]), _mm_add_ps(r[1], r[3]));
  const __m128 q = _mm_add_ps(h, _mm_movehl_ps(h, h));
  return _mm_cvtss_f32(_mm_add_ss(q, _mm_shuffle_ps(q, q, 1)));
}
}  // namespace

void mean_shift_sums(const float* xs, const float* ys, const float* zs, const float* ws, int32_t padded, float mx,
                     float my, float mz, float inv_b2, float* out) {
  const __m128 mx4 = _mm_set1_ps(mx), my4 = _mm_set1_ps(my), mz4 = _mm_set1_ps(mz), ib = _mm_set1_ps(inv_b2);
  __m128 sw[4], sx[4], sy[4], sz[4];
  for (int r = 0; r < 4; ++r) sw[r] = sx[r] = sy[r] = sz[r] = _mm_setzero_ps();
  for (int32_t i = 0; i < padded; i += 16) {
    for (int r = 0; r < 4; ++r) {
      const int32_t o = i + 4 * r;
      const __m128 x = _mm_loadu_ps(xs + o), y = _mm_loadu_ps(ys + o), z = _mm_loadu_ps(zs + o);
      const __m128 dx = _mm_sub_ps(x, mx4), dy = _mm_sub_ps(y, my4), dz = _mm_sub_ps(z, mz4);
      const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
      const __m128 k = _mm_mul_ps(_mm_loadu_ps(ws + o), exp_neg4(_mm_mul_ps(d2, ib)));
      sw[r] = _mm_add_ps(sw[r], k);
      sx[r] = _mm_add_ps(sx[r], _mm_mul_ps(k, x));
      sy[r] = _mm_add_ps(sy[r], _mm_mul_ps(k, y));
      sz[r] = _mm_add_ps(sz[r], _mm_mul_ps(k, z));
    }
  }
  out[0] = reduce16(sw);
  out[1] = reduce16(sx);
  out[2] = reduce16(sy);
  out[3] = reduce16(sz);
}

}  // namespace dp::kernels::sse41

namespace dp::kernels::sse41 {

// Four votes at a time: each lane keeps the first mode with the smallest d2 below reach2, then the
// weights are added in vote order (mean_shift_kernel.h).
void mode_weights(const float* xs, const float* ys, const float* zs, const float* ws, int32_t count, float* modes,
                  int32_t mode_count, float reach2) {
  const __m128 reach4 = _mm_set1_ps(reach2);
  for (int32_t i = 0; i < count; i += 4) {
    const __m128 x = _mm_loadu_ps(xs + i), y = _mm_loadu_ps(ys + i), z = _mm_loadu_ps(zs + i);
    __m128 best_d2 = reach4;
    __m128i best = _mm_set1_epi32(-1);
    for (int32_t m = 0; m < mode_count; ++m) {
      const float* q = modes + 4 * m;
      const __m128 dx = _mm_sub_ps(x, _mm_set1_ps(q[0])), dy = _mm_sub_ps(y, _mm_set1_ps(q[1])),
                   dz = _mm_sub_ps(z, _mm_set1_ps(q[2]));
      const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
      const __m128 closer = _mm_cmplt_ps(d2, best_d2);
      best_d2 = _mm_blendv_ps(best_d2, d2, closer);
      best = _mm_castps_si128(_mm_blendv_ps(_mm_castsi128_ps(best), _mm_castsi128_ps(_mm_set1_epi32(m)), closer));
    }
    alignas(16) int32_t lane_best[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(lane_best), best);
    for (int32_t l = 0; l < 4 && i + l < count; ++l)
      if (lane_best[l] >= 0) modes[4 * lane_best[l] + 3] += ws[i + l];
  }
}

}  // namespace dp::kernels::sse41
