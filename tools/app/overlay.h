// Overlay images for `depthpose run --overlay`: the depth frame in grey, each evaluated pixel
// coloured by its most likely body part (BPC) or tinted (OJR), the best proposal of every joint
// as a dot and the skeleton between joints whose names form a bone.
#pragma once
#include <cstdint>

#include "runtime/depthpose.h"
#include "tools/common/png_io.h"

namespace dp::tools {

// Distinct colour for part `part` (0..kMaxParts-1), r g b.
void part_colour(int part, uint8_t rgb[3]);

// Draws into `image`, which must already be frame.width × frame.height (allocated by the caller;
// this function allocates nothing).
void draw_overlay(const DepthFrame& frame, const Pipeline& pipeline, const FrameResult& result, ImageRgb* image);
// The three layers of draw_overlay, for frames processed in several passes (one per user with
// segmentation): the depth in grey, the evaluated pixels of the pipeline's last process() call
// (BPC: most likely part; OJR: tint), and one result's joints and bones.
void draw_depth_grey(const DepthFrame& frame, const blob::RuntimeConfig& config, ImageRgb* image);
void draw_evaluated_pixels(const Pipeline& pipeline, ImageRgb* image);
void draw_skeleton(const DepthFrame& frame, const blob::ForestMeta& meta, const FrameResult& result, ImageRgb* image);

// Projects a camera-frame point (metres, y up) to pixel coordinates. False when z ≤ 0.
bool project(const CameraIntrinsics& k, float x, float y, float z, float* u, float* v);

}  // namespace dp::tools
