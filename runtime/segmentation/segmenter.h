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
//   users            stable ids 1..max_users by greedy nearest-centroid association; a user who
//                    disappears keeps the id for track_keep_frames frames (short occlusions).
//
// Contract (same pattern as dp::Pipeline, docs/segmentation.md):
//   - The caller owns all memory: segmenter_required_bytes() says how much; init() takes a 64-byte
//     aligned arena. Persistent state (config, background model, tracks, floor) sits at the arena
//     tail, per-frame scratch at its head. Nothing allocates or throws.
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
#include "runtime/segmentation/segmenter_config.h"

namespace dp {

class ArenaCarver;

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

struct UserInfo {
  int32_t id;              // 1..max_users, stable across frames
  int32_t pixel_count;
  float centroid_m[3];     // mean 3D point (x, y, z)
  int16_t u_min, v_min, u_max, v_max;  // bounding box, inclusive
  float top_height_m;      // highest point above the floor (camera y extent without floor)
  int32_t frames_tracked;  // consecutive frames this id has been seen (1 = new)
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

// Arena bytes for frames up to max_width × max_height (0 for sizes outside 1..kMaxFrameDimension).
size_t segmenter_required_bytes(int32_t max_width, int32_t max_height);

class Segmenter {
 public:
  // kOk, kBadArgument (null arena, bad size), kArenaMisaligned, kArenaTooSmall, kBadConfig.
  Status init(const SegmenterConfig& config, int32_t max_width, int32_t max_height, uint8_t* arena,
              size_t arena_bytes);
  // kOk; kBadArgument (null result or labels, bad frame or intrinsics); kFrameTooLarge;
  // kNotInitialized. A frame of another size than the previous one restarts the background model
  // and the tracks. On error the labels are untouched and the result (except labels) zeroed.
  Status process(const DepthFrame& frame, SegmentationResult* result);
  // Replaces the config (kBadConfig when invalid); keeps the learned state.
  Status set_config(const SegmenterConfig& config);
  // Forgets the floor, the background model and the tracks (e.g. after the camera moved).
  void reset();

  const SegmenterConfig& config() const { return *config_; }
  size_t arena_used_bytes() const { return arena_used_; }

 private:
  struct Track {
    int32_t active;        // slot in use (visible or lost ≤ track_keep_frames)
    int32_t lost_frames;
    int32_t frames_tracked;
    float centroid[3];
    float velocity[3];     // metres per frame, smoothed
  };
  struct BackgroundCell {
    uint16_t depth_mm;     // 0 = unknown
    uint16_t far_frames;   // consecutive frames seen farther than the model
    uint16_t near_frames;  // consecutive frames seen nearer (not a user)
    uint16_t learned;      // frames averaged into depth_mm (saturating)
  };
  struct Candidate {
    int32_t root, pixels;
    double sx, sy, sz;
    float x_min, x_max, y_min, y_max, z_min, z_max, top;
    float bottom;          // lowest point above the floor (with a floor)
    int32_t occluded;      // box pixels hidden by something in front (top-border components)
    int32_t hidden_edge;   // pixel edges where the neighbour is nearer by more than hidden_gap_mm
    int32_t hidden_below;  // of those: the downward ones (cut_hidden_floor_contact_m)
    int32_t hull;          // pixels of the row-wise convex hull (top-border components, else 0)
    int32_t hull_filled;   // of those: the component's own plus the ones hidden by something in front
    int32_t cut_pixels;    // pixels of the pieces touching the top border and of merged pieces
                           // sharing their columns (cut_fill_border_columns)
    int16_t cut_u_min, cut_u_max;  // those pieces' image columns; none: cut_u_max < cut_u_min
    int32_t gap_rows;      // image rows with a seen-through gap between two runs of its pixels
                           // (top-border components; cut_gap_min_share)
    int16_t u_min, v_min, u_max, v_max;
    int32_t user;          // id or 0
    int32_t owner;         // candidate this one was merged into (itself when not merged)
  };

  struct State {
    int32_t frames;        // frames processed since init/reset (saturating)
    int32_t width, height; // geometry of the model and tracks
  };

