// A z-buffer triangle rasterizer for depth and part-label images.
//
// Camera frame: x right, y up, z forward (metres); pinhole projection u = cx + fx*x/z,
// v = cy - fy*y/z, pixel (u, v) has its centre at integer coordinates. A pixel is covered when its
// centre lies inside the projected triangle (top-left fill rule, so shared edges are drawn once).
// Depth is the camera z of the surface at the pixel centre, exact for planar triangles (1/z is
// interpolated linearly in screen space). The label of a covered pixel is the label of the
// triangle corner nearest in barycentric terms (so part borders run through triangles).
// Triangles with any corner nearer than kNearPlane are skipped (no clipping); both windings are
// drawn.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "tools/synth/geometry.h"

namespace dp::synth {

constexpr float kNearPlane = 0.05f;  // metres
constexpr uint8_t kNoLabel = 255;

struct Intrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  // Kinect-v1-like: fx = fy = 525 at 640x480, scaled with the width; centre at the image middle.
  static Intrinsics kinect_like(int width, int height);
};

struct DepthLabelImage {
  int width = 0, height = 0;
  std::vector<float> depth;     // metres; 0 = nothing rendered
  std::vector<uint8_t> label;   // kNoLabel where nothing with a label was drawn
  void reset(int w, int h);
};

// Draws triangles (corner indices into `points`, camera frame) into `target` with z-test.
// `vertex_labels` has one label per point.
void rasterize(const Intrinsics& k, const std::vector<Vec3f>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
               const std::vector<uint8_t>& vertex_labels, DepthLabelImage& target);

// Fills pixels whose depth is still 0 (or farther) with the plane n.X = d (camera frame), where
// the viewing ray hits it in front of the camera within max_depth; label stays kNoLabel.
void rasterize_plane(const Intrinsics& k, const Vec3& normal, double d, double max_depth, DepthLabelImage& target);

}  // namespace dp::synth
