// Users of dp::Segmenter (runtime/segmentation/segmenter.h): which candidates are users, with
// ids stable across frames, and the label image.
//
// Contract:
//   - tracks_ ([kMaxUsers], slot i ↔ id i + 1) is persistent state in the Segmenter's arena; the
//     candidates and pixel views are the component stage's (components.h). Owns nothing.
//   - assign_users: merge fragments, judge every candidate, match tracks to candidates (greedy,
//     nearest centroid relative to each track's reach; a lost track, with kReidHeightSamplesNeeded
//     heights seen, only by a candidate whose top is at least lost_min_height_ratio × the median
//     of its heights: its reach grows over the clutter around it), admit new users (largest first, lowest
//     free id, at most max_users; kSegFlagUsersTruncated beyond; re-identification below), update the tracks, fill
//     result->users (by increasing id), user_count, user_pixels and the labels (height ×
//     stride_px bytes, 0 = background).
//   - Re-identification: a track dropped after track_keep_frames stays `gone` for up to
//     reid_window_frames since last seen, with the medians of its last kReidHeightSamples heights
//     and silhouette areas. A new user takes a gone track's id when its height is within
//     reid_height_tolerance_m of that track's and of no other gone track's, its silhouette area
//     within a factor reid_area_ratio of that track's (either way; 0 = no area test), and its
//     centroid within association_distance_m + reid_speed_m per frame gone of where the track was
//     last seen (arrival kUserReturned). Silhouette area: pixels × z² / (fx · fy), z the centroid
//     depth (m²): the body's size as seen, which height alone does not tell apart.
//     Otherwise it takes the lowest id that is neither in use nor gone, else the id gone longest
//     (arrival kUserNew): a gone person's id is not handed to someone else while others are free.
//   - Furniture taken for a person: a tracked user whose component has been furniture-shaped
//     (PersonTests::furniture) in furniture_track_frames of its last furniture_track_window matched
//     frames, its centroid within furniture_static_m of where it stood in the first of them all
//     along, is no longer a user: its track is freed (not gone: no id is reserved for it) and its
//     pixels are background from that frame on. Shape and stillness are both needed: people stand
//     still, but a body's width changes with height in almost every frame. The piece is then
//     remembered (FurnitureMark, at most kMaxUsers, the one unseen longest replaced) and a
//     component at its place and height becomes no new user while it stays in view.
//   - Bounded: kMaxUsers medians of kReidHeightSamples heights (an insertion sort on the stack) and
//     kMaxUsers × kMaxCandidates per matching round, kMaxUsers rounds; one sweep over the
//     image box of each matched user for the furniture re-judgment; kMaxUsers × kMaxCandidates
//     comparisons with the furniture marks; kMaxCandidates admission rounds; one sweep over the
//     frame for the labels.
//   - Units: centroids and velocities in camera metres (per frame).
#pragma once
#include <stdint.h>

#include "runtime/segmentation/person_tests.h"

namespace dp::seg {

// Heights (top_height_m) and silhouette areas a track keeps, the last ones seen; re-identification needs
// kReidHeightSamplesNeeded of them (a person seen about a third of a second at 30 fps).
constexpr int32_t kReidHeightSamples = 15;  // odd: a true median
constexpr int32_t kReidHeightSamplesNeeded = 10;

struct Track {
  int32_t active;        // slot in use (visible or lost ≤ track_keep_frames)
  int32_t lost_frames;   // frames since last seen (counts on while gone, for re-identification)
  int32_t frames_tracked;
  float centroid[3];
  float velocity[3];     // metres per frame, smoothed
  // Re-identification: a dropped track stays `gone` (its id reserved for its person) until
  // lost_frames exceeds reid_window_frames; its height is the median of the samples.
  int32_t gone;
  int32_t height_count;  // samples held (≤ kReidHeightSamples)
  int32_t height_next;   // ring position of the next sample
  float heights[kReidHeightSamples];
  float height_m;        // median of the samples when the track was dropped
  float areas[kReidHeightSamples];  // silhouette areas (m²), sampled with the heights (same ring)
  float area_m2;                    // median of the areas when the track was dropped
  // Furniture re-judged while tracked (furniture_track_frames, furniture_track_window,
  // furniture_static_m): bit i of furniture_history is set when the component was furniture-shaped
  // (PersonTests::furniture) i matched frames ago; every frame since the evidence began had its
  // centroid within furniture_static_m of furniture_anchor, the centroid of that first
  // furniture-shaped frame (history 0: no evidence, the anchor unused).
  uint32_t furniture_history;
  float furniture_anchor[3];
};

// A tracked user dropped as furniture, remembered while it stays in view so that it does not come
// back as a new user in a frame where its shape looks less like furniture (someone walking in
// front): a component that is no user, with its centroid within furniture_static_m of `centroid`
// and its top within furniture_static_m of `top`, is that piece again. Forgotten after
// track_keep_frames frames without such a component.
struct FurnitureMark {
  int32_t active;
  int32_t unseen_frames;
  float centroid[3];  // camera metres, at the drop
  float top;          // metres above the floor
};

struct UserStage : PersonTests {
  Track* tracks_ = nullptr;  // [kMaxUsers], slot i ↔ id i + 1
  FurnitureMark* furniture_marks_ = nullptr;  // [kMaxUsers]

  void assign_users(const DepthFrame& frame, int32_t candidate_count, SegmentationResult* result);

 private:
  struct Verdicts;
  void set_centroid(int32_t k, Verdicts* v) const;
  void judge_candidates(const DepthFrame& frame, int32_t candidate_count, Verdicts* v);
  void associate_tracks(int32_t candidate_count, Verdicts* v);
  void drop_tracked_furniture(const DepthFrame& frame, int32_t candidate_count, Verdicts* v);
  void mark_furniture(const Candidate& c, const float* centroid);
  void keep_marked_furniture_out(int32_t candidate_count, Verdicts* v);
  int32_t admit_new_users(const DepthFrame& frame, int32_t candidate_count, Verdicts* v, SegmentationResult* r);
  int32_t slot_for_new_user(const Candidate& c, float area_m2, const float* centroid, bool* returned) const;
  void update_tracks(const DepthFrame& frame, const Verdicts& v, SegmentationResult* r);
  void write_labels(const DepthFrame& frame, SegmentationResult* r) const;
};

}  // namespace dp::seg