  // Carves the arena (counting only when `into` is null); shared by init and
  // segmenter_required_bytes so both agree.
  static bool carve(ArenaCarver& carver, int32_t max_width, int32_t max_height, Segmenter* into);
  friend size_t segmenter_required_bytes(int32_t max_width, int32_t max_height);

  SegmenterConfig* config_ = nullptr;
  int32_t max_width_ = 0, max_height_ = 0;
  size_t arena_used_ = 0;
  bool initialized_ = false;
  // persistent
  BackgroundCell* background_ = nullptr;
  Track* tracks_ = nullptr;          // [kMaxUsers], slot i ↔ id i + 1
  FloorPlane* floor_ = nullptr;
  State* state_ = nullptr;
  // scratch
  int32_t* parent_ = nullptr;        // union-find over pixels (−1 = not a candidate pixel)
  int32_t* aux_ = nullptr;           // root: component size, then candidate index or −1
  float* samples_ = nullptr;         // [kMaxFloorSamples][3]
  uint8_t* inlier_ = nullptr;        // [kMaxFloorSamples]
  int16_t* hull_rows_ = nullptr;     // [4 · max_height]: row extents and hull chains of one component
  Candidate* candidates_ = nullptr;  // [kMaxCandidates]

  // owner < 0: the pixels of `candidate`'s own component; else those of every component merged
  // into candidate `owner` (Candidate::owner).
  void measure_hull(const DepthFrame& frame, Candidate* candidate, int32_t owner = -1);
  bool owned(int32_t root, const Candidate* candidate, int32_t owner) const {
    return root >= 0 && aux_[root] >= 0 &&
           (owner < 0 ? &candidates_[aux_[root]] == candidate : candidates_[aux_[root]].owner == owner);
  }
  // visit(u, v, pixel index, depth mm) for every pixel of the components merged into candidate
  // `owner` (owned(·, ·, owner)), in raster order within candidates_[owner]'s image box.
  template <class Visit>
  void for_each_pixel_of(const DepthFrame& frame, int32_t owner, Visit&& visit) const;
  void fit_floor(const DepthFrame& frame, SegmentationResult* result);
  int32_t classify_pixels(const DepthFrame& frame);
  int32_t label_components(const DepthFrame& frame, SegmentationResult* result);
  // cut: also the relaxed tests for components cut by the image border.
  // short_top: a component cut by the top border may have only cut_top_area_fraction of the area
  // (only for new users: merging judges pieces as before).
  bool passes_person_test(const DepthFrame& frame, const Candidate& candidate, bool cut = true, bool short_top = false) const;
  // cut_side_area_fraction's relaxation (touches the left or right border, not the top one, a floor
  // known, min_person_height_m high, that fraction of `need` pixels); no width test. O(1).
  bool cut_by_side(const DepthFrame& frame, const Candidate& candidate, float need) const;
  void merge_fragments(const DepthFrame& frame, int32_t candidate_count);
  bool in_front_of_a_user(const DepthFrame& frame, int32_t candidate_count, int32_t k, const float* mean_z,
                          const bool* passes) const;
  int32_t absorbing_user(const DepthFrame& frame, int32_t candidate_count, int32_t k, const float* cx, const float* cy,
                         const float* cz) const;
  // 0 = not low or not a person; 1 = by its lid share (low_max_lid_share); 2 = by its outline only
  // (low_max_solidity); 3 = cut by the bottom border above the floor, by its lid share
  // (cut_bottom_low_max_lid_share). Non-const: the outline uses the hull scratch rows.
  int32_t low_person(const DepthFrame& frame, int32_t k);  // low_max_lid_share (header)
  // 0 = kept, 1 = box dropped, 2 = no user. low_outline: the component passed only as low by its
  // outline (low_max_solidity): judged although low, and a lid apart from the rest makes it no user.
  int32_t split_box(const DepthFrame& frame, int32_t k, bool low_outline = false);
  // pair_bridge_max_m (header): cuts candidate k in two at a bridge; returns the index of the new
  // candidate (candidate_count, which the caller then counts) or −1 when k is kept whole.
  int32_t split_pair(const DepthFrame& frame, int32_t candidate_count, int32_t k);
  void assign_users(const DepthFrame& frame, int32_t candidate_count, SegmentationResult* result);
  void update_background(const DepthFrame& frame, const uint8_t* labels, const SegmentationResult* result);
};

}  // namespace dp
