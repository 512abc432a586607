#include "runtime/segmentation/users.h"

#include <math.h>

namespace dp {
const char* user_arrival_name(int32_t arrival) {
  switch (arrival) {
    case kUserContinued: return "continued";
    case kUserNew: return "new";
    case kUserReturned: return "returned";
  }
  return "?";
}
}  // namespace dp

namespace dp::seg {

namespace {
// A candidate's silhouette area in m²: its pixels at its centroid depth z (users.h).
float silhouette_area(const DepthFrame& f, const Candidate& c, float z) {
  return float(c.pixels) * z * z / (f.intrinsics.fx * f.intrinsics.fy);
}

// The median of the first n ≤ kReidHeightSamples samples (insertion sort).
float median_of(const float* samples, int32_t n) {
  float sorted[kReidHeightSamples];
  for (int32_t i = 0; i < n; ++i) {
    const float h = samples[i];
    int32_t k = i;
    for (; k > 0 && sorted[k - 1] > h; --k) sorted[k] = sorted[k - 1];
    sorted[k] = h;
  }
  return n > 0 ? sorted[n / 2] : 0.0f;
}
}  // namespace

// The per-frame verdicts on the candidates and the tracks they matched (assign_users).
struct UserStage::Verdicts {
  bool strict[kMaxCandidates];   // meets the full person test (or as someone low): may become a new user
  bool relaxed[kMaxCandidates];  // wide and large enough to keep a tracked user's id
  bool outline[kMaxCandidates];  // qualifies only as low by its outline (low_max_solidity)
  float cx[kMaxCandidates], cy[kMaxCandidates], cz[kMaxCandidates];  // centroids, camera metres
  bool track_matched[kMaxUsers];
  int32_t arrival[kMaxUsers];  // UserArrival of each track's user this frame
};

void UserStage::set_centroid(int32_t k, Verdicts* v) const {
  const Candidate& c = candidates_[k];
  v->cx[k] = float(c.sx / c.pixels);
  v->cy[k] = float(c.sy / c.pixels);
  v->cz[k] = float(c.sz / c.pixels);
}

// Centroids and the two person verdicts of every candidate left after merging.
void UserStage::judge_candidates(const DepthFrame& f, int32_t n, Verdicts* v) {
  const SegmenterConfig& cfg = *config_;
  const float focal2 = f.intrinsics.fx * f.intrinsics.fy;
  for (int32_t k = 0; k < n; ++k) {
    const Candidate& c = candidates_[k];
    if (c.pixels == 0) {  // merged into another candidate
      v->strict[k] = v->relaxed[k] = false;
      v->cx[k] = v->cy[k] = v->cz[k] = 0.0f;
      continue;
    }
    set_centroid(k, v);
    const float need = cfg.min_person_area_m2 * focal2 / (v->cz[k] * v->cz[k]);
    v->strict[k] = meets_person_test(f, c, true, true);
    const int32_t low = v->strict[k] ? 0 : low_person(f, k);
    v->strict[k] = v->strict[k] || low > 0;
    v->outline[k] = low == 2;
    v->relaxed[k] = c.x_max - c.x_min <= cfg.max_person_width_m && float(c.pixels) >= cfg.tracked_area_fraction * need;
  }
}

// Greedy nearest-centroid association: repeatedly the closest (track, component) pair, the
// distance measured against each track's reach from its predicted position.
void UserStage::associate_tracks(int32_t n, Verdicts* v) {
  const SegmenterConfig& cfg = *config_;
  float predicted[kMaxUsers][3], reach[kMaxUsers], min_top[kMaxUsers];
  for (int32_t t = 0; t < kMaxUsers; ++t) {
    const Track& tr = tracks_[t];
    const float steps = float(tr.lost_frames + 1);
    for (int k = 0; k < 3; ++k) predicted[t][k] = tr.centroid[k] + tr.velocity[k] * steps;
    reach[t] = cfg.association_distance_m + cfg.association_growth_m * float(tr.lost_frames);
    // A lost track's reach grows over the clutter around it: what it may take back must be about
    // as tall as its person was (lost_min_height_ratio).
    const bool known = tr.active && tr.lost_frames > 0 && tr.height_count >= kReidHeightSamplesNeeded;
    min_top[t] = known ? cfg.lost_min_height_ratio * median_of(tr.heights, tr.height_count) : -1e30f;
  }
  for (int round = 0; round < kMaxUsers; ++round) {
    int32_t best_t = -1, best_k = -1;
    float best_ratio = 1.0f;  // distance / reach: a lost track's wider reach does not win ties
    for (int32_t t = 0; t < kMaxUsers; ++t) {
      if (!tracks_[t].active || v->track_matched[t]) continue;
      for (int32_t k = 0; k < n; ++k) {
        if (!v->relaxed[k] || candidates_[k].user) continue;
        if (candidates_[k].top < min_top[t]) continue;
        const float dx = v->cx[k] - predicted[t][0], dy = v->cy[k] - predicted[t][1], dz = v->cz[k] - predicted[t][2];
        const float ratio = sqrtf(dx * dx + dy * dy + dz * dz) / reach[t];
        if (ratio <= best_ratio) { best_ratio = ratio; best_t = t; best_k = k; }
      }
    }
    if (best_t < 0) break;
    v->track_matched[best_t] = true;
    candidates_[best_k].user = best_t + 1;
  }
}

// Tracked users re-judged as furniture (furniture_track_frames, furniture_track_window,
// furniture_static_m): the new-user test judges a component once, so furniture admitted in one
// frame (a person touching it, part of it hidden, one noisy frame) would stay a user for good, and
// the background model never learns what lies inside a user's box. Evidence over a window of frames
// at one place ends its user. On the validation sequences a tracked person was furniture-shaped in
// at most 2 frames of any 30, the furniture kept as users in 4 to 30 (docs/segmentation.md).
void UserStage::drop_tracked_furniture(const DepthFrame& f, int32_t n, Verdicts* v) {
  const SegmenterConfig& cfg = *config_;
  if (cfg.furniture_track_frames <= 0) return;
  const uint32_t window = cfg.furniture_track_window >= 32 ? 0xffffffffu : (1u << cfg.furniture_track_window) - 1u;
  for (int32_t k = 0; k < n; ++k) {
    const int32_t id = candidates_[k].user;
    if (id <= 0) continue;
    Track& tr = tracks_[id - 1];
    const bool shaped = furniture(f, k) != 0;
    const float dx = v->cx[k] - tr.furniture_anchor[0], dy = v->cy[k] - tr.furniture_anchor[1],
                dz = v->cz[k] - tr.furniture_anchor[2];
    const bool still = dx * dx + dy * dy + dz * dz <= cfg.furniture_static_m * cfg.furniture_static_m;
    if (tr.furniture_history != 0 && still) {
      tr.furniture_history = ((tr.furniture_history << 1) | (shaped ? 1u : 0u)) & window;
    } else {  // no evidence yet, or it moved: the evidence starts over here
      tr.furniture_history = shaped ? 1u : 0u;
      tr.furniture_anchor[0] = v->cx[k];
      tr.furniture_anchor[1] = v->cy[k];
      tr.furniture_anchor[2] = v->cz[k];
    }
    int32_t evidence = 0;
    for (int32_t bit = 0; bit < 32; ++bit) evidence += int32_t((tr.furniture_history >> bit) & 1u);
    if (evidence < cfg.furniture_track_frames) continue;
    tr = Track{};  // freed, not gone: the id waits for no one
    v->track_matched[id - 1] = false;
    v->strict[k] = false;  // nor a new user this frame
    candidates_[k].user = 0;
    const float centroid[3] = {v->cx[k], v->cy[k], v->cz[k]};
    mark_furniture(candidates_[k], centroid);
  }
}

// Remembers a piece of furniture dropped as a user: a free mark, else the one unseen longest.
void UserStage::mark_furniture(const Candidate& c, const float* centroid) {
  int32_t slot = 0;
  for (int32_t m = 0; m < kMaxUsers; ++m) {
    const FurnitureMark& mark = furniture_marks_[m];
    if (!mark.active) { slot = m; break; }
    if (mark.unseen_frames > furniture_marks_[slot].unseen_frames) slot = m;
  }
  FurnitureMark& mark = furniture_marks_[slot];
  mark.active = 1;
  mark.unseen_frames = 0;
  for (int a = 0; a < 3; ++a) mark.centroid[a] = centroid[a];
  mark.top = c.top;
}

// Components no track matched, at a remembered piece's place and height, are that piece: no new
// user. Marks no component matched this frame age, and go after track_keep_frames.
void UserStage::keep_marked_furniture_out(int32_t n, Verdicts* v) {
  const SegmenterConfig& cfg = *config_;
  const float reach2 = cfg.furniture_static_m * cfg.furniture_static_m;
  for (int32_t m = 0; m < kMaxUsers; ++m) {
    FurnitureMark& mark = furniture_marks_[m];
    if (!mark.active) continue;
    bool seen = false;
    for (int32_t k = 0; k < n; ++k) {
      const Candidate& c = candidates_[k];
      if (c.pixels == 0 || c.user != 0 || fabsf(c.top - mark.top) > cfg.furniture_static_m) continue;
      const float dx = v->cx[k] - mark.centroid[0], dy = v->cy[k] - mark.centroid[1], dz = v->cz[k] - mark.centroid[2];
      if (dx * dx + dy * dy + dz * dz > reach2) continue;
      v->strict[k] = false;
      seen = true;
    }
    if (seen) {
      mark.unseen_frames = 0;
    } else if (++mark.unseen_frames > cfg.track_keep_frames) {
      mark.active = 0;
    }
  }
}

// New users: unmatched components meeting the full person test, largest first, lowest free id;
// each may first be found a limb in front of a user, a box, two people or a piece of a user.
// Returns the candidate count, grown by the components cut in two (split_pair).
int32_t UserStage::admit_new_users(const DepthFrame& f, int32_t n, Verdicts* v, SegmentationResult* r) {
  const SegmenterConfig& cfg = *config_;
  for (int round = 0; round < kMaxCandidates; ++round) {
    int32_t best_k = -1;
    for (int32_t k = 0; k < n; ++k)
      if (v->strict[k] && !candidates_[k].user && (best_k < 0 || candidates_[k].pixels > candidates_[best_k].pixels))
        best_k = k;
    if (best_k < 0) break;
    if (in_front_of_a_user(f, n, best_k, v->cz, v->strict)) {  // a limb reaching out, not someone hidden
      v->strict[best_k] = false;
      continue;
    }
    const int32_t split = split_box(f, best_k, v->outline[best_k] && cfg.low_outline_box_split != 0);
    if (split == 2) {  // a box with a hand or arm over it (box_reject_min_share)
      v->strict[best_k] = false;
      continue;
    }
    if (split == 1) set_centroid(best_k, v);  // a box dropped from a person (box_split_height_m)
    const int32_t pair = split_pair(f, n, best_k);
    if (pair >= 0) {  // two people joined by an arm (pair_bridge_max_m): the other one waits its round
      ++n;
      set_centroid(best_k, v);
      set_centroid(pair, v);
      v->strict[pair] = true;
      v->relaxed[pair] = false;
    }
    if (furniture(f, best_k) != 0) {  // a door, shelf, chair or coat stand (furniture_smooth_min_share, furniture_pole_max_width_m)
      v->strict[best_k] = false;
      continue;
    }
    const int32_t into = absorbing_user(f, n, best_k, v->cx, v->cy, v->cz);
    if (into >= 0) {  // a piece of that user's body behind a depth jump (absorb_radius_m, head_radius_m)
      v->strict[best_k] = false;
      Candidate& dst = candidates_[into];
      Candidate& src = candidates_[best_k];
      add_stats(dst, src, floor_->valid != 0);
      set_centroid(into, v);
      for (int32_t j = 0; j < n; ++j)
        if (candidates_[j].owner == best_k) candidates_[j].owner = into;  // best_k's own pieces too
      src.pixels = 0;
      continue;
    }
    const float centroid[3] = {v->cx[best_k], v->cy[best_k], v->cz[best_k]};
    bool returned = false;
    const int32_t slot = slot_for_new_user(candidates_[best_k], silhouette_area(f, candidates_[best_k], centroid[2]),
                                           centroid, &returned);
    if (slot < 0) {
      r->flags |= kSegFlagUsersTruncated;
      break;
    }
    Track& tr = tracks_[slot];
    if (!returned) tr = Track{};  // a returning person keeps its height samples
    tr.active = 1;
    tr.gone = 0;
    tr.lost_frames = 0;
    tr.frames_tracked = 0;
    for (int a = 0; a < 3; ++a) {
      tr.centroid[a] = centroid[a];
      tr.velocity[a] = 0.0f;
    }
    v->arrival[slot] = returned ? kUserReturned : kUserNew;
    v->track_matched[slot] = true;
    candidates_[best_k].user = slot + 1;
  }
  return n;
}

// The id of a new user (slot, −1 when every id is in use): a gone track's whose person it is by
// height, silhouette area and reach (*returned = true; none when two gone tracks' heights fit),
// else the lowest id neither in use nor gone, else the one gone longest.
int32_t UserStage::slot_for_new_user(const Candidate& c, float area_m2, const float* centroid, bool* returned) const {
  const SegmenterConfig& cfg = *config_;
  int32_t match = -1, height_matches = 0, free_slot = -1, oldest = -1;
  for (int32_t t = 0; t < cfg.max_users; ++t) {
    const Track& tr = tracks_[t];
    if (tr.active) continue;
    if (!tr.gone) {
      if (free_slot < 0) free_slot = t;
      continue;
    }
    if (oldest < 0 || tr.lost_frames > tracks_[oldest].lost_frames) oldest = t;
    if (fabsf(c.top - tr.height_m) > cfg.reid_height_tolerance_m) continue;
    // The area test comes after the count: two gone people of one height still leave the
    // newcomer alone, whatever their areas.
    ++height_matches;
    const float ratio = cfg.reid_area_ratio;
    if (ratio > 0.0f && (area_m2 > ratio * tr.area_m2 || tr.area_m2 > ratio * area_m2)) continue;
    const float dx = centroid[0] - tr.centroid[0], dy = centroid[1] - tr.centroid[1], dz = centroid[2] - tr.centroid[2];
    const float reach = cfg.association_distance_m + cfg.reid_speed_m * float(tr.lost_frames);
    if (dx * dx + dy * dy + dz * dz <= reach * reach) match = t;
  }
  *returned = height_matches == 1 && match >= 0;
  if (*returned) return match;
  return free_slot >= 0 ? free_slot : oldest;
}

// Tracks (matched: moved and counted; unmatched: lost, dropped after track_keep_frames) and the
// visible users, by id.
void UserStage::update_tracks(const DepthFrame& f, const Verdicts& v, SegmentationResult* r) {
  const SegmenterConfig& cfg = *config_;
  for (int32_t t = 0; t < kMaxUsers; ++t) {
    Track& tr = tracks_[t];
    if (!tr.active) {
      if (tr.gone && ++tr.lost_frames > cfg.reid_window_frames) tr.gone = 0;
      continue;
    }
    if (!v.track_matched[t]) {
      tr.frames_tracked = 0;
      if (++tr.lost_frames > cfg.track_keep_frames) {
        tr.active = 0;
        tr.gone = cfg.reid_window_frames > cfg.track_keep_frames && tr.height_count >= kReidHeightSamplesNeeded;
        tr.height_m = median_of(tr.heights, tr.height_count);
        tr.area_m2 = median_of(tr.areas, tr.height_count);
      }
      continue;
    }
    int32_t k = 0;
    while (candidates_[k].user != t + 1) ++k;
    const Candidate& c = candidates_[k];
    // Velocity: smoothed displacement per frame (a reappearing user spreads it over the gap).
    const float now[3] = {v.cx[k], v.cy[k], v.cz[k]};
    const float gap = float(tr.lost_frames + 1);
    for (int a = 0; a < 3; ++a) {
      tr.velocity[a] = tr.frames_tracked > 0 || tr.lost_frames > 0
                           ? 0.5f * tr.velocity[a] + 0.5f * (now[a] - tr.centroid[a]) / gap
                           : 0.0f;
      tr.centroid[a] = now[a];
    }
    tr.lost_frames = 0;
    if (tr.frames_tracked < 0x7fffffff) ++tr.frames_tracked;
    tr.heights[tr.height_next] = c.top;
    tr.areas[tr.height_next] = silhouette_area(f, c, v.cz[k]);
    tr.height_next = (tr.height_next + 1) % kReidHeightSamples;
    if (tr.height_count < kReidHeightSamples) ++tr.height_count;
    UserInfo& u = r->users[r->user_count++];
    u.id = t + 1;
    u.pixel_count = c.pixels;
    u.centroid_m[0] = v.cx[k]; u.centroid_m[1] = v.cy[k]; u.centroid_m[2] = v.cz[k];
    u.u_min = c.u_min; u.v_min = c.v_min; u.u_max = c.u_max; u.v_max = c.v_max;
    u.top_height_m = c.top;
    u.frames_tracked = tr.frames_tracked;
    u.arrival = v.arrival[t];
    r->user_pixels += c.pixels;
  }
}

// The label image: every pixel of a candidate takes its owner's user id (0 for none).
void UserStage::write_labels(const DepthFrame& f, SegmentationResult* r) const {
  const int32_t w = f.width;
  for (int32_t v = 0; v < f.height; ++v) {
    uint8_t* out = r->labels + size_t(v) * f.stride_px;
    const int32_t* parent = parent_ + size_t(v) * w;
    for (int32_t u = 0; u < w; ++u) {
      const int32_t root = parent[u];
      const int32_t k = root >= 0 ? aux_[root] : -1;
      out[u] = k >= 0 ? uint8_t(candidates_[candidates_[k].owner].user) : 0;
    }
  }
}

void UserStage::assign_users(const DepthFrame& f, int32_t candidate_count, SegmentationResult* r) {
  merge_fragments(f, candidate_count);
  Verdicts v{};
  judge_candidates(f, candidate_count, &v);
  associate_tracks(candidate_count, &v);
  drop_tracked_furniture(f, candidate_count, &v);
  keep_marked_furniture_out(candidate_count, &v);
  admit_new_users(f, candidate_count, &v, r);
  update_tracks(f, v, r);
  write_labels(f, r);
}

}  // namespace dp::seg
