// Reference mean-shift kernels: mean_shift_kernel.h's contracts as plain C++ (16 scalar lane sums,
// the fixed reduction tree; fast_math.h's exp_neg). The specification the SIMD files reproduce.
#include "runtime/fast_math.h"
#include "runtime/kernels/mean_shift_kernel.h"

namespace dp::kernels::ref {

namespace {
// The fixed reduction tree: s[l] + s[l+8], then + [l+4], + [l+2], + [l+1].
float reduce16(float s[kMeanShiftLanes]) {
  for (int half = kMeanShiftLanes / 2; half >= 1; half /= 2)
    for (int l = 0; l < half; ++l) s[l] = s[l] + s[l + half];
  return s[0];
}
}  // namespace

void mean_shift_sums(const float* xs, const float* ys, const float* zs, const float* ws, int32_t padded, float mx,
                     float my, float mz, float inv_b2, float* out) {
  float sw[kMeanShiftLanes] = {}, sx[kMeanShiftLanes] = {}, sy[kMeanShiftLanes] = {}, sz[kMeanShiftLanes] = {};
  for (int32_t i = 0; i < padded; i += kMeanShiftLanes)
    for (int l = 0; l < kMeanShiftLanes; ++l) {
      const float x = xs[i + l], y = ys[i + l], z = zs[i + l];
      const float dx = x - mx, dy = y - my, dz = z - mz;
      const float d2 = (dx * dx + dy * dy) + dz * dz;
      const float k = ws[i + l] * exp_neg(d2 * inv_b2);
      sw[l] = sw[l] + k;
      sx[l] = sx[l] + k * x;
      sy[l] = sy[l] + k * y;
      sz[l] = sz[l] + k * z;
    }
  out[0] = reduce16(sw);
  out[1] = reduce16(sx);
  out[2] = reduce16(sy);
  out[3] = reduce16(sz);
}

void mode_weights(const float* xs, const float* ys, const float* zs, const float* ws, int32_t count, float* modes,
                  int32_t mode_count, float reach2) {
  for (int32_t i = 0; i < count; ++i) {
    float best_d2 = reach2;
    int32_t best = -1;
    for (int32_t m = 0; m < mode_count; ++m) {
      const float* q = modes + 4 * m;
      const float dx = xs[i] - q[0], dy = ys[i] - q[1], dz = zs[i] - q[2];
      const float d2 = (dx * dx + dy * dy) + dz * dz;
      if (d2 < best_d2) {
        best_d2 = d2;
        best = m;
      }
    }
    if (best >= 0) modes[4 * best + 3] += ws[i];
  }
}

}  // namespace dp::kernels::ref
