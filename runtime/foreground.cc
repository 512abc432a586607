#include "runtime/foreground.h"

#include "runtime/debug_check.h"
#include "runtime/fixed_point.h"
#include "runtime/kernels/forest_kernel.h"

namespace dp {

kernels::ForegroundScanResult list_foreground(kernels::ForegroundScanFn scan, const DepthFrame& f,
                                              const blob::RuntimeConfig& cfg, uint16_t* probe_image,
                                              EvaluatedPixel* pixels, int32_t pixel_cap) {
  DP_DCHECK(scan != nullptr && f.depth_mm != nullptr);
  DP_DCHECK(f.width >= 1 && f.height >= 1 && f.stride_px >= f.width && pixel_cap >= 1);
  kernels::fill_probe_border(probe_image, f.width, f.height);
  const kernels::ForegroundScanArgs a{f.depth_mm, f.width, f.height, f.stride_px, f.foreground_mask, cfg.near_mm,
                                      cfg.far_mm, probe_image, pixels, pixel_cap};
  return scan(a);
}

int32_t thin_to_budget(const uint16_t* probe_image, int32_t w, int32_t h, int32_t fg, int32_t budget,
                       EvaluatedPixel* pixels, int32_t* stride) {
  DP_DCHECK(budget >= 1);
  if (fg <= budget) {
    *stride = 1;
    return fg;
  }
  const int32_t step = (fg + budget - 1) / budget;
  *stride = step;
  const int32_t probe_stride = w + 2;
  int32_t n = 0, seen = 0;
  for (int32_t v = 0; v < h && n < budget; ++v) {
    const uint16_t* row = probe_image + size_t(v + 1) * probe_stride + 1;
    for (int32_t u = 0; u < w; ++u) {
      const int32_t z = kernels::probe_depth_of(row[u]);
      if (z == kBackgroundDepthMm) continue;
      if (seen++ % step != 0) continue;
      if (n >= budget) break;
      pixels[n++] = EvaluatedPixel{uint16_t(u), uint16_t(v), uint16_t(z), 0};
    }
  }
  return n;
}

}  // namespace dp
