// What dp::Segmenter reports per frame (runtime/segmentation/segmenter.h): the floor plane, the
// users, counts, stage cycles and flags. Shared by the segmenter and its stage files.
// Units: 3D points in metres, camera frame x right, y up, z forward (runtime/depthpose.h).
#pragma once
#include <stdint.h>

#include "runtime/depthpose.h"
#include "runtime/segmentation/segmenter_config.h"

namespace dp {

// Live sources (static camera, frames in sequence): everything on. Independent frames (datasets
// of unrelated frames): background model off.
SegmenterConfig default_segmenter_config(bool live_source);

struct FloorPlane {
  // n·p + d = signed height of p above the floor (metres); n unit, pointing up; d = camera height.
  float nx, ny, nz, d;
  int32_t valid;        // 1 when a plane is known this frame (found, tracked or held)
  int32_t inliers;      // sample points within floor_fit_mm of the plane
  int32_t samples;      // sample points this frame
  int32_t held_frames;  // frames since the plane was last fitted (0 = fitted this frame)
};

// How a user got its id this frame (UserInfo::arrival).
enum UserArrival : int32_t {
  kUserContinued = 0,   // the id's track matched (also after a short occlusion within track_keep_frames)
  kUserNew = 1,         // a new person: an id nobody held within reid_window_frames, or the oldest
  kUserReturned = 2,    // a person gone longer than track_keep_frames re-identified by height and silhouette area
};

const char* user_arrival_name(int32_t arrival);  // "continued", "new", "returned"; "?" otherwise

struct UserInfo {
  int32_t id;              // 1..max_users, stable across frames
  int32_t pixel_count;
  float centroid_m[3];     // mean 3D point (x, y, z)
  int16_t u_min, v_min, u_max, v_max;  // bounding box, inclusive
  float top_height_m;      // highest point above the floor (camera y extent without floor)
  int32_t frames_tracked;  // consecutive frames this id has been seen (1 = new)
  int32_t arrival;         // UserArrival: how this id came to this user this frame
};

enum SegmentationStage : int32_t {
  kSegStageFloor = 0,     // sample, RANSAC, refinement
  kSegStageBackground,    // per-pixel floor/background/band test
  kSegStageComponents,    // union-find, candidate selection, statistics
  kSegStageUsers,         // person test, association, labelling, model update
  kSegStageCount
};
const char* segmentation_stage_name(int32_t stage);

enum SegmentationFlag : uint32_t {
  kSegFlagFloorFitted = 1u << 0,        // a plane was fitted this frame
  kSegFlagFloorHeld = 1u << 1,          // no fit this frame; last plane kept (floor_keep_frames)
  kSegFlagBackgroundLearning = 1u << 2, // fewer than background_learn_frames frames seen
  kSegFlagCandidatesTruncated = 1u << 3,// more than kMaxCandidates components: smallest ignored
  kSegFlagUsersTruncated = 1u << 4,     // more people than free ids: smallest dropped
};

struct SegmentationResult {
  // Caller-owned output, set before process(): height × frame.stride_px bytes, written with the
  // frame's stride so it can serve directly as DepthFrame::foreground_mask. process() keeps it.
  uint8_t* labels;
  int32_t user_count;
  UserInfo users[kMaxUsers];   // visible users, by increasing id
  FloorPlane floor;
  int32_t candidate_pixels;    // valid, in band, not floor, not background
  int32_t user_pixels;         // labelled with a user id
  int32_t component_count;     // components ≥ min_component_pixels
  uint64_t stage_cycles[kSegStageCount];  // TSC cycles
  uint64_t total_cycles;
  uint32_t flags;              // SegmentationFlag bits
};

}  // namespace dp
