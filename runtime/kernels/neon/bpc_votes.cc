// NEON BPC vote scan: the 16 joints of a pixel in four registers (widening adds of the joint-mass
// rows, the three weight products per lane). Same votes as ref/bpc_votes.cc bit for bit
// (vote_kernel.h: exact integer sums, then the same three float products, no fused multiply-add).
#include <arm_neon.h>

#include "runtime/kernels/vote_kernel.h"

namespace dp::kernels::neon {

void bpc_scan(const BpcScanArgs& a) {
  const float32x4_t inv_total = vdupq_n_f32(a.inv_total);
  const uint32x4_t zero = vdupq_n_u32(0);
  const uint32x4_t lane_bit = {1u, 2u, 4u, 8u};
  uint32x4_t cand[4] = {zero, zero, zero, zero};
  alignas(16) float w[kMaxJoints];
  alignas(16) uint32_t mass[kMaxJoints];
  for (int32_t i = 0; i < a.count; ++i) {
    const EvaluatedPixel px = a.pixels[i];
    if (skipped(a, px)) continue;
    prefetch_mass_rows_ahead(a, i);
    uint32x4_t acc[4] = {zero, zero, zero, zero};
    for (int t = 0; t < a.trees; ++t) {
      const uint16_t* m = mass_row(a, t, i);
      const uint16x8_t lo = vld1q_u16(m), hi = vld1q_u16(m + 8);
      acc[0] = vaddw_u16(acc[0], vget_low_u16(lo));
      acc[1] = vaddw_high_u16(acc[1], lo);
      acc[2] = vaddw_u16(acc[2], vget_low_u16(hi));
      acc[3] = vaddw_high_u16(acc[3], hi);
    }
    const float z = float(px.z_mm) * 0.001f;
    const float32x4_t z4 = vdupq_n_f32(z);
    uint32_t keep = 0;
    float32x4_t wv[4];
    for (int g = 0; g < 4; ++g) {
      wv[g] = vmulq_f32(vmulq_f32(vmulq_f32(vcvtq_f32_u32(acc[g]), inv_total), z4), z4);
      const uint32x4_t live = vtstq_u32(acc[g], acc[g]);  // all ones where mass ≠ 0
      cand[g] = vsubq_u32(cand[g], live);
      const uint32x4_t below = vcltq_f32(wv[g], vld1q_f32(a.floor + 4 * g));
      keep |= vaddvq_u32(vandq_u32(vbicq_u32(live, below), lane_bit)) << (4 * g);
    }
    if (!keep) continue;
    for (int g = 0; g < 4; ++g) {
      vst1q_f32(w + 4 * g, wv[g]);
      vst1q_u32(mass + 4 * g, acc[g]);
    }
    append_bpc_survivors(a, i, px, z, keep, w, mass);
  }
  for (int g = 0; g < 4; ++g) {
    alignas(16) uint32_t c[4];
    vst1q_u32(c, cand[g]);
    for (int l = 0; l < 4; ++l) a.candidates[4 * g + l] += c[l];
  }
}

}  // namespace dp::kernels::neon
