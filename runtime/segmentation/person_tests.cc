#include "runtime/segmentation/person_tests.h"

namespace dp::seg {

namespace {

// Two pieces as one candidate: y's fields with x's statistics added. The occlusion, hidden-edge,
// hull and gap counts are summed over the pieces (each measured in its own box: lower bounds for
// the union's, so its solidity comes out higher, more box-like, not lower).
Candidate united(const Candidate& x, const Candidate& y, bool use_floor) {
  Candidate c = y;
  add_stats(c, x, use_floor);
  c.occluded += x.occluded;  // each counted in its own box: a lower bound for the union's
  c.hidden_edge += x.hidden_edge;
  c.hidden_below += x.hidden_below;
  c.hull += x.hull;          // each piece's own hull: the union's hull is at least as large,
  c.hull_filled += x.hull_filled;  // so its solidity comes out higher (more box-like), not lower
  c.gap_rows += x.gap_rows;  // each piece's own rows with a gap between two legs
  // The columns of the pieces cut by the top border, widened by a piece that shares columns with
  // them (below them: a shin, the body under raised arms), not by one beside them.
  const bool xc = x.cut_u_max >= x.cut_u_min, yc = y.cut_u_max >= y.cut_u_min;
  if (xc != yc) {
    const Candidate& cut = xc ? x : y;
    const Candidate& other = xc ? y : x;
    c.cut_u_min = cut.cut_u_min;
    c.cut_u_max = cut.cut_u_max;
    c.cut_pixels = cut.cut_pixels;
    if (other.u_min <= cut.cut_u_max && other.u_max >= cut.cut_u_min) {
      if (other.u_min < c.cut_u_min) c.cut_u_min = other.u_min;
      if (other.u_max > c.cut_u_max) c.cut_u_max = other.u_max;
      c.cut_pixels += other.pixels;
    }
  } else if (xc) {
    if (x.cut_u_min < c.cut_u_min) c.cut_u_min = x.cut_u_min;
    if (x.cut_u_max > c.cut_u_max) c.cut_u_max = x.cut_u_max;
    c.cut_pixels += x.cut_pixels;
  }
  return c;
}

}  // namespace

// Cut by the left or right border (cut_side_area_fraction): touches either side but not
// the top border (whose height would be out of view), a floor is known, as high as a person and
// holds the given fraction of the person area `need`. The width test is the caller's.
bool PersonTests::cut_by_side(const DepthFrame& f, const Candidate& c, float need) const {
  const SegmenterConfig& cfg = *config_;
  return cfg.cut_side_area_fraction > 0.0f && floor_->valid != 0 && (c.u_min == 0 || c.u_max == f.width - 1) &&
         c.v_min > 0 && c.top >= cfg.min_person_height_m &&
         float(c.pixels) >= cfg.cut_side_area_fraction * need;
}

bool PersonTests::meets_person_test(const DepthFrame& f, const Candidate& c, bool cut, bool short_top) const {
  const SegmenterConfig& cfg = *config_;
  const float z = float(c.sz / c.pixels);
  const float need = cfg.min_person_area_m2 * f.intrinsics.fx * f.intrinsics.fy / (z * z);
  if (c.x_max - c.x_min > cfg.max_person_width_m) return false;
  // Cut by the bottom border (the head and shoulders of someone close): part of the area is out
  // of view, the height is not (cut_bottom_area_fraction).
  if (cut && cfg.cut_bottom_area_fraction > 0.0f && c.v_max == f.height - 1 && floor_->valid != 0 &&
      c.top >= cfg.min_person_height_m && float(c.pixels) >= cfg.cut_bottom_area_fraction * need)
    return true;
  // Cut by the left or right border: part of the area is out of view, the height is not
  // (cut_side_area_fraction).
  if (cut && cut_by_side(f, c, need)) return true;
  // Mostly hidden behind something nearer: the height shows, the area does not
  // (hidden_area_fraction).
  if (cut && cfg.hidden_area_fraction > 0.0f && c.hidden_edge >= cfg.hidden_min_edge &&
      c.top >= cfg.min_person_height_m && float(c.pixels) >= cfg.hidden_area_fraction * need)
    return true;
  // Short of the area, only the top-border test may still accept it (cut_top_area_fraction).
  const bool area = float(c.pixels) >= need;
  if (!area && !(cut && short_top && cfg.cut_top_area_fraction > 0.0f && float(c.pixels) >= cfg.cut_top_area_fraction * need))
    return false;
  if (area && c.top >= cfg.min_person_height_m) return true;
  // Cut by the top border: the height is out of view (cut_max_fill).
  if (!cut || cfg.cut_max_fill <= 0.0f || c.v_min > 0 || floor_->valid == 0) return false;
  // Off the floor only when something nearer hides the lower part (cut_hidden_floor_contact_m).
  if (c.bottom > cfg.cut_floor_contact_m &&
      !(cfg.cut_hidden_floor_contact_m > 0.0f && c.bottom <= cfg.cut_hidden_floor_contact_m &&
        c.hidden_below >= cfg.hidden_min_edge))
    return false;
  // A union: over the columns of its pieces cut by the border only (cut_fill_border_columns).
  const bool pieces = cfg.cut_fill_border_columns != 0 && c.cut_u_max >= c.cut_u_min && c.cut_pixels < c.pixels;
  const int32_t cols = pieces ? c.cut_u_max - c.cut_u_min + 1 : c.u_max - c.u_min + 1;
  const float box = float(cols) * float(c.v_max - c.v_min + 1);
  const float filled = float((pieces ? c.cut_pixels : c.pixels) + c.occluded);
  if (filled <= cfg.cut_max_fill * box) return true;
  // The hull only where nothing in front cuts the silhouette: an object seen partly behind legs
  // takes their outline (cut_solidity_max_hidden).
  if (c.hull > 0 && float(c.hull_filled) <= cfg.cut_max_solidity * float(c.hull) &&
      float(c.occluded) <= cfg.cut_solidity_max_hidden * float(c.pixels))
    return true;
  // Two legs apart in enough rows (cut_gap_min_share).
  return cfg.cut_gap_min_share > 0.0f && float(c.gap_rows) >= cfg.cut_gap_min_share * float(c.v_max - c.v_min + 1) &&
         filled <= cfg.cut_gap_max_fill * box;
}

// Which candidates touch and which hide part of which: one sweep over the image. Bit m of
// touches[k]: a 4-neighbour pair of k and m within fragment_join_mm in depth. Bit m of hides[k]
// (only with the hidden-legs rule on): a 4-neighbour of k nearer than one of m by more than
// fragment_join_mm (k is in front of m beyond a depth jump).
void PersonTests::find_contacts(const DepthFrame& f, bool hidden_legs_on, MergeState* s) const {
  const SegmenterConfig& cfg = *config_;
  uint64_t* touches = s->touches;
  uint64_t* hides = s->hides;
  const int32_t w = f.width;
  const int32_t join = int32_t(cfg.fragment_join_mm);
  for (int32_t v = 0; v < f.height; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const int32_t* parent = parent_ + size_t(v) * w;
    for (int32_t u = 0; u < w; ++u) {
      if (parent[u] < 0) continue;
      const int32_t k = aux_[parent[u]];
      if (k < 0) continue;
      if (u + 1 < w && parent[u + 1] >= 0) {
        const int32_t m = aux_[parent[u + 1]];
        const int32_t dz = int32_t(row[u]) - int32_t(row[u + 1]);
        if (m >= 0 && m != k && dz <= join && dz >= -join) {
          touches[k] |= uint64_t(1) << m;
          touches[m] |= uint64_t(1) << k;
        }
        if (hidden_legs_on && m >= 0 && m != k && dz < -join) hides[k] |= uint64_t(1) << m;
        if (hidden_legs_on && m >= 0 && m != k && dz > join) hides[m] |= uint64_t(1) << k;
      }
      if (v + 1 < f.height && parent[u + w] >= 0) {
        const int32_t m = aux_[parent[u + w]];
        const int32_t dz = int32_t(row[u]) - int32_t(row[u + f.stride_px]);
        if (m >= 0 && m != k && dz <= join && dz >= -join) {
          touches[k] |= uint64_t(1) << m;
          touches[m] |= uint64_t(1) << k;
        }
        if (hidden_legs_on && m >= 0 && m != k && dz < -join) hides[k] |= uint64_t(1) << m;
        if (hidden_legs_on && m >= 0 && m != k && dz > join) hides[m] |= uint64_t(1) << k;
      }
    }
  }
}

// Squared distance of a displacement (camera metres) along the floor: without its part along the
// floor normal, or without its camera-y part when no floor is known.
float PersonTests::floor_distance2(float dx, float dy, float dz) const {
  float d[3] = {dx, dy, dz};
  if (floor_->valid != 0) {
    const float up = d[0] * floor_->nx + d[1] * floor_->ny + d[2] * floor_->nz;
    d[0] -= up * floor_->nx; d[1] -= up * floor_->ny; d[2] -= up * floor_->nz;
  } else {
    d[1] = 0.0f;
  }
  return d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
}

// Whether fragment k may join candidate m (before the union's own person test), and their
// squared centroid distance along the floor in *distance2.
bool PersonTests::may_merge(const MergeState& s, int32_t k, int32_t m, float* distance2) const {
  const SegmenterConfig& cfg = *config_;
  const bool use_floor = floor_->valid != 0;
  const bool hidden_on = cfg.hidden_area_fraction > 0.0f;
  const bool hidden_legs_on = hidden_on && use_floor && cfg.hidden_legs_radius_m > 0.0f;
  const Candidate& frag = candidates_[k];
  const Candidate& body = candidates_[m];
  // touches[k] holds k itself once something merged into k.
  const bool touching = (s.touches[k] >> m) & 1u;
  const float d2 = floor_distance2(float(frag.sx / frag.pixels - body.sx / body.pixels),
                                   float(frag.sy / frag.pixels - body.sy / body.pixels),
                                   float(frag.sz / frag.pixels - body.sz / body.pixels));
  *distance2 = d2;
  // Pieces of someone hidden behind a nearer body lie on either side of it: two pieces that
  // each qualify only as hidden join within hidden_pair_radius_m.
  // A piece that qualifies only as hidden takes another one, or a smaller hidden piece that
  // does not qualify at all (a leg below a head).
  const bool both_hidden = hidden_on && frag.hidden_edge >= cfg.hidden_min_edge &&
                           body.hidden_edge >= cfg.hidden_min_edge &&
                           ((s.hidden_only[k] && s.hidden_only[m]) ||
                            (s.hidden_only[m] && !s.full[k] && frag.pixels <= body.pixels) ||
                            (s.hidden_only[k] && !s.full[m] && body.pixels <= frag.pixels));
  // Legs below a body that does not reach the floor (legs_radius_m): the piece stands on the
  // floor and does not qualify alone, the body qualifies; the piece is lower in height and in the
  // image, shares columns with it and has at most twice its pixels.
  const int32_t cols_shared = (frag.u_max < body.u_max ? frag.u_max : body.u_max) -
                              (frag.u_min > body.u_min ? frag.u_min : body.u_min) + 1;
  const bool legs_below = cfg.legs_radius_m > 0.0f && use_floor && s.person[m] && !s.full[k] &&
                          body.bottom > cfg.cut_floor_contact_m && frag.bottom <= cfg.cut_floor_contact_m &&
                          frag.top < body.top && frag.v_min > body.v_min && cols_shared > 0 &&
                          frag.pixels <= 2 * body.pixels && d2 <= cfg.legs_radius_m * cfg.legs_radius_m;
  // The legs of someone partly hidden (hidden_legs_radius_m): both pieces have hidden edges, the
  // piece stands on the floor and does not qualify, the other qualifies; the piece is lower in height
  // and in the image and reaches up to within hidden_legs_max_gap_m of the other's lowest point.
  const bool hidden_legs = hidden_legs_on && !s.full[k] && s.full[m] && frag.hidden_edge >= cfg.hidden_min_edge &&
                           body.hidden_edge >= cfg.hidden_min_edge && frag.bottom <= cfg.cut_floor_contact_m &&
                           body.bottom > cfg.cut_floor_contact_m && frag.top < body.top && frag.v_min > body.v_min &&
                           frag.top + cfg.hidden_legs_max_gap_m >= body.bottom && !((s.hides[k] >> m) & 1u) &&
                           float(frag.pixels) <= cfg.hidden_legs_max_ratio * float(body.pixels) &&
                           d2 <= cfg.hidden_legs_radius_m * cfg.hidden_legs_radius_m;
  const bool close = d2 <= cfg.fragment_pair_radius_m * cfg.fragment_pair_radius_m ||
                     (both_hidden && d2 <= cfg.hidden_pair_radius_m * cfg.hidden_pair_radius_m) || legs_below ||
                     hidden_legs;
  if (d2 > cfg.fragment_radius_m * cfg.fragment_radius_m && !both_hidden && !legs_below && !hidden_legs) return false;
  // Pieces that do not touch (a person cut in two by someone standing in front) join only
  // when closer along the floor than two people can stand.
  if (!touching && !close) return false;
  // Two pieces of one body that each qualify (a torso over its legs, an arm in front of the
  // legs): the smaller joins.
  if (s.person[k]) {
    if (!s.person[m] || candidates_[m].pixels < candidates_[k].pixels) return false;
    // Stacked in the image (same columns, little row overlap), or closer along the floor than
    // two people can stand; unlike two people side by side or one behind the other.
    const Candidate& a = candidates_[k];
    const Candidate& b = candidates_[m];
    const int32_t cols = (a.u_max < b.u_max ? a.u_max : b.u_max) - (a.u_min > b.u_min ? a.u_min : b.u_min) + 1;
    const int32_t rows = (a.v_max < b.v_max ? a.v_max : b.v_max) - (a.v_min > b.v_min ? a.v_min : b.v_min) + 1;
    const int32_t narrow = (a.u_max - a.u_min < b.u_max - b.u_min ? a.u_max - a.u_min : b.u_max - b.u_min) + 1;
    const int32_t short_rows = (a.v_max - a.v_min < b.v_max - b.v_min ? a.v_max - a.v_min : b.v_max - b.v_min) + 1;
    const bool stacked = 2 * cols >= narrow && 10 * rows <= 6 * short_rows;
    if (!stacked && !close) return false;
  }
  // Neither qualifies alone: the smaller piece must be a real share of the union, or a hand
  // reaching over a box would lend the box its height.
  if (!s.full[k] && !s.full[m]) {
    const int32_t small = frag.pixels < body.pixels ? frag.pixels : body.pixels;
    if (float(small) < cfg.fragment_min_share * float(frag.pixels + body.pixels)) return false;
  }
  return true;
}

// Fragment k joins candidate `into`: the statistics, the verdicts and the contact bits of the
// union go to `into`; k keeps no pixels and names `into` as its owner.
void PersonTests::merge_into(const DepthFrame& f, int32_t n, int32_t k, int32_t into, MergeState* s) {
  const SegmenterConfig& cfg = *config_;
  Candidate& frag = candidates_[k];
  candidates_[into] = united(frag, candidates_[into], floor_->valid != 0);
  s->hidden_only[into] = candidates_[into].hidden_edge >= cfg.hidden_min_edge && !meets_person_test(f, candidates_[into], false);
  s->person[into] = s->full[into] = true;
  s->touches[into] |= s->touches[k];
  s->hides[into] |= s->hides[k];
  for (int32_t j = 0; j < n; ++j)
    if ((s->hides[j] >> k) & 1u) s->hides[j] |= uint64_t(1) << into;
  frag.owner = into;
  frag.pixels = 0;  // no longer a component of its own
}

// Owners of owners (a candidate merged into one that merged later) resolve to the last.
void PersonTests::resolve_owners(int32_t n) {
  for (int32_t k = 0; k < n; ++k)
    for (int32_t hop = 0; hop < kMaxCandidates && candidates_[candidates_[k].owner].owner != candidates_[k].owner; ++hop)
      candidates_[k].owner = candidates_[candidates_[k].owner].owner;
}

void PersonTests::merge_fragments(const DepthFrame& f, int32_t n) {
  const SegmenterConfig& cfg = *config_;
  if (cfg.fragment_join_mm <= 0.0f || n < 2) return;
  const bool use_floor = floor_->valid != 0;
  const bool hidden_on = cfg.hidden_area_fraction > 0.0f;
  const bool hidden_legs_on = hidden_on && use_floor && cfg.hidden_legs_radius_m > 0.0f;
  MergeState s{};
  find_contacts(f, hidden_legs_on, &s);
  // Pieces that qualify only as cut by the border are fragments here: they may still join the rest of
  // their body.
  for (int32_t k = 0; k < n; ++k) {
    s.person[k] = meets_person_test(f, candidates_[k], false);
    s.full[k] = s.person[k] || meets_person_test(f, candidates_[k], true);
  }
  // Passes only as someone mostly hidden (hidden_area_fraction).
  for (int32_t k = 0; k < n; ++k)
    s.hidden_only[k] = s.full[k] && !s.person[k] && candidates_[k].hidden_edge >= cfg.hidden_min_edge;
  // A fragment joins the nearest touching (or, within fragment_pair_radius_m, not touching)
  // candidate with which it forms a person: a body cut in two by a depth jump or by someone in
  // front (both pieces may qualify on their own), or a piece of a body that qualifies.
  float radius = cfg.fragment_radius_m > cfg.hidden_pair_radius_m || !hidden_on ? cfg.fragment_radius_m
                                                                              : cfg.hidden_pair_radius_m;
  if (cfg.legs_radius_m > radius) radius = cfg.legs_radius_m;
  if (hidden_legs_on && cfg.hidden_legs_radius_m > radius) radius = cfg.hidden_legs_radius_m;
  for (int32_t k = 0; k < n; ++k) {
    if (candidates_[k].pixels == 0) continue;
    int32_t best = -1;
    float best_d2 = radius * radius;
    for (int32_t m = 0; m < n; ++m) {
      if (m == k || candidates_[m].pixels == 0) continue;
      float d2 = 0.0f;
      if (!may_merge(s, k, m, &d2)) continue;
      if (d2 <= best_d2 && meets_person_test(f, united(candidates_[k], candidates_[m], use_floor))) {
        best_d2 = d2;
        best = m;
      }
    }
    if (best >= 0) merge_into(f, n, k, best, &s);
  }
  resolve_owners(n);
}

// A component that qualifies only as someone mostly hidden (too small otherwise, hidden edges, high
// enough) while its image box overlaps a user's (or a component's about to be one) and it is nearer
// than that user: it is not hidden by
// that user but in front of them, and what is in front of a body and overlapping it in the image is
// mostly that body's own arm or hand cut off by a depth jump. Someone
// hidden behind a user is farther than the user.
bool PersonTests::in_front_of_a_user(const DepthFrame& f, int32_t n, int32_t k, const float* cz, const bool* strict) const {
  const SegmenterConfig& cfg = *config_;
  const Candidate& c = candidates_[k];
  if (cfg.hidden_area_fraction <= 0.0f || c.hidden_edge < cfg.hidden_min_edge) return false;
  const float need = cfg.min_person_area_m2 * f.intrinsics.fx * f.intrinsics.fy / (cz[k] * cz[k]);
  if (float(c.pixels) >= need || meets_person_test(f, c, false)) return false;
  // Passing as cut by the bottom border (head and shoulders of someone close) is another matter.
  if (cfg.cut_bottom_area_fraction > 0.0f && c.v_max == f.height - 1 && floor_->valid != 0 &&
      c.top >= cfg.min_person_height_m && float(c.pixels) >= cfg.cut_bottom_area_fraction * need)
    return false;
  // So is qualifying as cut by the left or right border (someone walking out of view).
  if (cut_by_side(f, c, need)) return false;
  for (int32_t m = 0; m < n; ++m) {
    const Candidate& u = candidates_[m];
    if (m == k || (u.user == 0 && !strict[m]) || u.pixels == 0 || cz[m] <= cz[k]) continue;
    if (u.u_max < c.u_min || c.u_max < u.u_min || u.v_max < c.v_min || c.v_max < u.v_min) continue;
    return true;
  }
  return false;
}

// The user (candidate index) that a component about to become a new user belongs to, or −1: a
// larger user, nearer, whose image box (grown by 2 pixels) holds the component's and whose centroid
// is within absorb_radius_m along the floor, or, for a component without a person's area that
// reaches higher than the user, starts above its top row and shares its columns, within
// head_radius_m. The nearest such user. Work: one walk over the candidates.
int32_t PersonTests::absorbing_user(const DepthFrame& f, int32_t n, int32_t k, const float* cx, const float* cy,
                                  const float* cz) const {
  const SegmenterConfig& cfg = *config_;
  if (cfg.absorb_radius_m <= 0.0f && cfg.head_radius_m <= 0.0f) return -1;
  const Candidate& c = candidates_[k];
  const bool use_floor = floor_->valid != 0;
  // A piece without a person's area (it qualifies as hidden or cut) may be the top of a user's body
  // (head_radius_m).
  const bool small = float(c.pixels) < cfg.min_person_area_m2 * f.intrinsics.fx * f.intrinsics.fy / (cz[k] * cz[k]);
  // Such a piece cut by the top border (with cut_top_area_fraction it may qualify that way) beside a
  // larger user cut there too is mostly that user's other leg, a step nearer or farther.
  const bool leg_piece = cfg.cut_top_area_fraction > 0.0f && cfg.legs_radius_m > 0.0f && small && c.v_min == 0;
  int32_t best = -1;
  float r = cfg.absorb_radius_m > cfg.head_radius_m ? cfg.absorb_radius_m : cfg.head_radius_m;
  if (leg_piece && cfg.legs_radius_m > r) r = cfg.legs_radius_m;
  float best_d2 = r * r;
  for (int32_t m = 0; m < n; ++m) {
    const Candidate& u = candidates_[m];
    if (m == k || u.user == 0 || u.pixels <= c.pixels) continue;
    const bool nearer = cz[m] < cz[k];
    const bool inside = nearer && cfg.absorb_radius_m > 0.0f && c.u_min >= u.u_min - 2 && c.u_max <= u.u_max + 2 &&
                        c.v_min >= u.v_min - 2 && c.v_max <= u.v_max + 2;
    const bool head = nearer && cfg.head_radius_m > 0.0f && small && c.top > u.top && c.v_min < u.v_min &&
                      c.u_min <= u.u_max && u.u_min <= c.u_max;
    const bool leg = leg_piece && u.v_min == 0;
    if (!inside && !head && !leg) continue;
    float d[3] = {cx[k] - cx[m], cy[k] - cy[m], cz[k] - cz[m]};
    if (use_floor) {
      const float up = d[0] * floor_->nx + d[1] * floor_->ny + d[2] * floor_->nz;
      d[0] -= up * floor_->nx; d[1] -= up * floor_->ny; d[2] -= up * floor_->nz;
    } else {
      d[1] = 0.0f;
    }
    const float d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    float lim = inside && cfg.absorb_radius_m > (head ? cfg.head_radius_m : 0.0f) ? cfg.absorb_radius_m
                                                                                   : (head ? cfg.head_radius_m : 0.0f);
    if (leg && cfg.legs_radius_m > lim) lim = cfg.legs_radius_m;
    if (d2 <= lim * lim && d2 <= best_d2) { best_d2 = d2; best = m; }
  }
  return best;
}

// A person and a box as one component (box_split_height_m): the component's pixels binned
// on the floor in a kSplitCells² grid of box_split_cell_m centred on its centroid (pixels outside
// the grid stay). Cells whose highest point is lower than box_split_height_m are low (cells
// reaching the top image row never); the lid is the band of two kLidBins bins of cell tops holding
// the most low-cell pixels. The lid cells' pixels are dropped (marked −1 in parent_, so they are
// labelled background) when they stand on the floor, make at least box_split_min_share of the
// component, their centroid lies at least box_split_min_dist_m from the rest's along the floor and
// the rest meets the person test; the candidate's statistics become the rest's (the hidden-edge,
// occlusion and hull counts are kept). Returns 1 then; 2 when the lid is not dropped but holds at
// least box_reject_min_share of the component (no user); else 0. Work: at most four sweeps over
// the candidate's image box.
int32_t PersonTests::split_box(const DepthFrame& f, int32_t k, bool low_outline) {
  const SegmenterConfig& cfg = *config_;
  if (cfg.box_split_height_m <= 0.0f || floor_->valid == 0) return 0;
  Candidate& c = candidates_[k];
  // Not for components cut by the top border: the legs of someone seen from close show no top
  // and look like a lid in the cells below the border.
  if (c.pixels == 0 || (c.top < cfg.box_split_height_m && !low_outline) || c.v_min == 0) return 0;
  if (c.bottom > cfg.cut_floor_contact_m) return 0;  // nothing of it stands on the floor
  constexpr int32_t kSplitCells = FloorGrid::kCells;
  float cell_top[kSplitCells * kSplitCells];
  for (int32_t i = 0; i < kSplitCells * kSplitCells; ++i) cell_top[i] = -1e30f;
  FloorGrid grid;
  if (!grid.init_at(*floor_, f.intrinsics, c, cfg.box_split_cell_m))
    return 0;
  const float ax = grid.ax, ay = grid.ay, az = grid.az, bx = grid.bx, by = grid.by, bz = grid.bz;
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  // visit(u, v, pixel index, depth mm, cell or -1, height above the floor) for every pixel of the
  // component, in raster order within its image box.
  auto for_each_pixel = [&](auto&& visit) {
    for_each_pixel_of(f, k, [&](int32_t u, int32_t v, int32_t i, uint16_t z_mm) {
      float up;
      const int32_t cell = grid.cell_of(u, v, z_mm, &up);
      visit(u, v, i, z_mm, cell, up);
    });
  };
  for_each_pixel([&](int32_t, int32_t v, int32_t, uint16_t, int32_t cell, float up) {
    // A cell reaching the top image row has its top out of view (legs cut by the border reach
    // the same height in every cell, like a lid): never dropped.
    if (cell >= 0 && (up > cell_top[cell] || v == 0)) cell_top[cell] = v == 0 ? 1e30f : up;
  });
  // The lid: a box's or cylinder's cells all reach the same height (its top face, or the top edge
  // of its faces), a body's low cells (feet, a leg, a hand) do not. Pixel-weighted histogram of
  // the low cells' tops in kLidBins bins below box_split_height_m; the lid is the pair of
  // neighbouring bins with the most pixels, and only cells whose top lies in it are dropped.
  constexpr int32_t kLidBins = 32;
  int32_t lid_hist[kLidBins] = {};
  const float bin_scale = float(kLidBins) / cfg.box_split_height_m;
  for_each_pixel([&](int32_t, int32_t, int32_t, uint16_t, int32_t cell, float) {
    if (cell < 0 || cell_top[cell] >= cfg.box_split_height_m || cell_top[cell] < 0.0f) return;
    const int32_t bin = int32_t(cell_top[cell] * bin_scale);
    ++lid_hist[bin < kLidBins ? bin : kLidBins - 1];
  });
  int32_t lid_bin = 0;
  for (int32_t b = 1; b + 1 < kLidBins; ++b)
    if (lid_hist[b] + lid_hist[b + 1] > lid_hist[lid_bin] + lid_hist[lid_bin + 1]) lid_bin = b;
  const float lid_lo = float(lid_bin) / bin_scale, lid_hi = float(lid_bin + 2) / bin_scale;
  auto in_lid = [&](int32_t cell) {
    return cell >= 0 && cell_top[cell] >= lid_lo && cell_top[cell] < lid_hi && cell_top[cell] < cfg.box_split_height_m;
  };
  // The rest's statistics, and the dropped part's count and lowest point.
  Candidate rest = c;
  clear_stats(rest);
  int32_t dropped = 0;
  float dropped_bottom = 1e30f;
  for_each_pixel([&](int32_t u, int32_t v, int32_t, uint16_t z_mm, int32_t cell, float up) {
    if (in_lid(cell)) {
      ++dropped;
      if (up < dropped_bottom) dropped_bottom = up;
      return;
    }
    const float z = float(z_mm) * 0.001f;
    const float x = (float(u) - f.intrinsics.cx) * z * inv_fx;
    const float y = -(float(v) - f.intrinsics.cy) * z * inv_fy;
    add_point(rest, u, v, x, y, z, x * ax + y * ay + z * az);
    add_height(rest, up);
  });
  if (dropped == 0 || rest.pixels == 0 || dropped_bottom > cfg.cut_floor_contact_m) return 0;
  const bool rest_is_person = meets_person_test(f, rest);
  // Centroid distance along the floor between the dropped part and the rest.
  const float dx = float((c.sx - rest.sx) / dropped - rest.sx / rest.pixels);
  const float dy = float((c.sy - rest.sy) / dropped - rest.sy / rest.pixels);
  const float dz = float((c.sz - rest.sz) / dropped - rest.sz / rest.pixels);
  const float da = dx * ax + dy * ay + dz * az, db = dx * bx + dy * by + dz * bz;
  const bool apart = da * da + db * db >= cfg.box_split_min_dist_m * cfg.box_split_min_dist_m;
  // A low component that qualified only by its outline (low_max_solidity) holding a box's lid
  // apart from the rest: the outline is that of a box and something beside it, not a body's. A lid
  // under the rest is its own back (someone bent over), which the reject below would take for a
  // box's: not for these.
  const bool lid_apart = apart && float(dropped) >= cfg.box_split_min_share * float(c.pixels);
  if (low_outline && !(rest_is_person && lid_apart)) return lid_apart ? 2 : 0;
  if (!rest_is_person || !apart || float(dropped) < cfg.box_split_min_share * float(c.pixels)) {
    // Not a box beside a person: a lid holding box_reject_min_share of the component is a box with
    // a hand or arm over it.
    const bool lid = cfg.box_reject_min_share > 0.0f && float(dropped) >= cfg.box_reject_min_share * float(c.pixels);
    return lid ? 2 : 0;
  }
  for_each_pixel([&](int32_t, int32_t, int32_t i, uint16_t, int32_t cell, float) {
    if (in_lid(cell)) parent_[i] = -1;
  });
  c = rest;
  return 1;
}

// Someone low over the floor (low_max_lid_share): a component with the person area and
// width, standing on the floor, its top in view, at least low_min_height_m but less than
// min_person_height_m high, whose cells on the floor (box_split_cell_m, a kLowCells² grid centred on
// its centroid; pixels outside the grid count as outside the lid) reach many heights: at most
// low_max_lid_share of its pixels lie in cells whose tops fall within the height band (kLowBins
// bins below min_person_height_m, as wide as the depth noise at its mean depth) holding the most
// pixels. A box or cylinder reaches its top in every cell. Returns 1 then. Returns 2 (low_max_solidity) when at most low_outline_max_lid_share of its pixels lie there and its
// silhouette fills at most low_max_solidity of its row-wise hull (measure_hull over its merged
// pieces): no solid's outline. Returns 3 (cut_bottom_low_max_lid_share) for a
// component cut by the bottom border whose lowest point is above cut_floor_contact_m (its feet and
// the floor under them out of view) when at most cut_bottom_low_max_lid_share of its pixels lie in
// that band and at most cut_solidity_max_hidden of its image box is hidden by something nearer; such
// a component gets no other test. Else 0. Work: two sweeps over the candidate's image box (three
// more for the hull, one for the hidden pixels), 48 × 48 cells (9 KB) and 64 bins on the stack.
int32_t PersonTests::low_person(const DepthFrame& f, int32_t k) {
  const SegmenterConfig& cfg = *config_;
  const Candidate& c = candidates_[k];
  if ((cfg.low_max_lid_share <= 0.0f && cfg.low_max_solidity <= 0.0f && cfg.cut_bottom_low_max_lid_share <= 0.0f) ||
      floor_->valid == 0 || c.pixels == 0 || c.v_min == 0)
    return 0;
  // Cut by the bottom border above the floor (cut_bottom_low_max_lid_share): the feet and
  // the floor under them are below the image; only the lid share judges it, with its own cap.
  const bool feet_below = cfg.cut_bottom_low_max_lid_share > 0.0f && c.v_max == f.height - 1 &&
                          c.bottom > cfg.cut_floor_contact_m;
  if (c.top >= cfg.min_person_height_m || c.top < cfg.low_min_height_m || (c.bottom > cfg.cut_floor_contact_m && !feet_below))
    return 0;
  if (c.x_max - c.x_min > cfg.max_person_width_m) return 0;
  const float z = float(c.sz / c.pixels);
  if (float(c.pixels) < cfg.min_person_area_m2 * f.intrinsics.fx * f.intrinsics.fy / (z * z)) return 0;
  constexpr int32_t kLowCells = FloorGrid::kCells;
  constexpr int32_t kLowBins = 64;
  float cell_top[kLowCells * kLowCells];
  for (int32_t i = 0; i < kLowCells * kLowCells; ++i) cell_top[i] = -1e30f;
  FloorGrid grid;
  if (!grid.init_at(*floor_, f.intrinsics, c, cfg.box_split_cell_m))
    return 0;
  // sweep 0: each cell's top; sweep 1: pixel-weighted histogram of the cells' tops.
  int32_t hist[kLowBins] = {};
  const float bin_scale = float(kLowBins) / cfg.min_person_height_m;
  for (int32_t sweep = 0; sweep < 2; ++sweep)
    for_each_pixel_of(f, k, [&](int32_t u, int32_t v, int32_t, uint16_t z_mm) {
      float up;
      const int32_t cell = grid.cell_of(u, v, z_mm, &up);
      if (cell < 0) return;
      float& top = cell_top[cell];
      if (sweep == 0) {
        if (up > top) top = up;
      } else if (top >= 0.0f) {
        const int32_t bin = int32_t(top * bin_scale);
        ++hist[bin < kLowBins ? bin : kLowBins - 1];
      }
    });
  // The band widens with the depth noise, which spreads a box's cell tops: 2·(3 cm + 4 mm/m²·z²)
  // (13 cm at 3 m, 22 cm at 4.5 m; with a fixed 5.3 cm band boxes beyond 3 m fell to lid shares of
  // 0.2-0.4, like the people).
  constexpr float kBandM = 0.03f, kBandPerM2 = 0.004f;
  int32_t band = int32_t(2.0f * (kBandM + kBandPerM2 * z * z) * bin_scale + 0.5f);
  if (band < 1) band = 1;
  if (band > kLowBins) band = kLowBins;
  int32_t lid = 0, run = 0;
  for (int32_t b = 0; b < kLowBins; ++b) {
    run += hist[b] - (b >= band ? hist[b - band] : 0);
    if (run > lid) lid = run;
  }
  if (feet_below) {
    if (float(lid) > cfg.cut_bottom_low_max_lid_share * float(c.pixels)) return 0;
    // Not when something nearer hides part of its image box (more than cut_solidity_max_hidden of
    // its pixel count): what is hidden may be the rest of a lid (a box behind someone showed 0.62).
    // One sweep over the image box.
    int32_t occluded = 0;
    const int32_t front = int32_t(c.z_min * 1000.0f) - int32_t(cfg.join_mm);
    for (int32_t v = c.v_min; v <= c.v_max; ++v) {
      const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
      for (int32_t u = c.u_min; u <= c.u_max; ++u) occluded += row[u] != 0 && int32_t(row[u]) < front;
    }
    return float(occluded) <= cfg.cut_solidity_max_hidden * float(c.pixels) ? 3 : 0;
  }
  if (cfg.low_max_lid_share > 0.0f && float(lid) <= cfg.low_max_lid_share * float(c.pixels)) return 1;
  // A lid over most cells, but an outline no solid has (low_max_solidity): the image of a
  // box or cylinder is convex and fills its row-wise hull. Readings nearer than the component (less
  // join_mm) count as filled, since what they hide is unknown. Three sweeps over the image box.
  if (cfg.low_max_solidity <= 0.0f || float(lid) > cfg.low_outline_max_lid_share * float(c.pixels)) return 0;
  Candidate outline = c;
  measure_hull(f, &outline, k);
  const bool hollow = outline.hull > 0 && float(outline.hull_filled) <= cfg.low_max_solidity * float(outline.hull);
  return hollow ? 2 : 0;
}

// Two people joined by an arm (pair_bridge_max_m): the component's pixels profiled along the
// floor's horizontal axis (FloorGrid's a, the axis of its width) in at most kPairBins bins of at
// least kPairBinM, each with its highest and lowest point. The first run of bridge bins (not empty,
// thin and at least min_person_height_m up) with a standing bin (floor to min_person_height_m) on
// each side is cut in its middle when each side alone meets the person test (no border
// relaxations) and stands on the floor. The pixels beyond the cut (the higher bins) move to a new
// candidate (index n): its root is one of them that is no component's root, and every pixel of
// that side points to it (labels and the later tests read one hop, parent_ → aux_); candidate k
// keeps the rest, its statistics re-measured (its hidden-edge, occlusion and hull counts kept; the
// new one has none). Returns n, or −1 when k is kept whole. Work: three sweeps over the
// candidate's image box, 64 bins on the stack.
int32_t PersonTests::split_pair(const DepthFrame& f, int32_t n, int32_t k) {
  const SegmenterConfig& cfg = *config_;
  if (cfg.pair_bridge_max_m <= 0.0f || floor_->valid == 0 || n >= kMaxCandidates) return -1;
  Candidate& c = candidates_[k];
  // Also when cut by the top border (someone's head out of view): the height shown there is a lower
  // bound, so the standing bins and the person test of each side only get stricter.
  if (c.pixels == 0 || c.bottom > cfg.cut_floor_contact_m || c.top < cfg.min_person_height_m) return -1;
  FloorGrid grid;
  if (!grid.init_at(*floor_, f.intrinsics, c, cfg.box_split_cell_m))
    return -1;
  const float ax = grid.ax, ay = grid.ay, az = grid.az;
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  constexpr int32_t kPairBins = 64;
  constexpr float kPairBinM = 0.05f;
  // x_min/x_max run along the same axis (label_components, merges): the bins cover the extent.
  const float a_lo = c.x_min, extent = c.x_max - c.x_min;
  float bin_m = extent / float(kPairBins - 1);
  if (bin_m < kPairBinM) bin_m = kPairBinM;
  const int32_t bins = int32_t(extent / bin_m) + 1;
  if (bins < 3) return -1;
  // visit(u, v, pixel index, x, y, z, height above the floor, bin) for every pixel of the union.
  auto for_each_pixel = [&](auto&& visit) {
    for_each_pixel_of(f, k, [&](int32_t u, int32_t v, int32_t i, uint16_t z_mm) {
      const float z = float(z_mm) * 0.001f;
      const float x = (float(u) - f.intrinsics.cx) * z * inv_fx;
      const float y = -(float(v) - f.intrinsics.cy) * z * inv_fy;
      const float up = floor_->nx * x + floor_->ny * y + floor_->nz * z + floor_->d;
      int32_t b = int32_t((x * ax + y * ay + z * az - a_lo) / bin_m);
      b = b < 0 ? 0 : b >= bins ? bins - 1 : b;
      visit(u, v, i, x, y, z, up, b);
    });
  };
  float top[kPairBins], low[kPairBins];
  for (int32_t b = 0; b < bins; ++b) { top[b] = -1e30f; low[b] = 1e30f; }
  for_each_pixel([&](int32_t, int32_t, int32_t, float, float, float, float up, int32_t b) {
    if (up > top[b]) top[b] = up;
    if (up < low[b]) low[b] = up;
  });
  // A bridge bin: an arm held out, at least min_person_height_m up and thin. A single body's thin
  // slices (between the legs, a knee, a leg held out) are lower. Not an empty bin: the pieces of a
  // body that merge_fragments joined across someone in front leave empty bins between them.
  auto thin = [&](int32_t b) {
    return top[b] >= low[b] && low[b] >= cfg.min_person_height_m && top[b] - low[b] <= cfg.pair_bridge_max_m;
  };
  // A standing bin: from the floor to min_person_height_m in one slice (legs under a body).
  auto standing = [&](int32_t b) { return low[b] <= cfg.cut_floor_contact_m && top[b] >= cfg.min_person_height_m; };
  // Per bin: is there a standing bin before it (after it)?
  bool left_ok[kPairBins], right_ok[kPairBins];
  bool seen = false;
  for (int32_t b = 0; b < bins; ++b) {
    left_ok[b] = seen;
    seen = seen || standing(b);
  }
  seen = false;
  for (int32_t b = bins - 1; b >= 0; --b) {
    right_ok[b] = seen;
    seen = seen || standing(b);
  }
  int32_t cut = -1;  // first bin beyond the cut
  for (int32_t b = 1; b + 1 < bins && cut < 0;) {
    if (!thin(b)) { ++b; continue; }
    int32_t e = b;
    while (e + 1 < bins && thin(e + 1)) ++e;
    if (e + 1 < bins && left_ok[b] && right_ok[e]) cut = (b + e + 1) / 2;
    b = e + 1;
  }
  if (cut < 0) return -1;
  // Both sides alone.
  Candidate keep = c, moved = c;
  clear_stats(keep);
  clear_stats(moved);
  int32_t root = -1;
  for_each_pixel([&](int32_t u, int32_t v, int32_t i, float x, float y, float z, float up, int32_t b) {
    Candidate& side = b < cut ? keep : moved;
    add_point(side, u, v, x, y, z, x * ax + y * ay + z * az);
    add_height(side, up);
    if (b >= cut && root < 0 && parent_[i] != i) root = i;
  });
  if (root < 0 || keep.pixels == 0 || moved.pixels == 0) return -1;
  if (keep.bottom > cfg.cut_floor_contact_m || moved.bottom > cfg.cut_floor_contact_m) return -1;
  if (!meets_person_test(f, keep, false) || !meets_person_test(f, moved, false)) return -1;
  for_each_pixel([&](int32_t, int32_t, int32_t i, float, float, float, float, int32_t b) {
    if (b >= cut) parent_[i] = root;
  });
  parent_[root] = root;
  aux_[root] = n;
  moved.root = root;
  moved.occluded = moved.hidden_edge = moved.hidden_below = moved.hull = moved.hull_filled = moved.gap_rows = 0;
  moved.cut_pixels = 0;
  moved.cut_u_min = int16_t(32767);
  moved.cut_u_max = int16_t(-1);
  moved.user = 0;
  moved.owner = n;
  candidates_[n] = moved;
  c = keep;
  return n;
}

// Tall furniture: a door, a shelf, a cabinet or a chair is a vertical prism (a slab, a box, a
// seat on legs under a back panel), so its extent along the floor's horizontal axis (FloorGrid's
// a) is nearly the same from one height to the next: the front legs span the seat, the faces span
// the box, and only where one part ends and another begins (the seat under a narrower back) does
// it jump. A body's changes all the way up: feet, shins, knees, thighs, hips, waist, arms,
// shoulders, neck and head each differ from the next by more than the depth noise. A coat stand is
// a pole: most of its height is a few centimetres wide, where a body's narrowest parts (a leg, a
// body seen from the side) are 0.1 m and more.
// The component's pixels (its merged pieces) are profiled in kFurnitureBandM bands of height above
// the floor, each with its extent along a. From its lowest to its highest band with pixels (at
// least kFurnitureMinBands of them: someone lying or crouching is lower and never judged):
//   - furniture (1) when, among the pairs of neighbouring bands that both hold pixels (at least
//     kFurnitureMinBands − 1 of them), at least furniture_smooth_min_share differ in width by at
//     most furniture_smooth_step_m + furniture_smooth_step_per_m2 · z̄² (z̄ its mean depth: a
//     pixel's width and the depth noise move a band's ends more far away). A band emptied by
//     something in front says nothing about the shape: on the validation scenes counting the pairs
//     next to one as rough kept 43 of 966 pieces of tall furniture users and no person;
//   - a pole (2) when at least furniture_pole_min_share of the bands hold pixels and are at most
//     furniture_pole_max_width_m wide.
// Something in front hiding part of a piece of furniture empties or narrows the bands it hides, so
// such a piece may stay a user: the rule only drops what it is sure of. Tuned on tall-clutter
// scenes of seeds 101–106 and short-clutter ones of 101–103 (validation clips), docs/segmentation.md.
int32_t PersonTests::furniture(const DepthFrame& f, int32_t k) const {
  const SegmenterConfig& cfg = *config_;
  if ((cfg.furniture_smooth_min_share <= 0.0f && cfg.furniture_pole_max_width_m <= 0.0f) || floor_->valid == 0)
    return 0;
  const Candidate& c = candidates_[k];
  if (c.pixels == 0) return 0;
  // 0.1 m bands: a head (0.2–0.25 m tall) fills two of them, a thigh or a shin four. 32 bands reach
  // 3.2 m, above anyone; higher points count in the last one.
  constexpr float kFurnitureBandM = 0.1f;
  constexpr int32_t kFurnitureBands = 32;
  // 0.6 m of height: shorter components (someone lying, a box) are not profiled.
  constexpr int32_t kFurnitureMinBands = 6;
  FloorGrid grid;
  if (!grid.init_at(*floor_, f.intrinsics, c, kFurnitureBandM)) return 0;
  const float ax = grid.ax, ay = grid.ay, az = grid.az;
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  float lo[kFurnitureBands], hi[kFurnitureBands];
  for (int32_t b = 0; b < kFurnitureBands; ++b) { lo[b] = 1e30f; hi[b] = -1e30f; }
  for_each_pixel_of(f, k, [&](int32_t u, int32_t v, int32_t, uint16_t z_mm) {
    const float z = float(z_mm) * 0.001f;
    const float x = (float(u) - f.intrinsics.cx) * z * inv_fx;
    const float y = -(float(v) - f.intrinsics.cy) * z * inv_fy;
    const float up = floor_->nx * x + floor_->ny * y + floor_->nz * z + floor_->d;
    int32_t b = int32_t(up / kFurnitureBandM);
    b = b < 0 ? 0 : b >= kFurnitureBands ? kFurnitureBands - 1 : b;
    const float a = x * ax + y * ay + z * az;
    if (a < lo[b]) lo[b] = a;
    if (a > hi[b]) hi[b] = a;
  });
  int32_t first = -1, last = -1;
  for (int32_t b = 0; b < kFurnitureBands; ++b)
    if (hi[b] >= lo[b]) {
      if (first < 0) first = b;
      last = b;
    }
  const int32_t bands = last - first + 1;
  if (first < 0 || bands < kFurnitureMinBands) return 0;
  auto held = [&](int32_t b) { return hi[b] >= lo[b]; };
  if (cfg.furniture_smooth_min_share > 0.0f) {
    const float z = float(c.sz / c.pixels);
    const float step = cfg.furniture_smooth_step_m + cfg.furniture_smooth_step_per_m2 * z * z;
    int32_t smooth = 0, pairs = 0;
    for (int32_t b = first; b < last; ++b) {
      if (!held(b) || !held(b + 1)) continue;
      ++pairs;
      smooth += fabsf((hi[b + 1] - lo[b + 1]) - (hi[b] - lo[b])) <= step;
    }
    if (pairs >= kFurnitureMinBands - 1 && float(smooth) >= cfg.furniture_smooth_min_share * float(pairs)) return 1;
  }
  if (cfg.furniture_pole_max_width_m > 0.0f) {
    int32_t thin = 0;
    for (int32_t b = first; b <= last; ++b) thin += held(b) && hi[b] - lo[b] <= cfg.furniture_pole_max_width_m;
    if (float(thin) >= cfg.furniture_pole_min_share * float(bands)) return 2;
  }
  return 0;
}

}  // namespace dp::seg
