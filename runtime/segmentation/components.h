// Components stage of dp::Segmenter (runtime/segmentation/segmenter.h): the candidate pixels
// joined into 3D-connected components, the kMaxCandidates largest measured (Candidate).
//
// Contract:
//   - ComponentStage holds views into the Segmenter's arena, set by Segmenter::carve; it owns
//     nothing. parent_: one int32 per pixel (row-major with the frame's width; −1 = not a
//     candidate pixel; after label_components every candidate pixel holds its component's root).
//     aux_: per root, the candidate index or −1. candidates_: kMaxCandidates. hull_rows_: 4 ·
//     max_height int16 (measure_hull's scratch).
//   - Units: Candidate sums sx, sy, sz over `pixels` in camera metres; x_min/x_max along the
//     floor's horizontal axis (camera x without a floor); top/bottom in metres above the floor
//     (top is the y extent without a floor); image boxes in pixels, inclusive.
//   - Bounded: the union-find is O(W·H·log(W·H)); measure_hull and for_each_pixel_of sweep one
//     candidate's image box.
#pragma once
#include <math.h>
#include <stdint.h>

#include "runtime/segmentation/segmentation_result.h"

namespace dp::seg {

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

// Running statistics of a component (Candidate): pixel count, centroid sums,
// extents, height range above the floor and image box. One place for the rules, so building a
// component, re-measuring a cut one and merging two agree.
template <class Stats>
inline void clear_stats(Stats& c) {
  c.pixels = 0;
  c.sx = c.sy = c.sz = 0.0;
  c.x_min = c.y_min = c.z_min = 1e30f;
  c.x_max = c.y_max = c.z_max = c.top = -1e30f;
  c.bottom = 1e30f;
  c.u_min = c.v_min = 32767;
  c.u_max = c.v_max = -1;
}

// (x, y, z): camera metres; horizontal: the point along the extent axis; up: height above the
// floor (only when a floor is known).
template <class Stats>
inline void add_point(Stats& c, int32_t u, int32_t v, float x, float y, float z, float horizontal) {
  ++c.pixels;
  c.sx += x; c.sy += y; c.sz += z;
  if (horizontal < c.x_min) c.x_min = horizontal;
  if (horizontal > c.x_max) c.x_max = horizontal;
  if (y < c.y_min) c.y_min = y;
  if (y > c.y_max) c.y_max = y;
  if (z < c.z_min) c.z_min = z;
  if (z > c.z_max) c.z_max = z;
  if (u < c.u_min) c.u_min = int16_t(u);
  if (u > c.u_max) c.u_max = int16_t(u);
  if (v < c.v_min) c.v_min = int16_t(v);
  if (v > c.v_max) c.v_max = int16_t(v);
}

template <class Stats>
inline void add_height(Stats& c, float up) {
  if (up > c.top) c.top = up;
  if (up < c.bottom) c.bottom = up;
}

// Without a floor, `top` is the y extent.
template <class Stats>
inline void add_stats(Stats& dst, const Stats& src, bool use_floor) {
  dst.pixels += src.pixels;
  dst.sx += src.sx; dst.sy += src.sy; dst.sz += src.sz;
  if (src.x_min < dst.x_min) dst.x_min = src.x_min;
  if (src.x_max > dst.x_max) dst.x_max = src.x_max;
  if (src.y_min < dst.y_min) dst.y_min = src.y_min;
  if (src.y_max > dst.y_max) dst.y_max = src.y_max;
  if (src.z_min < dst.z_min) dst.z_min = src.z_min;
  if (src.z_max > dst.z_max) dst.z_max = src.z_max;
  dst.top = use_floor ? (src.top > dst.top ? src.top : dst.top) : dst.y_max - dst.y_min;
  if (src.bottom < dst.bottom) dst.bottom = src.bottom;
  if (src.u_min < dst.u_min) dst.u_min = src.u_min;
  if (src.u_max > dst.u_max) dst.u_max = src.u_max;
  if (src.v_min < dst.v_min) dst.v_min = src.v_min;
  if (src.v_max > dst.v_max) dst.v_max = src.v_max;
}

// A component's pixels on the floor (split_box, low_person): a kCells × kCells grid of square
// cells of side cell_m centred on the component's mean point, along the floor's in-plane axes
// a (camera x without its part along the normal) and b = n × a, and each pixel's height above it.
struct FloorGrid {
  static constexpr int32_t kCells = 48;
  float ax, ay, az, bx, by, bz;
  // False when the floor normal is (nearly) camera x: no axis a.
  bool init(const FloorPlane& floor, const CameraIntrinsics& in, float mx, float my, float mz, float cell_m) {
    nx = floor.nx; ny = floor.ny; nz = floor.nz; d = floor.d;
    ax = 1.0f - nx * nx; ay = -nx * ny; az = -nx * nz;
    const float len = sqrtf(ax * ax + ay * ay + az * az);
    if (len < 1e-3f) return false;
    ax /= len; ay /= len; az /= len;
    bx = ny * az - nz * ay; by = nz * ax - nx * az; bz = nx * ay - ny * ax;
    inv_cell = 1.0f / cell_m;
    a0 = mx * ax + my * ay + mz * az;
    b0 = mx * bx + my * by + mz * bz;
    cx = in.cx; cy = in.cy;
    inv_fx = 1.0f / in.fx; inv_fy = 1.0f / in.fy;
    return true;
  }
  // init() centred on a candidate component's mean point (sums sx, sy, sz over `pixels`, > 0).
  template <class Component>
  bool init_at(const FloorPlane& floor, const CameraIntrinsics& in, const Component& c, float cell_m) {
    return init(floor, in, float(c.sx / c.pixels), float(c.sy / c.pixels), float(c.sz / c.pixels), cell_m);
  }
  // The cell of pixel (u, v) at depth_mm, or −1 off the grid; *up = its height above the floor.
  int32_t cell_of(int32_t u, int32_t v, uint16_t depth_mm, float* up) const {
    const float z = float(depth_mm) * 0.001f;
    const float x = (float(u) - cx) * z * inv_fx;
    const float y = -(float(v) - cy) * z * inv_fy;
    *up = nx * x + ny * y + nz * z + d;
    const int32_t ia = int32_t(floorf((x * ax + y * ay + z * az - a0) * inv_cell)) + kCells / 2;
    const int32_t ib = int32_t(floorf((x * bx + y * by + z * bz - b0) * inv_cell)) + kCells / 2;
    if (ia < 0 || ia >= kCells || ib < 0 || ib >= kCells) return -1;
    return ia * kCells + ib;
  }

