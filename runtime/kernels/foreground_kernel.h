// Foreground scan (stage 1), one entry point per ISA folder (ref: plain C++, the specification;
// sse41: eight pixels at a time, the same output).
//
// Contract: for every pixel (u, v) of the frame, in raster order, with z = depth_mm[v·stride_px + u]:
//     foreground  ⇔  z ≠ 0, z < kBackgroundDepthMm, and (mask ? mask[v·stride_px + u] ≠ 0
//                                                            : near_mm ≤ z ≤ far_mm)
// writes probe element probe_element(foreground ? z : kBackgroundDepthMm) at interior position
// (u + 1, v + 1) of the padded probe image (row stride width + 2; the border is not touched), counts
// the foreground, and lists the first pixel_cap foreground pixels as EvaluatedPixel{u, v, z, 0}.
// Returns the count and how many were listed (≤ pixel_cap). No allocation, no state.
#pragma once
#include <stdint.h>

#include "runtime/depthpose.h"

namespace dp::kernels {

struct ForegroundScanArgs {
  const uint16_t* depth_mm;
  int32_t width, height, stride_px;
  const uint8_t* mask;          // nullptr: the near/far band decides
  uint16_t near_mm, far_mm;
  uint16_t* probe_image;        // padded: (width + 2) × (height + 2)
  EvaluatedPixel* pixels;       // pixel_cap entries
  int32_t pixel_cap;
};

struct ForegroundScanResult {
  int32_t foreground;  // every foreground pixel of the frame
  int32_t listed;      // min(foreground, pixel_cap)
};

using ForegroundScanFn = ForegroundScanResult (*)(const ForegroundScanArgs& args);
namespace ref { ForegroundScanResult foreground_scan(const ForegroundScanArgs& args); }
namespace sse41 { ForegroundScanResult foreground_scan(const ForegroundScanArgs& args); }

}  // namespace dp::kernels
