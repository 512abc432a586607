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

namespace dp::tools {

namespace {

// splitmix64: a fixed integer sequence (the same on every platform and standard library).
struct SceneRng {
  uint64_t state;
  uint64_t next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  float uniform(float lo, float hi) { return lo + (hi - lo) * float(double(next() >> 11) * 0x1.0p-53); }
  int integer(int lo, int hi) { return lo + int(next() % uint64_t(hi - lo + 1)); }
};

enum class Posture { kStanding, kCrouching, kLying, kBentOver };

// One body at world (x, z), facing the camera, from boxes and cylinders tagged `truth`.
void add_person(Scene* s, float x, float z, float height, Posture posture, float arm_out_m, uint8_t truth) {
  const float k = height / 1.75f;
  switch (posture) {
    case Posture::kStanding: {
      const float hip = 0.85f * k, shoulder = 1.45f * k;
      s->cylinders.push_back({x - 0.1f * k, z, 0.07f * k, 0.0f, hip, truth});
      s->cylinders.push_back({x + 0.1f * k, z, 0.07f * k, 0.0f, hip, truth});
      s->cylinders.push_back({x, z, 0.17f * k, hip - 0.02f, shoulder, truth});
      s->cylinders.push_back({x, z, 0.1f * k, shoulder, height, truth});
      // Arms: down at the sides, one possibly held out sideways at shoulder height.
      s->boxes.push_back({x - 0.27f * k, x - 0.19f * k, hip, shoulder - 0.02f, z - 0.04f, z + 0.04f, truth});
      if (arm_out_m > 0.0f)
        s->boxes.push_back({x + 0.17f * k, x + 0.17f * k + arm_out_m, shoulder - 0.1f, shoulder - 0.02f, z - 0.04f,
                            z + 0.04f, truth});
      else
        s->boxes.push_back({x + 0.19f * k, x + 0.27f * k, hip, shoulder - 0.02f, z - 0.04f, z + 0.04f, truth});
      break;
    }
    case Posture::kCrouching: {
      s->boxes.push_back({x - 0.2f * k, x + 0.2f * k, 0.0f, 0.45f * k, z - 0.15f, z + 0.2f, truth});
      s->cylinders.push_back({x, z + 0.05f, 0.17f * k, 0.4f * k, 0.85f * k, truth});
      s->cylinders.push_back({x, z + 0.05f, 0.1f * k, 0.85f * k, 1.05f * k, truth});
      break;
    }
    case Posture::kLying: {
      s->boxes.push_back({x - 0.9f * k, x + 0.7f * k, 0.0f, 0.25f * k, z - 0.18f, z + 0.18f, truth});
      s->cylinders.push_back({x + 0.8f * k, z, 0.1f * k, 0.0f, 0.22f * k, truth});
      if (arm_out_m > 0.0f) s->boxes.push_back({x, x + 0.08f, 0.25f * k, 0.8f * k, z - 0.04f, z + 0.04f, truth});
      break;
    }
    case Posture::kBentOver: {
      s->cylinders.push_back({x - 0.1f * k, z, 0.07f * k, 0.0f, 0.8f * k, truth});
      s->cylinders.push_back({x + 0.1f * k, z, 0.07f * k, 0.0f, 0.8f * k, truth});
      s->boxes.push_back({x - 0.2f * k, x + 0.2f * k, 0.75f * k, 1.0f * k, z - 0.7f * k, z + 0.05f, truth});
      s->cylinders.push_back({x, z - 0.75f * k, 0.1f * k, 0.7f * k, 0.95f * k, truth});
      break;
    }
  }
}

}  // namespace

Scene random_scene(uint32_t seed, int frame, int width, int height) {
  SceneRng rng{0xD1B54A32D192ED03ull ^ (uint64_t(seed) * 0x9E3779B97F4A7C15ull)};
  Scene s;
  s.camera.width = width;
  s.camera.height = height;
  s.camera.height_m = rng.uniform(0.5f, 2.3f);
  s.camera.pitch_deg = rng.uniform(-5.0f, 35.0f);
  s.camera.roll_deg = rng.uniform(-8.0f, 8.0f);
  if (rng.integer(0, 2) > 0) s.wall_z = rng.uniform(4.5f, 7.0f);
  const int people = rng.integer(1, 4);
  for (int p = 0; p < people; ++p) {
    const int kind = rng.integer(0, 9);
    const Posture posture = kind < 6 ? Posture::kStanding
                            : kind == 6 ? Posture::kCrouching
                            : kind == 7 ? Posture::kLying
                                        : Posture::kBentOver;
    // Some people close to the camera (cut by the borders), most at 1.5–5 m.
    const bool close = rng.integer(0, 5) == 0;
    const float z0 = close ? rng.uniform(0.7f, 1.3f) : rng.uniform(1.5f, 5.0f);
    const float x0 = rng.uniform(-0.5f, 0.5f) * z0 * 1.1f;
    const float vx = rng.uniform(-0.12f, 0.12f), vz = rng.uniform(-0.06f, 0.06f);
    const float arm = rng.integer(0, 3) == 0 ? rng.uniform(0.3f, 0.7f) : 0.0f;
    const float tall = rng.uniform(1.45f, 1.95f);
    float z = z0 + vz * float(frame);
    if (z < 0.6f) z = 0.6f;
    add_person(&s, x0 + vx * float(frame), z, tall, posture, arm, uint8_t(p + 1));
  }
  const int clutter = rng.integer(2, 7);
  for (int c = 0; c < clutter; ++c) {
    const float z = rng.uniform(1.2f, 6.0f);
    const float x = rng.uniform(-0.6f, 0.6f) * z;
    const float tall = rng.uniform(0.3f, 0.8f);
    if (rng.integer(0, 2) == 0) {
      s.cylinders.push_back({x, z, rng.uniform(0.12f, 0.3f), 0.0f, tall, 0});
    } else {
      const float half_w = rng.uniform(0.15f, 0.6f), half_d = rng.uniform(0.15f, 0.5f);
      s.boxes.push_back({x - half_w, x + half_w, 0.0f, tall, z - half_d, z + half_d, 0});
    }
  }
  return s;
}

void add_depth_noise(RenderedScene* scene, uint32_t seed, int frame) {
  SceneRng rng{0x2545F4914F6CDD1Dull ^ (uint64_t(seed) << 20) ^ uint64_t(uint32_t(frame))};
  const int w = scene->width, h = scene->height;
  for (int v = 0; v < h; ++v) {
    uint16_t* row = scene->depth_mm.data() + size_t(v) * w;
    for (int u = 0; u < w; ++u) {
      const uint64_t r = rng.next();
      if (row[u] == 0) continue;
      if (r % 100 == 0) {
        row[u] = 0;
        continue;
      }
      // Jitter of up to ±0.2 % of the depth.
      const int32_t jitter = int32_t((r >> 8) % 401) - 200;
      const int32_t z = int32_t(row[u]) + int32_t(int64_t(row[u]) * jitter / 100000);
      row[u] = uint16_t(z < 1 ? 1 : z > 65535 ? 65535 : z);
    }
    // Dropout runs where the depth jumps (occluding edges cast shadows without readings).
    for (int u = 1; u < w; ++u) {
      const int32_t a = row[u - 1], b = row[u];
      if (a == 0 || b == 0 || (a - b < 200 && b - a < 200)) continue;
      const int run = int(rng.next() % 4);
      for (int k = 0; k < run && u + k < w; ++k) row[u + k] = 0;
      u += run;
    }
  }
}

}  // namespace dp::tools
