// Floor stage of dp::Segmenter (runtime/segmentation/segmenter.h): finds the floor plane in a
// depth frame, or keeps last frame's for a while.
//
// Contract:
//   - fit_floor samples at most cfg.floor_samples points (a grid over the lower
//     cfg.floor_sample_fraction of the image, depths near_mm..floor_far_mm) into `samples`
//     ([kMaxFloorSamples][3] floats, camera metres) and `inlier` ([kMaxFloorSamples] bytes), both
//     scratch owned by the caller, and draws at most floor_iterations + floor_retry_iterations
//     RANSAC hypotheses (floor_tracked_iterations while tracking), each scored over the sample.
//   - *floor (caller-owned, persistent across frames) is updated in place: fitted, held for at most
//     floor_keep_frames frames, or cleared; r->floor receives a copy and r->flags the
//     kSegFlagFloorFitted / kSegFlagFloorHeld bits.
//   - Deterministic: the hypotheses come from a fixed generator seeded by `frames_seen`.
//   - Units: plane n·p + d in camera metres, n unit and pointing up, d the camera height.
#pragma once
#include <stdint.h>

#include "runtime/segmentation/segmentation_result.h"

namespace dp::seg {

void fit_floor(const SegmenterConfig& cfg, const DepthFrame& frame, int32_t frames_seen, float* samples,
               uint8_t* inlier, FloorPlane* floor, SegmentationResult* r);

}  // namespace dp::seg
