// NEON mean-shift sums: the 16 lanes of mean_shift_kernel.h in 4 registers (lanes 0–3, 4–7, 8–11,
// 12–15), as the SSE4.1 file. Bit-exact with ref/mean_shift.cc: the same operations per lane
// (frintm for the floor, no fused multiply-add under -ffp-contract=off), the same reduction tree.
#include <arm_neon.h>

#include "runtime/kernels/mean_shift_kernel.h"

namespace dp::kernels::neon {

namespace {
// e^(−t) for t ≥ 0 (fast_math.h's exp_neg polynomial, branch-free); 0 for t ≥ 80.
inline float32x4_t exp_neg4(float32x4_t t) {
  const uint32x4_t live = vcltq_f32(t, vdupq_n_f32(80.0f));
  t = vminq_f32(t, vdupq_n_f32(80.0f));
  const float32x4_t y = vmulq_f32(t, vdupq_n_f32(-1.44269504f));
  const float32x4_t fi = vrndmq_f32(y);
  const float32x4_t f = vsubq_f32(y, fi);
  float32x4_t p = vaddq_f32(vdupq_n_f32(0.05550411f), vmulq_f32(f, vdupq_n_f32(0.00961813f)));
  p = vaddq_f32(vdupq_n_f32(0.24022650f), vmulq_f32(f, p));
  p = vaddq_f32(vdupq_n_f32(0.69314718f), vmulq_f32(f, p));
  p = vaddq_f32(vdupq_n_f32(1.0f), vmulq_f32(f, p));
  const int32x4_t e = vshlq_n_s32(vaddq_s32(vcvtq_s32_f32(fi), vdupq_n_s32(127)), 23);
  return vreinterpretq_f32_u32(vandq_u32(live, vreinterpretq_u32_f32(vmulq_f32(p, vreinterpretq_f32_s32(e)))));
}

// Lanes (l, l+4, l+8, l+12) held as r[0..3][l]: the fixed tree of the header.
inline float reduce16(const float32x4_t r[4]) {
  const float32x4_t h = vaddq_f32(vaddq_f32(r[0], r[2]), vaddq_f32(r[1], r[3]));
  const float32x2_t q = vadd_f32(vget_low_f32(h), vget_high_f32(h));
  return vget_lane_f32(q, 0) + vget_lane_f32(q, 1);
}
}  // namespace

void mean_shift_sums(const float* xs, const float* ys, const float* zs, const float* ws, int32_t padded, float mx,
                     float my, float mz, float inv_b2, float* out) {
  const float32x4_t mx4 = vdupq_n_f32(mx), my4 = vdupq_n_f32(my), mz4 = vdupq_n_f32(mz), ib = vdupq_n_f32(inv_b2);
  float32x4_t sw[4], sx[4], sy[4], sz[4];
  for (int r = 0; r < 4; ++r) sw[r] = sx[r] = sy[r] = sz[r] = vdupq_n_f32(0.0f);
  for (int32_t i = 0; i < padded; i += 16) {
    for (int r = 0; r < 4; ++r) {
      const int32_t o = i + 4 * r;
      const float32x4_t x = vld1q_f32(xs + o), y = vld1q_f32(ys + o), z = vld1q_f32(zs + o);
      const float32x4_t dx = vsubq_f32(x, mx4), dy = vsubq_f32(y, my4), dz = vsubq_f32(z, mz4);
      const float32x4_t d2 = vaddq_f32(vaddq_f32(vmulq_f32(dx, dx), vmulq_f32(dy, dy)), vmulq_f32(dz, dz));
      const float32x4_t k = vmulq_f32(vld1q_f32(ws + o), exp_neg4(vmulq_f32(d2, ib)));
      sw[r] = vaddq_f32(sw[r], k);
      sx[r] = vaddq_f32(sx[r], vmulq_f32(k, x));
      sy[r] = vaddq_f32(sy[r], vmulq_f32(k, y));
      sz[r] = vaddq_f32(sz[r], vmulq_f32(k, z));
    }
  }
  out[0] = reduce16(sw);
  out[1] = reduce16(sx);
  out[2] = reduce16(sy);
  out[3] = reduce16(sz);
}

}  // namespace dp::kernels::neon
