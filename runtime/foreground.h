// Stage 1, foreground and probe image: the frame becomes the padded probe image the forest reads
// (kernels/forest_kernel.h: every element a probe depth plus kProbeBias, background outside the
// person and on the one-pixel border) and the list of pixels the forest evaluates, in raster order.
// Foreground (kernels/foreground_kernel.h): a reading (0 < z < kBackgroundDepthMm) inside the
// config's [near_mm, far_mm] band, or nonzero in the frame's mask when it has one. A frame with more
// foreground than the pixel budget evaluates every stride-th foreground pixel.
#pragma once
#include <stdint.h>

#include "forest_blob/blob_format.h"
#include "runtime/depthpose.h"
#include "runtime/kernels/foreground_kernel.h"

namespace dp {

// Fills the probe image (padded_probe_elements(width, height) elements) for `frame` and lists its
// first `pixel_cap` foreground pixels in `pixels`. frame: 1 ≤ width, height; stride_px ≥ width.
kernels::ForegroundScanResult list_foreground(kernels::ForegroundScanFn scan, const DepthFrame& frame,
                                              const blob::RuntimeConfig& config, uint16_t* probe_image,
                                              EvaluatedPixel* pixels, int32_t pixel_cap);

// Thins the list to at most `budget` (≥ 1) pixels: when foreground > budget, re-lists every
// stride-th foreground pixel of the probe image (stride = ⌈foreground / budget⌉), else keeps the
// list. Returns the evaluated count; *stride gets the stride (1 when unthinned).
int32_t thin_to_budget(const uint16_t* probe_image, int32_t width, int32_t height, int32_t foreground,
                       int32_t budget, EvaluatedPixel* pixels, int32_t* stride);

}  // namespace dp
