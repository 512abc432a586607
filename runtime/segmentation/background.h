// Background stage of dp::Segmenter (runtime/segmentation/segmenter.h): which pixels may belong
// to a person (classify_pixels) and the per-pixel model of the static scene (update_background).
//
// Contract:
//   - `background` is the caller's persistent model, one BackgroundCell per pixel of the frame
//     (row-major with the frame's width, not its stride); all zero = nothing learned.
//   - classify_pixels writes pixel_parent (one int32 per pixel: its own index when the pixel is a
//     candidate, −1 otherwise) and uses pixel_aux (one int32 per pixel) as scratch, leaving it 1
//     for every pixel (the component stage's initial sizes). Returns the number of candidates.
//   - A pixel is a candidate when its depth is within near_mm..far_mm, it lies above the floor by
//     more than the floor margin (when a floor is known) and, with the background model on and
//     at least one frame seen, it is nearer than the model by more than the tolerance.
//   - update_background learns from the pixels no user holds, outside every user's box grown by a
//     margin. One sweep over the frame each; no allocation.
//   - Units: depths in mm, tolerances in mm (+ mm per m² of depth squared).
#pragma once
#include <stdint.h>

#include "runtime/segmentation/segmentation_result.h"

namespace dp::seg {

struct BackgroundCell {
  uint16_t depth_mm;     // 0 = unknown
  uint16_t far_frames;   // consecutive frames seen farther than the model
  uint16_t near_frames;  // consecutive frames seen nearer (not a user)
  uint16_t learned;      // frames averaged into depth_mm (saturating)
};

// base_mm + per_m2_mm · z² with z in metres: the depth tolerance at depth z_mm.
inline float tolerance_mm(float base_mm, float per_m2_mm, float z_mm) {
  const float zm = z_mm * 0.001f;
  return base_mm + per_m2_mm * zm * zm;
}

int32_t classify_pixels(const SegmenterConfig& cfg, const DepthFrame& frame, const FloorPlane& floor,
                        const BackgroundCell* background, int32_t frames_seen, int32_t* pixel_parent, int32_t* pixel_aux);
void update_background(const SegmenterConfig& cfg, const DepthFrame& frame, const uint8_t* labels,
                       const SegmentationResult* r, int32_t frames_seen, BackgroundCell* background);

}  // namespace dp::seg
