// Named fixed-point operations of the depth-comparison feature (paper Eq. 3), the exact integer
// rule that the scalar reference kernel, every SIMD kernel and the trainer share.
// docs/fixed_point.md explains the choices; nothing here allocates or throws.
//
// Units and Q formats
//   depth_mm        uint16 millimetres; 0 = no reading.
//   offset_pxm      int16 probe offset in pixel·metres at the blob's reference focal length:
//                   a pixel at 1 m depth, for a camera whose focal length is the reference one.
//   focal_factor    int32 = round(1000 · f_frame / f_reference): millimetres at which one
//                   offset unit is one pixel of this frame (1000 when the focal lengths agree).
//   scale_q13       uint16-range int32, pixels per offset unit in Q13 (8192 = 1.0), saturated.
//   probe offset    int32 pixels.
// The rule
//   scale_q13(z)     = min(32767, (focal_factor·8192 + z/2) / z)          (z > 0, integer /)
//   probe_offset(δ)  = (δ·scale_q13 + 4096) >> 13                          (round half up)
//   probe depth      = probe_image[v'][u'] where the probe image holds the depth of foreground
//                      pixels and kBackgroundDepthMm everywhere else; probes off the image also
//                      read kBackgroundDepthMm.
//   feature          = probe depth 1 − probe depth 2 (int32, mm)
//   branch           = right child (2n+2) iff feature > threshold_mm, else left child (2n+1).
#pragma once
#include <stdint.h>

namespace dp {

constexpr int kScaleShift = 13;                 // Q13
constexpr int32_t kScaleOneQ13 = 1 << kScaleShift;
constexpr int32_t kScaleMaxQ13 = 32767;         // 4.0 − 2^-13: saturates for z < focal_factor/4
constexpr uint16_t kBackgroundDepthMm = 32767;  // "large positive constant" of the paper
constexpr int32_t kMaxFocalFactor = 65535;      // keeps focal_factor·8192 inside int32

// focal_factor for a frame of focal length `frame_focal_px` and a forest trained for
// `reference_focal_px` (both meant > 0). Computed once per frame; rounding half away from zero, then
// clamped to 1..kMaxFocalFactor. The ratio is range-checked before the float → int conversion, so
// any input is defined: +inf or a huge ratio gives kMaxFocalFactor; NaN, 0 and negatives give 1.
inline int32_t focal_factor_mm(float frame_focal_px, float reference_focal_px) {
  const float f = 1000.0f * frame_focal_px / reference_focal_px;
  if (!(f >= 1.0f)) return 1;  // also NaN
  if (!(f < float(kMaxFocalFactor))) return kMaxFocalFactor;
  const int32_t v = static_cast<int32_t>(f + 0.5f);
  return v < kMaxFocalFactor ? v : kMaxFocalFactor;
}

// Pixels per offset unit at depth z (Q13), saturated at kScaleMaxQ13. z_mm must be > 0.
inline int32_t scale_q13(int32_t focal_factor, int32_t z_mm) {
  int32_t s = (focal_factor * kScaleOneQ13 + z_mm / 2) / z_mm;
  return s < kScaleMaxQ13 ? s : kScaleMaxQ13;
}

// Probe displacement in pixels: round(offset · scale), halves rounded up (towards +inf).
// |offset_pxm| ≤ 32767 and scale ≤ 32767 keep the product inside int32.
inline int32_t probe_offset_px(int32_t offset_pxm, int32_t scale_q13_value) {
  return (offset_pxm * scale_q13_value + (kScaleOneQ13 >> 1)) >> kScaleShift;
}

// Reads the probe image at (u, v); off-image reads the background constant.
inline int32_t probe_depth(const uint16_t* probe_image, int32_t width, int32_t height, int32_t u,
                           int32_t v) {
  if (static_cast<uint32_t>(u) >= static_cast<uint32_t>(width) ||
      static_cast<uint32_t>(v) >= static_cast<uint32_t>(height))
    return kBackgroundDepthMm;
  return probe_image[v * width + u];
}

// The depth-comparison feature at pixel (u, v) whose own depth is z_mm (> 0).
inline int32_t depth_feature(const uint16_t* probe_image, int32_t width, int32_t height, int32_t u,
                             int32_t v, int32_t z_mm, int32_t focal_factor, int32_t du1, int32_t dv1,
                             int32_t du2, int32_t dv2) {
  const int32_t s = scale_q13(focal_factor, z_mm);
  const int32_t d1 = probe_depth(probe_image, width, height, u + probe_offset_px(du1, s),
                                 v + probe_offset_px(dv1, s));
  const int32_t d2 = probe_depth(probe_image, width, height, u + probe_offset_px(du2, s),
                                 v + probe_offset_px(dv2, s));
  return d1 - d2;
}

}  // namespace dp
