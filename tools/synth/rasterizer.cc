#include "tools/synth/rasterizer.h"

#include <algorithm>
#include <cmath>

namespace dp::synth {

Intrinsics Intrinsics::kinect_like(int width, int height) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  k.fx = k.fy = 525.0 * width / 640.0;
  k.cx = (width - 1) * 0.5;
  k.cy = (height - 1) * 0.5;
  return k;
}

void DepthLabelImage::reset(int w, int h) {
  width = w;
  height = h;
  depth.assign(size_t(w) * h, 0.0f);
  label.assign(size_t(w) * h, kNoLabel);
}

namespace {
struct Projected {
  float u, v, inv_z;
  bool valid;
};
}  // namespace

void rasterize(const Intrinsics& k, const std::vector<Vec3f>& points, const std::vector<std::array<uint32_t, 3>>& triangles,
               const std::vector<uint8_t>& vertex_labels, DepthLabelImage& t) {
  thread_local std::vector<Projected> proj;
  proj.resize(points.size());
  const float fx = float(k.fx), fy = float(k.fy), cx = float(k.cx), cy = float(k.cy);
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points[i];
    if (p.z < kNearPlane) {
      proj[i].valid = false;
      continue;
    }
    const float iz = 1.0f / p.z;
    proj[i] = {cx + fx * p.x * iz, cy - fy * p.y * iz, iz, true};
  }
  const int W = t.width, H = t.height;
  float* depth = t.depth.data();
  uint8_t* label = t.label.data();
  for (const auto& tri : triangles) {
    const Projected* a = &proj[tri[0]];
    const Projected* b = &proj[tri[1]];
    const Projected* c = &proj[tri[2]];
    if (!a->valid || !b->valid || !c->valid) continue;
    uint8_t la = vertex_labels[tri[0]], lb = vertex_labels[tri[1]], lc = vertex_labels[tri[2]];
    float area = (b->u - a->u) * (c->v - a->v) - (b->v - a->v) * (c->u - a->u);
    if (area == 0.0f || !std::isfinite(area)) continue;
    if (area < 0) {  // make the corner order counter-clockwise in (u, v)
      std::swap(b, c);
      std::swap(lb, lc);
      area = -area;
    }
    const float umin = std::min({a->u, b->u, c->u}), umax = std::max({a->u, b->u, c->u});
    const float vmin = std::min({a->v, b->v, c->v}), vmax = std::max({a->v, b->v, c->v});
    const int x0 = std::max(0, int(std::ceil(umin))), x1 = std::min(W - 1, int(std::floor(umax)));
    const int y0 = std::max(0, int(std::ceil(vmin))), y1 = std::min(H - 1, int(std::floor(vmax)));
    if (x0 > x1 || y0 > y1) continue;
    // Edge function e(p) = A*u + B*v + C, positive inside; corner opposite the edge gets its weight.
    auto edge = [](const Projected* p, const Projected* q, float& A, float& B, float& C) {
      A = -(q->v - p->v);
      B = q->u - p->u;
      C = -(A * p->u + B * p->v);
    };
    float A0, B0, C0, A1, B1, C1, A2, B2, C2;
    edge(b, c, A0, B0, C0);  // weight of a
    edge(c, a, A1, B1, C1);  // weight of b
    edge(a, b, A2, B2, C2);  // weight of c
    // Top-left rule: a pixel centre exactly on an edge belongs to one of the two triangles sharing it.
    const bool tl0 = A0 > 0 || (A0 == 0 && B0 > 0);
    const bool tl1 = A1 > 0 || (A1 == 0 && B1 > 0);
    const bool tl2 = A2 > 0 || (A2 == 0 && B2 > 0);
    const float inv_area = 1.0f / area;
    const float za = a->inv_z * inv_area, zb = b->inv_z * inv_area, zc = c->inv_z * inv_area;
    for (int y = y0; y <= y1; ++y) {
      float w0 = A0 * x0 + B0 * y + C0, w1 = A1 * x0 + B1 * y + C1, w2 = A2 * x0 + B2 * y + C2;
      float* drow = depth + size_t(y) * W;
      uint8_t* lrow = label + size_t(y) * W;
      for (int x = x0; x <= x1; ++x, w0 += A0, w1 += A1, w2 += A2) {
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        if ((w0 == 0 && !tl0) || (w1 == 0 && !tl1) || (w2 == 0 && !tl2)) continue;
        const float z = 1.0f / (w0 * za + w1 * zb + w2 * zc);
        float& d = drow[x];
        if (d != 0.0f && d <= z) continue;
        d = z;
        lrow[x] = (w0 >= w1 && w0 >= w2) ? la : (w1 >= w2 ? lb : lc);
      }
    }
  }
}

void rasterize_plane(const Intrinsics& k, const Vec3& n, double d, double max_depth, DepthLabelImage& t) {
  for (int y = 0; y < t.height; ++y) {
    for (int x = 0; x < t.width; ++x) {
      // Ray direction with z = 1: X = z * r.
      const Vec3 r{(x - k.cx) / k.fx, -(y - k.cy) / k.fy, 1.0};
      const double denom = n.dot(r);
      if (std::fabs(denom) < 1e-12) continue;
      const double z = d / denom;
      if (!(z > kNearPlane) || z > max_depth) continue;
      float& cur = t.depth[size_t(y) * t.width + x];
      if (cur == 0.0f || z < cur) cur = float(z);
    }
  }
}

}  // namespace dp::synth
