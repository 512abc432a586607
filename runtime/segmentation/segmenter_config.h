// dp::SegmenterConfig: every tunable of dp::Segmenter declared once, in
// DP_SEGMENTER_CONFIG_FIELDS below, with its type, default, range, unit and meaning. From that one
// list come the struct, the validation (segmenter_config_check), the strict text parser of the
// tools (tools/segeval/segmenter_config_text.h) and the table in docs/segmentation.md
// (`depthpose segeval --print-config-table`; a test keeps the two equal). Why each rule and default
// is what it is: docs/segmentation.md ("Stages").
//
// Runtime code: no heap, no exceptions. The field descriptors are constant data.
#pragma once
#include <float.h>
#include <stddef.h>
#include <stdint.h>

namespace dp {

constexpr int kMaxUsers = 15;             // ids 1..15
constexpr int kMaxFloorSamples = 4096;    // RANSAC sample points
constexpr int kMaxFloorIterations = 1024; // RANSAC hypotheses per frame
constexpr int kMaxCandidates = 64;        // largest components examined per frame

// How a field's [min, max] bounds apply: kRangeOpenMin excludes min, kRangeOpenMax excludes max.
enum SegmenterConfigRange : int32_t { kRangeClosed, kRangeOpenMin, kRangeOpenMax, kRangeOpen };
// Upper bound of a field limited only from below (a float must still be finite).
constexpr double kConfigUnbounded = double(FLT_MAX);
constexpr double kConfigIntUnbounded = double(INT32_MAX);

// X(type, name, default, min, max, range, unit, meaning) for every field, in struct order.
// Lengths in metres (_m) or millimetres (_mm), depths z in metres inside the formulas; shares and
// fractions are unitless in 0..1 of what the unit column names. A rule whose field is 0 is off.
#define DP_SEGMENTER_CONFIG_FIELDS(X) \
  /* Depth band */ \
  X(uint16_t, near_mm, 400, 1, 65535, kRangeClosed, "mm", "readings nearer than this are background") \
  X(uint16_t, far_mm, 6000, 1, 65535, kRangeClosed, "mm", "readings farther than this are background (> near_mm)") \
  /* Floor */ \
  X(bool, floor_enabled, true, 0, 1, kRangeClosed, "", "fit and remove the floor; off: no pixel is floor") \
  X(float, floor_sample_fraction, 0.5f, 0, 1, kRangeOpenMin, "", "floor samples come from rows v >= (1 - fraction) * height") \
  X(uint16_t, floor_far_mm, 8000, 1, 65535, kRangeClosed, "mm", "farthest floor sample (>= near_mm; may exceed far_mm)") \
  X(int32_t, floor_samples, 800, 16, kMaxFloorSamples, kRangeClosed, "points", "grid sample size for the floor fit") \
  X(int32_t, floor_iterations, 512, 1, kMaxFloorIterations, kRangeClosed, "hypotheses", "RANSAC hypotheses without a tracked plane") \
  X(int32_t, floor_retry_iterations, 512, 0, kMaxFloorIterations, kRangeClosed, "hypotheses", "more hypotheses when the first found no floor") \
  X(int32_t, floor_tracked_iterations, 32, 0, kMaxFloorIterations, kRangeClosed, "hypotheses", "hypotheses while last frame's plane keeps >= half its inliers") \
  X(float, floor_fit_mm, 30.0f, 0, kConfigUnbounded, kRangeOpenMin, "mm", "inlier distance for the plane fit") \
  X(float, floor_margin_mm, 10.0f, 0, kConfigUnbounded, kRangeClosed, "mm", "pixels closer to the plane than margin + margin_per_m2 * z^2 (or below it) are floor") \
  X(float, floor_margin_per_m2_mm, 1.0f, 0, kConfigUnbounded, kRangeClosed, "mm/m^2", "growth of the floor margin with depth squared") \
  X(float, floor_max_tilt_deg, 45.0f, 0, 90, kRangeOpen, "deg", "largest angle between the plane normal and the camera's up axis") \
  X(float, floor_min_inlier_fraction, 0.15f, 0, 1, kRangeOpenMin, "of samples", "inliers a floor needs") \
  X(float, floor_min_extent_m, 1.0f, 0, kConfigUnbounded, kRangeClosed, "m", "smallest diagonal of the inliers' bounding box") \
  X(float, floor_wide_inlier_fraction, 0.05f, 0, 1, kRangeOpenMin, "of samples", "fewer inliers suffice when they span floor_wide_extent_m (<= floor_min_inlier_fraction)") \
  X(float, floor_wide_extent_m, 3.0f, 0, kConfigUnbounded, kRangeClosed, "m", "span that makes a plane with few inliers a floor (>= floor_min_extent_m)") \
  X(float, camera_height_min_m, 0.4f, 0, kConfigUnbounded, kRangeOpenMin, "m", "lowest camera height above a floor") \
  X(float, camera_height_max_m, 5.0f, 0, kConfigUnbounded, kRangeOpenMin, "m", "highest camera height above a floor (> camera_height_min_m)") \
  X(int32_t, floor_keep_frames, 15, 0, kConfigIntUnbounded, kRangeClosed, "frames", "a plane not found again is kept this long") \
  /* Background model */ \
  X(bool, background_enabled, true, 0, 1, kRangeClosed, "", "learn the static scene and remove it") \
  X(int32_t, background_learn_frames, 30, 1, 65535, kRangeClosed, "frames", "frames averaged before the model counts as learned") \
  X(float, background_tolerance_mm, 40.0f, 0, kConfigUnbounded, kRangeOpenMin, "mm", "abs(z - model) <= tol + tol_per_m2 * z^2 is background") \
  X(float, background_tolerance_per_m2_mm, 6.0f, 0, kConfigUnbounded, kRangeClosed, "mm/m^2", "growth of the tolerance with depth squared") \
  X(int32_t, background_update_shift, 5, 0, 12, kRangeClosed, "", "after learning, model += (z - model) / 2^shift") \
  X(int32_t, background_reveal_frames, 3, 1, 65535, kRangeClosed, "frames", "farther depth seen this long replaces the model") \
  X(int32_t, background_absorb_frames, 0, 0, 65535, kRangeClosed, "frames", "nearer non-user depth seen this long is absorbed; 0 = never") \
  /* Components and the person test */ \
  X(float, join_mm, 30.0f, 0, 65535, kRangeOpenMin, "mm", "neighbours join when abs(dz) <= join_mm + join_mm_per_m * z") \
  X(float, join_mm_per_m, 45.0f, 0, kConfigUnbounded, kRangeClosed, "mm/m", "growth of the join distance with depth") \
  X(int32_t, min_component_pixels, 24, 1, kConfigIntUnbounded, kRangeClosed, "pixels", "smaller components are never examined") \
  X(float, min_person_area_m2, 0.06f, 0, kConfigUnbounded, kRangeOpenMin, "m^2", "a person has >= area * fx * fy / z^2 pixels") \
  X(float, min_person_height_m, 0.85f, 0, kConfigUnbounded, kRangeClosed, "m", "a person's top is this high above the floor") \
  X(float, max_person_width_m, 1.8f, 0, kConfigUnbounded, kRangeOpenMin, "m", "a person is at most this wide") \
  X(float, tracked_area_fraction, 0.35f, 0, 1, kRangeOpenMin, "of the person area", "area a component matched to a track needs (no height test)") \
  X(float, fragment_join_mm, 450.0f, 0, 65535, kRangeClosed, "mm", "pieces touch when neighbouring pixels are this close in depth; 0 = no merging") \
  X(float, fragment_radius_m, 0.5f, 0, kConfigUnbounded, kRangeClosed, "m", "a touching piece joins a body within this along the floor") \
  X(float, fragment_pair_radius_m, 0.4f, 0, kConfigUnbounded, kRangeClosed, "m", "pieces join without touching within this; 0 = stacked pieces only") \
  X(float, fragment_min_share, 0.05f, 0, 0.5, kRangeOpenMax, "of the union", "when neither piece qualifies alone, the smaller holds at least this share") \
  X(float, absorb_radius_m, 0.6f, 0, kConfigUnbounded, kRangeClosed, "m", "a new user inside a nearer user's box within this joins it; 0 = off") \
  X(float, head_radius_m, 0.7f, 0, kConfigUnbounded, kRangeClosed, "m", "a small piece above a user beyond a depth jump joins it within this; 0 = off") \
  X(float, legs_radius_m, 0.55f, 0, kConfigUnbounded, kRangeClosed, "m", "legs on the floor join a body above the floor within this; 0 = off") \
  X(float, box_split_height_m, 0.85f, 0, kConfigUnbounded, kRangeClosed, "m", "cells lower than this can be a box's lid; 0 = no box split or reject") \
  X(float, box_split_min_share, 0.4f, 0, 1, kRangeClosed, "of the component", "a lid this large may be split off") \
  X(float, box_split_cell_m, 0.1f, 0, kConfigUnbounded, kRangeOpenMin, "m", "floor cell size for the lid and low tests") \
  X(float, box_split_min_dist_m, 0.6f, 0, kConfigUnbounded, kRangeClosed, "m", "the lid's centroid at least this far from the rest's") \
  X(float, box_reject_min_share, 0.7f, 0, 1, kRangeClosed, "of the component", "a lid this large not split off makes no user; 0 = off") \
  X(float, cut_max_fill, 0.6f, 0, 1, kRangeClosed, "of the image box", "top-border cut on the floor qualifies filling at most this; 0 = off") \
  X(float, cut_max_solidity, 0.8f, 0, 1, kRangeClosed, "of the hull", "... or filling at most this of its row-wise hull; 0 = off") \
  X(float, cut_solidity_max_hidden, 0.05f, 0, kConfigUnbounded, kRangeClosed, "of its pixels", "hull test only when at most this of the box is hidden") \
  X(int32_t, cut_fill_border_columns, 1, 0, 1, kRangeClosed, "", "1: a union's fill counts the border-cut pieces' columns only") \
  X(float, cut_floor_contact_m, 0.3f, 0, kConfigUnbounded, kRangeClosed, "m", "lowest point within this of the floor: stands on it") \
  X(float, cut_top_area_fraction, 0.8f, 0, 1, kRangeClosed, "of the person area", "area a new top-border cut needs; 0 = the full area") \
  X(float, low_max_lid_share, 0.4f, 0, 1, kRangeClosed, "of the component", "someone low qualifies with at most this in the lid band; 0 = off") \
  X(float, low_min_height_m, 0.7f, 0, kConfigUnbounded, kRangeClosed, "m", "someone low reaches at least this high") \
  X(float, low_max_solidity, 0.6f, 0, 1, kRangeClosed, "of the hull", "someone low qualifies by an outline filling at most this; 0 = off") \
  X(float, low_outline_max_lid_share, 0.9f, 0, 1, kRangeClosed, "of the component", "... with at most this in the lid band") \
  X(int32_t, low_outline_box_split, 1, 0, 1, kRangeClosed, "", "1: a low outline holding a box's lid apart is no user") \
  X(float, cut_bottom_area_fraction, 0.3f, 0, 1, kRangeClosed, "of the person area", "area a bottom-border cut as high as a person needs; 0 = off") \
  X(float, cut_bottom_low_max_lid_share, 0.8f, 0, 1, kRangeClosed, "of the component", "someone low cut by the bottom border: lid band share at most; 0 = off") \
  X(float, cut_side_area_fraction, 0.6f, 0, 1, kRangeClosed, "of the person area", "area a side-border cut as high as a person needs; 0 = off") \
  X(float, hidden_area_fraction, 0.5f, 0, 1, kRangeClosed, "of the person area", "area someone mostly hidden needs; 0 = off") \
  X(float, hidden_gap_mm, 300.0f, 0, 65535, kRangeOpenMin, "mm", "an edge is hidden when the neighbour is nearer by more than this") \
  X(int32_t, hidden_min_edge, 8, 1, kConfigIntUnbounded, kRangeClosed, "edges", "hidden edges that make a component partly hidden") \
  X(float, hidden_pair_radius_m, 0.8f, 0, kConfigUnbounded, kRangeClosed, "m", "two hidden-only pieces join within this") \
  X(float, hidden_legs_radius_m, 0.7f, 0, kConfigUnbounded, kRangeClosed, "m", "the legs of someone partly hidden join within this; 0 = off") \
  X(float, hidden_legs_max_gap_m, 0.3f, 0, kConfigUnbounded, kRangeClosed, "m", "... reaching up to within this of the body's lowest point") \
  X(float, hidden_legs_max_ratio, 5.0f, 0, kConfigUnbounded, kRangeOpenMin, "", "... holding at most this times the body's pixels") \
  /* Users */ \
  X(int32_t, max_users, 8, 1, kMaxUsers, kRangeClosed, "users", "ids 1..max_users") \
  X(float, association_distance_m, 0.6f, 0, kConfigUnbounded, kRangeOpenMin, "m", "a component within this of a track's prediction keeps its id") \
  X(float, association_growth_m, 0.08f, 0, kConfigUnbounded, kRangeClosed, "m/frame", "reach added per frame a track has been lost") \
  X(int32_t, track_keep_frames, 30, 0, 65535, kRangeClosed, "frames", "a lost user keeps its id this long") \
  /* lost_min_height_ratio: tried 0.5-0.9 on 32 validation sequences (reid-eval, docs/skeleton.md \
     "Ids across leaving and re-entering"): 0.75-0.9 keep seq72's id (a 1.04 m person's lost track \
     took a 0.75 m box), 0.7 and below do not; 0.8, the middle. segeval --live on the validation \
     sequences of docs/segmentation.md (seeds 101-106): people found 1800/1800 with and without tall \
     clutter either way, false users 0.904 -> 0.900 per frame with it */ \
  X(float, lost_min_height_ratio, 0.8f, 0, 1, kRangeClosed, "of its height", "a lost user is not continued by a component whose top is below this times its median height (kReidHeightSamplesNeeded samples); 0 = off") \
  X(int32_t, reid_window_frames, 150, 0, 65535, kRangeClosed, "frames", "a dropped user's id waits this long since last seen for its person (by height and area); 0 = off") \
  /* reid_height_tolerance_m and reid_area_ratio: chosen on 32 validation sequences (reid-eval, \
     docs/skeleton.md "Ids across leaving and re-entering"): newcomers given the gone id 9 -> 3, \
     returns kept 19 -> 19 against height alone within 0.05 m */ \
  X(float, reid_height_tolerance_m, 0.08f, 0, kConfigUnbounded, kRangeClosed, "m", "... when its height differs by at most this (and no other gone user's does)") \
  X(float, reid_area_ratio, 1.25f, 0, kConfigUnbounded, kRangeClosed, "", "... and its silhouette area is within this ratio of that user's (either way); 0 = off") \
  X(float, reid_speed_m, 0.1f, 0, kConfigUnbounded, kRangeClosed, "m/frame", "... and it reappears within association_distance_m + this per frame gone") \
  /* Top-border and bridge rules */ \
  X(float, cut_gap_min_share, 0.05f, 0, 1, kRangeClosed, "of the rows", "legs together cut by the top border qualify with this share of gap rows; 0 = off") \
  X(float, cut_gap_max_fill, 0.8f, 0, 1, kRangeClosed, "of the image box", "... filling at most this") \
  X(float, cut_hidden_floor_contact_m, 0.6f, 0, kConfigUnbounded, kRangeClosed, "m", "a top-border cut with hidden feet stands on the floor up to this; 0 = off") \
  X(float, pair_bridge_max_m, 0.4f, 0, kConfigUnbounded, kRangeClosed, "m", "thickest arm that bridges two people; 0 = off") \
  /* Tall furniture */ \
  X(float, furniture_smooth_min_share, 0.75f, 0, 1, kRangeClosed, "of its band pairs", "a new user this share of whose neighbouring 0.1 m height bands differ in width by at most the step (below) is furniture; 0 = off") \
  X(float, furniture_smooth_step_m, 0.015f, 0, kConfigUnbounded, kRangeClosed, "m", "... the step") \
  X(float, furniture_smooth_step_per_m2, 0.001f, 0, kConfigUnbounded, kRangeClosed, "m/m^2", "growth of the step with the component's mean depth squared") \
  X(float, furniture_pole_max_width_m, 0.06f, 0, kConfigUnbounded, kRangeClosed, "m", "a new user with furniture_pole_min_share of its height bands at most this wide is a pole (coat stand); 0 = off") \
  X(float, furniture_pole_min_share, 0.5f, 0, 1, kRangeOpenMin, "of its height bands", "... that share") \
  X(int32_t, furniture_track_frames, 5, 0, 32, kRangeClosed, "frames", "a tracked user furniture-shaped (above) in this many of the last furniture_track_window frames, static all along, is no longer a user; 0 = off") \
  X(int32_t, furniture_track_window, 30, 1, 32, kRangeClosed, "frames", "... the window") \
  X(float, furniture_static_m, 0.1f, 0, kConfigUnbounded, kRangeOpenMin, "m", "... static: its centroid within this of where it stood in the first of those frames")

// Constraints between fields: X(name, relation, other) means `name relation other` must hold.
#define DP_SEGMENTER_CONFIG_RELATIONS(X) \
  X(far_mm, kRelationGreater, near_mm) \
  X(floor_far_mm, kRelationGreaterEqual, near_mm) \
  X(floor_wide_inlier_fraction, kRelationLessEqual, floor_min_inlier_fraction) \
  X(floor_wide_extent_m, kRelationGreaterEqual, floor_min_extent_m) \
  X(camera_height_max_m, kRelationGreater, camera_height_min_m) \
  X(furniture_track_frames, kRelationLessEqual, furniture_track_window)

struct SegmenterConfig {
#define DP_SEGMENTER_CONFIG_MEMBER(type, name, def, lo, hi, range, unit, meaning) type name = def;
  DP_SEGMENTER_CONFIG_FIELDS(DP_SEGMENTER_CONFIG_MEMBER)
#undef DP_SEGMENTER_CONFIG_MEMBER
};

enum SegmenterConfigType : int32_t { kConfigBool, kConfigUint16, kConfigInt32, kConfigFloat };
enum SegmenterConfigRelation : int32_t { kRelationGreater, kRelationGreaterEqual, kRelationLessEqual };

struct SegmenterConfigField {
  const char* name;
  SegmenterConfigType type;
  double default_value;
  double min, max;
  SegmenterConfigRange range;
  const char* unit;      // "" when unitless
  const char* meaning;
};

struct SegmenterConfigConstraint {
  int32_t field, other;  // indices into kSegmenterConfigFields
  SegmenterConfigRelation relation;
};

namespace segmenter_config_detail {
template <class T> constexpr SegmenterConfigType type_of();
template <> constexpr SegmenterConfigType type_of<bool>() { return kConfigBool; }
template <> constexpr SegmenterConfigType type_of<uint16_t>() { return kConfigUint16; }
template <> constexpr SegmenterConfigType type_of<int32_t>() { return kConfigInt32; }
template <> constexpr SegmenterConfigType type_of<float>() { return kConfigFloat; }
enum FieldIndex : int32_t {
#define DP_SEGMENTER_CONFIG_INDEX(type, name, def, lo, hi, range, unit, meaning) k_##name,
  DP_SEGMENTER_CONFIG_FIELDS(DP_SEGMENTER_CONFIG_INDEX)
#undef DP_SEGMENTER_CONFIG_INDEX
  kFieldCount
};
}  // namespace segmenter_config_detail

constexpr int32_t kSegmenterConfigFieldCount = segmenter_config_detail::kFieldCount;

inline constexpr SegmenterConfigField kSegmenterConfigFields[] = {
#define DP_SEGMENTER_CONFIG_DESCRIPTOR(type, name, def, lo, hi, range, unit, meaning) \
  {#name, segmenter_config_detail::type_of<type>(), double(def), double(lo), double(hi), range, unit, meaning},
    DP_SEGMENTER_CONFIG_FIELDS(DP_SEGMENTER_CONFIG_DESCRIPTOR)
#undef DP_SEGMENTER_CONFIG_DESCRIPTOR
};

inline constexpr SegmenterConfigConstraint kSegmenterConfigConstraints[] = {
#define DP_SEGMENTER_CONFIG_CONSTRAINT(name, relation, other) \
  {segmenter_config_detail::k_##name, segmenter_config_detail::k_##other, relation},
    DP_SEGMENTER_CONFIG_RELATIONS(DP_SEGMENTER_CONFIG_CONSTRAINT)
#undef DP_SEGMENTER_CONFIG_CONSTRAINT
};
constexpr int32_t kSegmenterConfigConstraintCount =
    int32_t(sizeof kSegmenterConfigConstraints / sizeof kSegmenterConfigConstraints[0]);

// Field `index` of `config` as a double (exact for every field type). index in
// 0..kSegmenterConfigFieldCount − 1.
double segmenter_config_value(const SegmenterConfig& config, int32_t index);
// True when `value` lies in field `index`'s range (NaN never does).
bool segmenter_config_in_range(int32_t index, double value);
// True when constraint `index` (0..kSegmenterConfigConstraintCount − 1) holds.
bool segmenter_config_constraint_holds(const SegmenterConfig& config, int32_t index);

// The validation Segmenter::init and set_config apply: every field in its range, then every
// constraint. Returns true when valid; otherwise false with *bad_field (when not null) the index
// of the first field out of range, or −1 − c for the first failing constraint c.
bool segmenter_config_check(const SegmenterConfig& config, int32_t* bad_field = nullptr);

}  // namespace dp
