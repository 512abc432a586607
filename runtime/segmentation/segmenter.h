// dp::Segmenter: finds the people in a depth frame before the forest runs (the paper assumes
// background subtraction, section 1.2). One frame in, a per-pixel user-id mask out:
//
//   floor plane      RANSAC over a bounded grid sample of the lower image part, refined by least
//                    squares (orthogonal fit), tracked frame to frame; pitch and roll unknown.
//                    Pixels within a margin of the plane (or below it) are background.
//   background model per-pixel depth learned over the first frames, updated slowly (optional;
//                    on in default_segmenter_config(true) for live sources, off for independent
//                    frames). Pixels near the learned depth are background.
//   components       4-connected components in 3D: neighbours join when their depth difference
//                    is ≤ join_mm + join_mm_per_m · z. Components too small or too low for a
//                    person at their distance are dropped.
//   users            the person tests decide which components (alone or joined) are people;
//                    stable ids 1..max_users by greedy nearest-centroid association; a user who
//                    disappears keeps the id for track_keep_frames frames (short occlusions).
//
// Each stage has its file pair, whose header states that stage's contract: floor.h,
// background.h, components.h, person_tests.h, users.h. This class owns the arena layout and runs
// the stages in order (segmenter.cc). The configuration is declared in segmenter_config.h.
//
// Contract (same pattern as dp::Pipeline, docs/segmentation.md):
//   - The caller owns all memory: segmenter_required_bytes() says how much; init() takes a 64-byte
//     aligned arena. Persistent state (config, background model, tracks, furniture marks, floor)
//     sits at the arena tail, per-frame scratch at its head. Nothing allocates or throws.
//   - Every loop is bounded by the frame size and the caps below (validated by init/set_config);
//     a frame full of clutter costs O(W·H·log(W·H)) for the components plus
//     O(kMaxCandidates · W·H) at worst for the candidate selection, never more.
//   - process() is deterministic for the same config and frame sequence.
// Units: depth uint16 mm (0 = no reading); 3D points in metres, camera frame x right, y up,
// z forward (runtime/depthpose.h). Labels: uint8, 0 = background, 1..max_users = user id.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "runtime/depthpose.h"
#include "runtime/segmentation/segmentation_result.h"
#include "runtime/segmentation/segmenter_config.h"
#include "runtime/segmentation/background.h"
#include "runtime/segmentation/users.h"

namespace dp {

class ArenaCarver;

// Arena bytes for frames up to max_width × max_height (0 for sizes outside 1..kMaxFrameDimension).
size_t segmenter_required_bytes(int32_t max_width, int32_t max_height);

class Segmenter {
 public:
  Segmenter() = default;
  // Not copyable: two copies would share one arena (and its tracks and background model).
  // Movable: the moved-to segmenter takes over the arena views; the moved-from one is left
  // uninitialized (process() returns kNotInitialized until init()).
  Segmenter(const Segmenter&) = delete;
  Segmenter& operator=(const Segmenter&) = delete;
  Segmenter(Segmenter&& other) noexcept { take(other); }
  Segmenter& operator=(Segmenter&& other) noexcept {
    if (this != &other) take(other);
    return *this;
  }

  // kOk, kBadArgument (null arena, bad size), kArenaMisaligned, kArenaTooSmall, kBadConfig.
  Status init(const SegmenterConfig& config, int32_t max_width, int32_t max_height, uint8_t* arena,
              size_t arena_bytes);
  // kOk; kBadArgument (null result or labels, bad frame or intrinsics); kFrameTooLarge;
  // kNotInitialized. A frame of another size than the previous one restarts the background model
  // and the tracks. On error the labels are untouched and the result (except labels) zeroed.
  Status process(const DepthFrame& frame, SegmentationResult* result);
  // Replaces the config (kBadConfig when invalid, segmenter_config_check); keeps the learned state.
  Status set_config(const SegmenterConfig& config);
  // Forgets the floor, the background model and the tracks (e.g. after the camera moved).
  void reset();

  const SegmenterConfig& config() const { return *config_; }
  size_t arena_used_bytes() const { return arena_used_; }

 private:
  struct State {
    int32_t frames;        // frames processed since init/reset (saturating)
    int32_t width, height; // geometry of the model and tracks
  };

  // Carves the arena (counting only when `into` is null); shared by init and
  // segmenter_required_bytes so both agree.
  static bool carve(ArenaCarver& carver, int32_t max_width, int32_t max_height, Segmenter* into);
  friend size_t segmenter_required_bytes(int32_t max_width, int32_t max_height);
  void take(Segmenter& other);

  SegmenterConfig* config_ = nullptr;
  int32_t max_width_ = 0, max_height_ = 0;
  size_t arena_used_ = 0;
  bool initialized_ = false;
  // Persistent state in the arena tail.
  seg::BackgroundCell* background_ = nullptr;  // one per pixel (background.h)
  FloorPlane* floor_ = nullptr;
  State* state_ = nullptr;
  // Per-frame scratch in the arena head.
  float* samples_ = nullptr;         // [kMaxFloorSamples][3] (floor.h)
  uint8_t* inlier_ = nullptr;        // [kMaxFloorSamples]
  // Components, person tests and users: views into the arena (parent, aux, candidates, hull rows,
  // tracks), set by carve (components.h, person_tests.h, users.h).
  seg::UserStage stages_;
};

}  // namespace dp
