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
// The same with one skeleton per entry of `skeletons` (per-user results of a segmented frame;
// count 0 draws pixels only).
void draw_overlay_users(const DepthFrame& frame, const Pipeline& pipeline, const FrameResult* skeletons, int count,
                        ImageRgb* image);

// Projects a camera-frame point (metres, y up) to pixel coordinates. False when z ≤ 0.
bool project(const CameraIntrinsics& k, float x, float y, float z, float* u, float* v);

}  // namespace dp::tools
