// The synth rasterizer on tiny fixture meshes whose depth is known exactly.
#include <gtest/gtest.h>

#include <cmath>

#include "tools/synth/rasterizer.h"

namespace dp::synth {
namespace {

Intrinsics small_camera() {
  Intrinsics k;
  k.width = 64;
  k.height = 48;
  k.fx = k.fy = 50.0;
  k.cx = 31.5;
  k.cy = 23.5;
  return k;
}

// A camera-facing quad covering pixel columns [u0, u1) and rows [v0, v1) at depth z: its edges
// lie half a pixel outside the pixel centres.
void add_quad(const Intrinsics& k, double u0, double u1, double v0, double v1, float z, uint8_t label,
              std::vector<Vec3f>& pts, std::vector<std::array<uint32_t, 3>>& tris, std::vector<uint8_t>& labels) {
  auto at = [&](double u, double v) {
    return Vec3f{float((u - k.cx) * z / k.fx), float(-(v - k.cy) * z / k.fy), z};
  };
  const uint32_t b = uint32_t(pts.size());
  pts.push_back(at(u0 - 0.5, v0 - 0.5));
  pts.push_back(at(u1 - 0.5, v0 - 0.5));
  pts.push_back(at(u1 - 0.5, v1 - 0.5));
  pts.push_back(at(u0 - 0.5, v1 - 0.5));
  for (int i = 0; i < 4; ++i) labels.push_back(label);
  tris.push_back({b, b + 1, b + 2});
  tris.push_back({b, b + 2, b + 3});
}

TEST(SynthRasterizer, FrontoParallelQuadHasExactDepthAndCoverage) {
  const Intrinsics k = small_camera();
  std::vector<Vec3f> pts;
  std::vector<std::array<uint32_t, 3>> tris;
  std::vector<uint8_t> labels;
  add_quad(k, 10, 30, 5, 20, 2.0f, 7, pts, tris, labels);
  DepthLabelImage img;
  img.reset(k.width, k.height);
  rasterize(k, pts, tris, labels, img);
  int covered = 0;
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      const size_t i = size_t(v) * k.width + u;
      const bool inside = u >= 10 && u < 30 && v >= 5 && v < 20;
      if (inside) {
        ++covered;
        EXPECT_NEAR(img.depth[i], 2.0f, 1e-6f) << u << "," << v;
        EXPECT_EQ(img.label[i], 7);
      } else {
        EXPECT_EQ(img.depth[i], 0.0f) << u << "," << v;
        EXPECT_EQ(img.label[i], kNoLabel);
      }
    }
  EXPECT_EQ(covered, 20 * 15);
}

TEST(SynthRasterizer, SharedEdgesThroughPixelCentresAreDrawnOnce) {
  // Two triangles whose shared diagonal and outer edges pass exactly through pixel centres.
  const Intrinsics k = small_camera();
  const float z = 1.0f;
  auto at = [&](double u, double v) { return Vec3f{float((u - k.cx) * z / k.fx), float(-(v - k.cy) * z / k.fy), z}; };
  std::vector<Vec3f> pts = {at(4, 4), at(12, 4), at(12, 12), at(4, 12)};
  std::vector<uint8_t> labels = {1, 1, 2, 2};
  std::vector<std::array<uint32_t, 3>> tris = {{0, 1, 2}, {0, 2, 3}};
  // Count each pixel's coverage by rendering the triangles separately.
  std::vector<int> count(size_t(k.width) * k.height, 0);
  for (const auto& t : tris) {
    DepthLabelImage img;
    img.reset(k.width, k.height);
    rasterize(k, pts, {t}, labels, img);
    for (size_t i = 0; i < count.size(); ++i) count[i] += img.depth[i] != 0;
  }
  int total = 0;
  for (int c : count) {
    EXPECT_LE(c, 1);
    total += c;
  }
  EXPECT_EQ(total, 8 * 8);  // an 8x8 square of pixel centres: one closed and one open side per axis
}

TEST(SynthRasterizer, TiltedPlaneDepthIsPerspectiveCorrect) {
  // Plane z = 2 + 0.5 x (metres): a quad spanning x in [-0.6, 0.6], y in [-0.4, 0.4].
  const Intrinsics k = small_camera();
  auto on_plane = [](float x, float y) { return Vec3f{x, y, 2.0f + 0.5f * x}; };
  std::vector<Vec3f> pts = {on_plane(-0.6f, -0.4f), on_plane(0.6f, -0.4f), on_plane(0.6f, 0.4f), on_plane(-0.6f, 0.4f)};
  std::vector<uint8_t> labels = {3, 3, 3, 3};
  DepthLabelImage img;
  img.reset(k.width, k.height);
  rasterize(k, pts, {{0, 1, 2}, {0, 2, 3}}, labels, img);
  int checked = 0;
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      const float d = img.depth[size_t(v) * k.width + u];
      if (d == 0) continue;
      // Ray (a, b, 1) * z meets z = 2 + 0.5 a z  =>  z = 2 / (1 - 0.5 a).
      const double a = (u - k.cx) / k.fx;
      EXPECT_NEAR(d, 2.0 / (1.0 - 0.5 * a), 1e-5) << u << "," << v;
      ++checked;
    }
  EXPECT_GT(checked, 300);
}

TEST(SynthRasterizer, NearerSurfaceWinsRegardlessOfOrderAndWinding) {
  const Intrinsics k = small_camera();
  for (int order = 0; order < 2; ++order) {
    std::vector<Vec3f> pts;
    std::vector<std::array<uint32_t, 3>> tris;
    std::vector<uint8_t> labels;
    if (order == 0) {
      add_quad(k, 0, 40, 0, 30, 3.0f, 1, pts, tris, labels);
      add_quad(k, 20, 50, 10, 40, 1.5f, 2, pts, tris, labels);
    } else {
      add_quad(k, 20, 50, 10, 40, 1.5f, 2, pts, tris, labels);
      add_quad(k, 0, 40, 0, 30, 3.0f, 1, pts, tris, labels);
      for (auto& t : tris) std::swap(t[1], t[2]);  // opposite winding
    }
    DepthLabelImage img;
    img.reset(k.width, k.height);
    rasterize(k, pts, tris, labels, img);
    const size_t overlap = size_t(15) * k.width + 25, far_only = size_t(5) * k.width + 5;
    EXPECT_FLOAT_EQ(img.depth[overlap], 1.5f);
    EXPECT_EQ(img.label[overlap], 2);
    EXPECT_FLOAT_EQ(img.depth[far_only], 3.0f);
    EXPECT_EQ(img.label[far_only], 1);
  }
}

TEST(SynthRasterizer, PlaneFillsBackgroundOnly) {
  const Intrinsics k = small_camera();
  DepthLabelImage img;
  img.reset(k.width, k.height);
  img.depth[0] = 0.5f;
  // Floor 1 m below a level camera: y = -1  <=>  (0,1,0).X = -1.
  rasterize_plane(k, {0, 1, 0}, -1.0, 10.0, img);
  EXPECT_FLOAT_EQ(img.depth[0], 0.5f);        // nearer body pixel kept
  EXPECT_EQ(img.depth[size_t(10) * k.width + 3], 0.0f);  // above the horizon: no floor
  const int v = 40;
  EXPECT_NEAR(img.depth[size_t(v) * k.width + 3], 1.0 * k.fy / (v - k.cy), 1e-4);
  EXPECT_EQ(img.label[size_t(v) * k.width + 3], kNoLabel);
}

}  // namespace
}  // namespace dp::synth
