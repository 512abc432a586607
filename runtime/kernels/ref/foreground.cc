// Reference foreground scan: foreground_kernel.h's contract, one pixel at a time.
#include "runtime/fixed_point.h"
#include "runtime/kernels/foreground_kernel.h"
#include "runtime/kernels/forest_kernel.h"

namespace dp::kernels::ref {

ForegroundScanResult foreground_scan(const ForegroundScanArgs& a) {
  ForegroundScanResult r{0, 0};
  const int32_t probe_stride = a.width + 2;
  for (int32_t v = 0; v < a.height; ++v) {
    const uint16_t* row = a.depth_mm + size_t(v) * size_t(a.stride_px);
    const uint8_t* mrow = a.mask ? a.mask + size_t(v) * size_t(a.stride_px) : nullptr;
    uint16_t* out = a.probe_image + size_t(v + 1) * size_t(probe_stride) + 1;
    for (int32_t u = 0; u < a.width; ++u) {
      const uint16_t z = row[u];
      const bool is_fg = z != 0 && z < kBackgroundDepthMm && (mrow ? mrow[u] != 0 : (z >= a.near_mm && z <= a.far_mm));
      out[u] = probe_element(is_fg ? z : kBackgroundDepthMm);
      r.foreground += is_fg;
      if (is_fg && r.listed < a.pixel_cap) a.pixels[r.listed++] = EvaluatedPixel{uint16_t(u), uint16_t(v), z, 0};
    }
  }
  return r;
}

}  // namespace dp::kernels::ref
