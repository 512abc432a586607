#include "runtime/segmentation/components.h"

namespace dp::seg {

namespace {

inline int32_t find_root(int32_t* parent, int32_t i) {
  while (parent[i] != i) {  // path halving; union by size keeps depth ≤ log2(W·H)
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

inline void unite(int32_t* parent, int32_t* size, int32_t a, int32_t b) {
  a = find_root(parent, a);
  b = find_root(parent, b);
  if (a == b) return;
  if (size[a] < size[b] || (size[a] == size[b] && b < a)) {
    const int32_t t = a; a = b; b = t;
  }
  parent[b] = a;
  size[a] += size[b];
}

}  // namespace

int32_t ComponentStage::label_components(const DepthFrame& f, SegmentationResult* r) {
  const SegmenterConfig& cfg = *config_;
  const int32_t w = f.width, h = f.height;
  const float join_per_mm = cfg.join_mm_per_m * 0.001f;
  auto join = [&](int32_t i, int32_t j, int32_t z, int32_t zn) {
    const int32_t zmax = z > zn ? z : zn;
    if (float(z > zn ? z - zn : zn - z) <= cfg.join_mm + join_per_mm * float(zmax)) unite(parent_, aux_, i, j);
  };
  for (int32_t v = 0; v < h; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const uint16_t* above = v > 0 ? row - f.stride_px : nullptr;
    for (int32_t u = 0; u < w; ++u) {
      const int32_t i = v * w + u;
      if (parent_[i] < 0) continue;
      const int32_t z = row[u];
      if (u > 0 && parent_[i - 1] >= 0) {
        const int32_t zn = row[u - 1];
        const int32_t zmax = z > zn ? z : zn;
        if (float(z > zn ? z - zn : zn - z) <= cfg.join_mm + join_per_mm * float(zmax)) unite(parent_, aux_, i, i - 1);
      }
      if (above && parent_[i - w] >= 0) {
        const int32_t zn = above[u];
        const int32_t zmax = z > zn ? z : zn;
        if (float(z > zn ? z - zn : zn - z) <= cfg.join_mm + join_per_mm * float(zmax)) unite(parent_, aux_, i, i - w);
      }
      // Sensor dropouts (no reading) cut thin limbs into pieces: bridge a one-pixel hole to the
      // left and above, and join the upper diagonals.
      if (u > 1 && row[u - 1] == 0 && parent_[i - 2] >= 0) join(i, i - 2, z, row[u - 2]);
      if (v > 1 && above[u] == 0 && parent_[i - 2 * w] >= 0) join(i, i - 2 * w, z, above[u - f.stride_px]);
      if (above && u > 0 && parent_[i - w - 1] >= 0) join(i, i - w - 1, z, above[u - 1]);
      if (above && u + 1 < w && parent_[i - w + 1] >= 0) join(i, i - w + 1, z, above[u + 1]);
    }
  }
  // Keep the kMaxCandidates largest components (replace-smallest keeps it independent of
  // raster order); every other root is marked −1.
  const int32_t total = w * h;
  int32_t kept = 0, components = 0;
  for (int32_t i = 0; i < total; ++i) {
    if (parent_[i] != i) continue;
    const int32_t size = aux_[i];
    aux_[i] = -1;
    if (size < cfg.min_component_pixels) continue;
    ++components;
    if (kept < kMaxCandidates) {
      candidates_[kept++].root = i;
      candidates_[kept - 1].pixels = size;
      continue;
    }
    r->flags |= kSegFlagCandidatesTruncated;
    int32_t smallest = 0;
    for (int32_t k = 1; k < kept; ++k)
      if (candidates_[k].pixels < candidates_[smallest].pixels) smallest = k;
    if (size > candidates_[smallest].pixels) {
      candidates_[smallest].root = i;
      candidates_[smallest].pixels = size;
    }
  }
  r->component_count = components;
  for (int32_t k = 0; k < kept; ++k) {
    Candidate& c = candidates_[k];
    aux_[c.root] = k;
    clear_stats(c);
    c.hidden_edge = 0;
    c.hidden_below = 0;
    c.user = 0;
    c.owner = k;
  }
  // Statistics. With a floor, x_min/x_max run along the floor's horizontal axis nearest camera x
  // and `top` is the height above the floor; without one, camera x and the y extent.
  const bool use_floor = floor_->valid != 0;
  float hx = 1.0f, hy = 0.0f, hz = 0.0f;
  if (use_floor) {
    const float dot = floor_->nx;
    hx = 1.0f - dot * floor_->nx; hy = -dot * floor_->ny; hz = -dot * floor_->nz;
    const float len = sqrtf(hx * hx + hy * hy + hz * hz);
    if (len > 1e-3f) { hx /= len; hy /= len; hz /= len; } else { hx = 1.0f; hy = hz = 0.0f; }
  }
  const float inv_fx = 1.0f / f.intrinsics.fx, inv_fy = 1.0f / f.intrinsics.fy;
  const bool count_hidden = cfg.hidden_area_fraction > 0.0f;
  const int32_t gap = int32_t(cfg.hidden_gap_mm);
  for (int32_t v = 0; v < h; ++v) {
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    for (int32_t u = 0; u < w; ++u) {
      const int32_t i = v * w + u;
      if (parent_[i] < 0) continue;
      const int32_t root = find_root(parent_, i);
      parent_[i] = root;
      const int32_t k = aux_[root];
      if (k < 0) continue;
      Candidate& c = candidates_[k];
      if (count_hidden) {
        // Per direction (left, right, up, down) the first reading within kHiddenReach pixels
        // (an occluding edge casts a shadow without readings): nearer by more than the gap?
        constexpr int32_t kHiddenReach = 4;
        const int32_t zi = int32_t(row[u]) - gap;
        const int32_t du[4] = {-1, 1, 0, 0}, dv[4] = {0, 0, -1, 1};
        for (int32_t dir = 0; dir < 4; ++dir) {
          int32_t uu = u, vv = v;
          for (int32_t step = 0; step < kHiddenReach; ++step) {
            uu += du[dir];
            vv += dv[dir];
            if (uu < 0 || uu >= w || vv < 0 || vv >= h) break;
            const uint16_t zn = f.depth_mm[size_t(vv) * f.stride_px + uu];
            if (zn == 0) continue;
            c.hidden_edge += int32_t(zn) < zi;
            if (dir == 3) c.hidden_below += int32_t(zn) < zi;
            break;
          }
        }
      }
      const float z = float(row[u]) * 0.001f;
      const float x = (float(u) - f.intrinsics.cx) * z * inv_fx;
      const float y = -(float(v) - f.intrinsics.cy) * z * inv_fy;
      add_point(c, u, v, x, y, z, x * hx + y * hy + z * hz);
      if (use_floor) add_height(c, floor_->nx * x + floor_->ny * y + floor_->nz * z + floor_->d);
    }
  }
  if (!use_floor)
    for (int32_t k = 0; k < kept; ++k) candidates_[k].top = candidates_[k].y_max - candidates_[k].y_min;
  // Components cut by the top border (the only ones whose fill matters, meets_person_test):
  // pixels of the image box hidden by something in front count as filled, since what is behind
  // them is unknown. At most kMaxCandidates boxes, each within the frame.
  for (int32_t k = 0; k < kept; ++k) {
    Candidate& c = candidates_[k];
    c.occluded = c.hull = c.hull_filled = c.gap_rows = 0;
    c.cut_pixels = c.v_min == 0 ? c.pixels : 0;
    c.cut_u_min = c.v_min == 0 ? c.u_min : int16_t(32767);
    c.cut_u_max = c.v_min == 0 ? c.u_max : int16_t(-1);
    if (!use_floor || cfg.cut_max_fill <= 0.0f || c.v_min > 0 || c.pixels == 0) continue;
    const int32_t front = int32_t(c.z_min * 1000.0f) - int32_t(cfg.join_mm);
    for (int32_t v = c.v_min; v <= c.v_max; ++v) {
      const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
      for (int32_t u = c.u_min; u <= c.u_max; ++u)
        c.occluded += row[u] != 0 && int32_t(row[u]) < front;
    }
    measure_hull(f, &c);
  }
  return kept;
}

// The component's row-wise convex hull: per image row, the span between the convex chain of its
// leftmost pixels and the concave chain of its rightmost ones (Andrew's monotone chain with the
// row as abscissa). hull = pixels in those spans; hull_filled = the component's own pixels plus
// the readings in the spans nearer than its nearest point less join_mm (hidden by something in
// front: unknown, counted as filled). A solid box or cylinder fills its hull whatever the camera's
// roll; two legs leave the gap between them. Work: 3 sweeps over the candidate's image box.
void ComponentStage::measure_hull(const DepthFrame& f, Candidate* cand, int32_t owner) {
  Candidate& c = *cand;
  const int32_t w = f.width;
  const int32_t rows = c.v_max - c.v_min + 1;
  int16_t* left = hull_rows_;             // leftmost u per row (−1: none)
  int16_t* right = hull_rows_ + rows;     // rightmost u per row
  int16_t* lchain = hull_rows_ + 2 * rows;// row offsets of the left chain's vertices
  int16_t* rchain = hull_rows_ + 3 * rows;
  // Rows with a gap between two runs of the component's pixels, at least 2 pixels wide, seen
  // through (no reading nearer than the component's nearest point less join_mm: nothing in front
  // hides it; pixels without a reading allowed, at least one with a reading): the space between
  // two legs (cut_gap_min_share). Counted for every top-border component, rule on or off.
  const int32_t front = int32_t(c.z_min * 1000.0f) - int32_t(config_->join_mm);
  c.gap_rows = 0;
  for (int32_t v = c.v_min; v <= c.v_max; ++v) {
    const int32_t* parent = parent_ + size_t(v) * w;
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    int16_t lo = -1, hi = -1;
    int32_t gap = 0, seen = 0;  // since the last own pixel: gap pixels, of them with a reading
    bool through = true, two_runs = false;
    for (int32_t u = c.u_min; u <= c.u_max; ++u) {
      const int32_t p = parent[u];
      if (!owned(p, cand, owner)) {
        ++gap;
        seen += row[u] != 0;
        through = through && (row[u] == 0 || int32_t(row[u]) >= front);
        continue;
      }
      if (lo >= 0 && gap >= 2 && seen > 0 && through) two_runs = true;
      gap = seen = 0;
      through = true;
      if (lo < 0) lo = int16_t(u);
      hi = int16_t(u);
    }
    c.gap_rows += two_runs;
    left[v - c.v_min] = lo;
    right[v - c.v_min] = hi;
  }
    // Chains: left = lower convex hull of (row, left), right = upper hull of (row, right).
  int32_t nl = 0, nr = 0;
  for (int32_t r = 0; r < rows; ++r) {
    if (left[r] < 0) continue;
    while (nl >= 2) {
      const int32_t a = lchain[nl - 2], b = lchain[nl - 1];
      // cross((b − a), (r − a)) in (row, u): pop b when it is not strictly left of a→r's chain.
      const int32_t cross = (b - a) * (left[r] - left[a]) - (left[b] - left[a]) * (r - a);
      if (cross <= 0) --nl; else break;
    }
    lchain[nl++] = int16_t(r);
    while (nr >= 2) {
      const int32_t a = rchain[nr - 2], b = rchain[nr - 1];
      const int32_t cross = (b - a) * (right[r] - right[a]) - (right[b] - right[a]) * (r - a);
      if (cross >= 0) --nr; else break;
    }
    rchain[nr++] = int16_t(r);
  }
  c.hull = c.hull_filled = 0;
  if (nl == 0) return;
  int32_t li = 0, ri = 0;
  for (int32_t r = lchain[0]; r <= lchain[nl - 1]; ++r) {
    while (li + 1 < nl && lchain[li + 1] < r) ++li;
    while (ri + 1 < nr && rchain[ri + 1] < r) ++ri;
    float lu = left[lchain[li]], ru = right[rchain[ri]];
    if (li + 1 < nl && lchain[li + 1] > lchain[li]) {
      const float t = float(r - lchain[li]) / float(lchain[li + 1] - lchain[li]);
      lu = float(left[lchain[li]]) + t * float(left[lchain[li + 1]] - left[lchain[li]]);
    }
    if (ri + 1 < nr && rchain[ri + 1] > rchain[ri]) {
      const float t = float(r - rchain[ri]) / float(rchain[ri + 1] - rchain[ri]);
      ru = float(right[rchain[ri]]) + t * float(right[rchain[ri + 1]] - right[rchain[ri]]);
    }
    const int32_t u0 = int32_t(ceilf(lu - 1e-3f)), u1 = int32_t(floorf(ru + 1e-3f));
    const int32_t v = c.v_min + r;
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    const int32_t* parent = parent_ + size_t(v) * w;
    for (int32_t u = u0; u <= u1; ++u) {
      ++c.hull;
      const int32_t p = parent[u];
      const bool own = owned(p, cand, owner);
      c.hull_filled += own || (row[u] != 0 && int32_t(row[u]) < front);
    }
  }
}

}  // namespace dp::seg
