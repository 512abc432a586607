// Person tests of dp::Segmenter (runtime/segmentation/segmenter.h): which components, alone or
// joined with others, are people. The rules and the reason for each are in docs/segmentation.md
// ("The person test"); their parameters are SegmenterConfig fields (segmenter_config.h).
//
// Contract:
//   - Works on the candidates measured by the component stage (components.h) through the same
//     views into the Segmenter's arena; owns nothing. Tests are const; merge_fragments, split_box,
//     split_pair and low_person change candidates (statistics, owner, pixels' roots) or the hull
//     scratch rows, as each says.
//   - Bounded: each test is O(1) on a candidate's statistics or sweeps that candidate's image box a
//     fixed number of times; merge_fragments sweeps the image once and compares kMaxCandidates²
//     pairs at most. Grids and histograms live on the stack (at most 9 KB).
//   - Units: metres along or above the floor, pixels, shares in 0..1.
#pragma once
#include <stdint.h>

#include "runtime/segmentation/components.h"

namespace dp::seg {

struct PersonTests : ComponentStage {
  // The person test: the area, height and width of a person (min_person_area_m2,
  // min_person_height_m, max_person_width_m). cut: also the relaxed tests for components cut by
  // an image border or mostly hidden. short_top: a component cut by the top border may have only
  // cut_top_area_fraction of the area (only for new users: merging judges pieces by the full area).
  bool meets_person_test(const DepthFrame& frame, const Candidate& candidate, bool cut = true,
                          bool short_top = false) const;
  // cut_side_area_fraction's relaxation (touches the left or right border, not the top one, a floor
  // known, min_person_height_m high, that fraction of `need` pixels); no width test. O(1).
  bool cut_by_side(const DepthFrame& frame, const Candidate& candidate, float need) const;
  // Joins fragments into the bodies they belong to (Candidate::owner, statistics of the union).
  void merge_fragments(const DepthFrame& frame, int32_t candidate_count);
  // A component qualifying only as someone mostly hidden that is nearer than a user (or strict
  // candidate) whose image box it overlaps: a limb in front of that user, no one hidden.
  bool in_front_of_a_user(const DepthFrame& frame, int32_t candidate_count, int32_t k, const float* mean_z,
                          const bool* strict) const;
  // The candidate index of the user that candidate k (about to become a new user) belongs to, or −1
  // (absorb_radius_m, head_radius_m, legs_radius_m). Centroids in camera metres.
  int32_t absorbing_user(const DepthFrame& frame, int32_t candidate_count, int32_t k, const float* cx,
                         const float* cy, const float* cz) const;
  // 0 = not low or not a person; 1 = by its lid share (low_max_lid_share); 2 = by its outline only
  // (low_max_solidity); 3 = cut by the bottom border above the floor, by its lid share
  // (cut_bottom_low_max_lid_share). Non-const: the outline uses the hull scratch rows.
  int32_t low_person(const DepthFrame& frame, int32_t k);
  // 0 = kept, 1 = box dropped (its pixels leave the component), 2 = no user (box_split_height_m,
  // box_reject_min_share). low_outline: the component qualified only as low by its outline
  // (low_max_solidity): judged although low, and a lid apart from the rest makes it no user.
  int32_t split_box(const DepthFrame& frame, int32_t k, bool low_outline = false);
  // Tall furniture (furniture_smooth_min_share, furniture_pole_max_width_m): 0 = not furniture (or
  // the rules off, or no floor), 1 = a prism (a door, shelf or chair: its width along the floor
  // nearly the same from one 0.1 m height band to the next), 2 = a pole (a coat stand: most bands
  // a pole's width). One sweep over candidate k's image box (its merged pieces), two arrays of
  // kFurnitureBands floats on the stack.
  int32_t furniture(const DepthFrame& frame, int32_t k) const;
  // pair_bridge_max_m: cuts candidate k in two at a bridge; returns the index of the new
  // candidate (candidate_count, which the caller then counts) or −1 when k is kept whole.
  int32_t split_pair(const DepthFrame& frame, int32_t candidate_count, int32_t k);

 private:
  struct MergeState {
    uint64_t touches[kMaxCandidates];  // bit m of touches[k]: k and m touch
    uint64_t hides[kMaxCandidates];    // bit m of hides[k]: k hides part of m
    bool person[kMaxCandidates];       // meets the person test without the border relaxations
    bool full[kMaxCandidates];         // meets it with them
    bool hidden_only[kMaxCandidates];  // qualifies only as someone mostly hidden
  };
  void find_contacts(const DepthFrame& frame, bool hidden_legs_on, MergeState* s) const;
  float floor_distance2(float dx, float dy, float dz) const;
  bool may_merge(const MergeState& s, int32_t k, int32_t m, float* distance2) const;
  void merge_into(const DepthFrame& frame, int32_t candidate_count, int32_t k, int32_t into, MergeState* s);
  void resolve_owners(int32_t candidate_count);
};

}  // namespace dp::seg
