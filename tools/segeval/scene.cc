#include "tools/segeval/scene.h"

#include <cmath>

#include "tools/demo/fixtures.h"

namespace dp::tools {

namespace {

struct Axes {
  double right[3], up[3], forward[3];  // camera axes in world coordinates
};

Axes camera_axes(const SceneCamera& c) {
  const double p = c.pitch_deg * M_PI / 180.0, r = c.roll_deg * M_PI / 180.0;
  const double f[3] = {0.0, -std::sin(p), std::cos(p)};
  const double u0[3] = {0.0, std::cos(p), std::sin(p)};
  const double r0[3] = {1.0, 0.0, 0.0};
  Axes a;
  for (int k = 0; k < 3; ++k) {
    a.forward[k] = f[k];
    a.right[k] = r0[k] * std::cos(r) - u0[k] * std::sin(r);
    a.up[k] = u0[k] * std::cos(r) + r0[k] * std::sin(r);
  }
  return a;
}

CameraIntrinsics resolved(const SceneCamera& c) {
  return c.intrinsics.fx > 0 ? c.intrinsics : kinect_intrinsics(c.width, c.height);
}

}  // namespace

void floor_plane_in_camera(const SceneCamera& c, float n[3], float* d) {
  const Axes a = camera_axes(c);
  n[0] = float(a.right[1]);
  n[1] = float(a.up[1]);
  n[2] = float(a.forward[1]);
  *d = c.height_m;
}

void world_to_camera(const SceneCamera& c, const float w[3], float out[3]) {
  const Axes a = camera_axes(c);
  const double rel[3] = {w[0], w[1] - c.height_m, w[2]};
  out[0] = float(rel[0] * a.right[0] + rel[1] * a.right[1] + rel[2] * a.right[2]);
  out[1] = float(rel[0] * a.up[0] + rel[1] * a.up[1] + rel[2] * a.up[2]);
  out[2] = float(rel[0] * a.forward[0] + rel[1] * a.forward[1] + rel[2] * a.forward[2]);
}

RenderedScene render_scene(const Scene& s) {
  RenderedScene out;
  out.width = s.camera.width;
  out.height = s.camera.height;
  out.intrinsics = resolved(s.camera);
  out.depth_mm.assign(size_t(out.width) * out.height, 0);
  out.truth.assign(size_t(out.width) * out.height, 0);
  const Axes a = camera_axes(s.camera);
  const double o[3] = {0.0, s.camera.height_m, 0.0};
  for (int v = 0; v < out.height; ++v) {
    for (int u = 0; u < out.width; ++u) {
      const double dx = (u - out.intrinsics.cx) / out.intrinsics.fx, dy = -(v - out.intrinsics.cy) / out.intrinsics.fy;
      double d[3];
      for (int k = 0; k < 3; ++k) d[k] = a.right[k] * dx + a.up[k] * dy + a.forward[k];
      // Camera z of the point o + t·d is t (the forward component of d is 1).
      double best = 1e30;
      uint8_t truth = 0;
      auto consider = [&](double t, uint8_t id) {
        if (t > 1e-3 && t < best) { best = t; truth = id; }
      };
      if (s.floor && d[1] < 0) consider(-o[1] / d[1], 0);
      if (s.wall_z > 0 && d[2] > 0) consider(s.wall_z / d[2], 0);
      for (const SceneBox& b : s.boxes) {
        double t0 = -1e30, t1 = 1e30;
        const double lo[3] = {b.x0, b.y0, b.z0}, hi[3] = {b.x1, b.y1, b.z1};
        bool miss = false;
        for (int k = 0; k < 3 && !miss; ++k) {
          if (std::fabs(d[k]) < 1e-12) {
            miss = o[k] < lo[k] || o[k] > hi[k];
            continue;
          }
          double ta = (lo[k] - o[k]) / d[k], tb = (hi[k] - o[k]) / d[k];
          if (ta > tb) std::swap(ta, tb);
          t0 = std::max(t0, ta);
          t1 = std::min(t1, tb);
        }
        if (!miss && t0 <= t1) consider(t0, b.truth);
      }
      for (const SceneCylinder& c : s.cylinders) {
        const double px = o[0] - c.x, pz = o[2] - c.z;
        const double qa = d[0] * d[0] + d[2] * d[2], qb = 2 * (px * d[0] + pz * d[2]),
                     qc = px * px + pz * pz - c.radius * c.radius;
        const double disc = qb * qb - 4 * qa * qc;
        if (qa > 1e-12 && disc >= 0) {
          const double t = (-qb - std::sqrt(disc)) / (2 * qa);
          const double y = o[1] + t * d[1];
          if (y >= c.y0 && y <= c.y1) consider(t, c.truth);
        }
        if (std::fabs(d[1]) > 1e-12) {  // top cap
          const double t = (c.y1 - o[1]) / d[1];
          const double x = o[0] + t * d[0] - c.x, z = o[2] + t * d[2] - c.z;
          if (x * x + z * z <= c.radius * c.radius) consider(t, c.truth);
        }
      }
      if (best < 65.0) {
        const size_t i = size_t(v) * out.width + u;
        out.depth_mm[i] = uint16_t(std::lround(best * 1000.0));
        out.truth[i] = truth;
      }
    }
  }
  return out;
}

}  // namespace dp::tools