 private:
  float nx, ny, nz, d, inv_cell, a0, b0, cx, cy, inv_fx, inv_fy;
};


struct ComponentStage {
  const SegmenterConfig* config_ = nullptr;
  const FloorPlane* floor_ = nullptr;
  int32_t* parent_ = nullptr;        // union-find over pixels (−1 = not a candidate pixel)
  int32_t* aux_ = nullptr;           // root: component size, then candidate index or −1
  Candidate* candidates_ = nullptr;  // [kMaxCandidates]
  int16_t* hull_rows_ = nullptr;     // [4 · max_height]: row extents and hull chains of one component

  // Joins the candidate pixels (classify_pixels) into components and measures the
  // kMaxCandidates largest; sets result->component_count and kSegFlagCandidatesTruncated.
  // Returns the number of candidates.
  int32_t label_components(const DepthFrame& frame, SegmentationResult* result);
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
};

template <class Visit>
void ComponentStage::for_each_pixel_of(const DepthFrame& f, int32_t owner, Visit&& visit) const {
  const Candidate& c = candidates_[owner];
  for (int32_t v = c.v_min; v <= c.v_max; ++v) {
    const int32_t* parent = parent_ + size_t(v) * f.width;
    const uint16_t* row = f.depth_mm + size_t(v) * f.stride_px;
    for (int32_t u = c.u_min; u <= c.u_max; ++u)
      if (owned(parent[u], nullptr, owner)) visit(u, v, v * f.width + u, row[u]);
  }
}

}  // namespace dp::seg
