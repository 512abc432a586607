// Users of dp::Segmenter (runtime/segmentation/segmenter.h): which candidates are users, with
// ids stable across frames, and the label image.
//
// Contract:
//   - tracks_ ([kMaxUsers], slot i ↔ id i + 1) is persistent state in the Segmenter's arena; the
//     candidates and pixel views are the component stage's (components.h). Owns nothing.
//   - assign_users: merge fragments, judge every candidate, match tracks to candidates (greedy,
//     nearest centroid relative to each track's reach), admit new users (largest first, lowest
//     free id, at most max_users; kSegFlagUsersTruncated beyond), update the tracks, fill
//     result->users (by increasing id), user_count, user_pixels and the labels (height ×
//     stride_px bytes, 0 = background).
//   - Bounded: kMaxUsers × kMaxCandidates per matching round, kMaxUsers rounds; kMaxCandidates
//     admission rounds; one sweep over the frame for the labels.
//   - Units: centroids and velocities in camera metres (per frame).
#pragma once
#include <stdint.h>

#include "runtime/segmentation/person_tests.h"

namespace dp::seg {

struct Track {
  int32_t active;        // slot in use (visible or lost ≤ track_keep_frames)
  int32_t lost_frames;
  int32_t frames_tracked;
  float centroid[3];
  float velocity[3];     // metres per frame, smoothed
};

struct UserStage : PersonTests {
  Track* tracks_ = nullptr;  // [kMaxUsers], slot i ↔ id i + 1

  void assign_users(const DepthFrame& frame, int32_t candidate_count, SegmentationResult* result);

 private:
  struct Verdicts;
  void set_centroid(int32_t k, Verdicts* v) const;
  void judge_candidates(const DepthFrame& frame, int32_t candidate_count, Verdicts* v);
  void associate_tracks(int32_t candidate_count, Verdicts* v);
  int32_t admit_new_users(const DepthFrame& frame, int32_t candidate_count, Verdicts* v, SegmentationResult* r);
  void update_tracks(const Verdicts& v, SegmentationResult* r);
  void write_labels(const DepthFrame& frame, SegmentationResult* r) const;
};

}  // namespace dp::seg
