// Procedural "stick bodies" for the trainer's benchmark: a torso, head and eight limb segments
// drawn as depth-shaded capsules at 1.8–3.5 m, each capsule split into labelled halves (up to 31
// parts), in a 320×240 frame with f = 285 px. Not a human model — just enough structure that the
// trees grow to realistic depth and the probes touch realistic memory.
#pragma once
#include <cmath>
#include <cstdint>
#include <vector>

#include "tools/train/training_set.h"

namespace dp::train::testing_bodies {

struct BodyImage {
  int width = 320, height = 240;
  std::vector<uint16_t> depth;  // mm, 0 = no reading
  std::vector<uint8_t> parts;   // 0..30, 255 = not body
  std::vector<float> joints;    // 16 × {x, y, z} metres (capsule ends), camera frame
};

inline BodyImage make_stick_body(uint64_t seed, int width = 320, int height = 240, double f = 285) {
  Rng rng(seed * 0x9E3779B97F4A7C15ull + 1);
  BodyImage im;
  im.width = width;
  im.height = height;
  im.depth.assign(size_t(width) * height, 0);
  im.parts.assign(size_t(width) * height, 255);
  const double z = 1.8 + 1.7 * rng.unit();
  const double cx = width / 2.0 + (rng.unit() - 0.5) * width * 0.4, cy = height / 2.0;
  const double px_per_m = f / z;
  struct Capsule {
    double x0, y0, x1, y1, r;  // metres in the body plane (x right, y up), radius
    int part;
  };
  std::vector<Capsule> caps;
  auto limb = [&](double x, double y, double angle, double length, double r, int part) {
    const double x1 = x + length * std::sin(angle), y1 = y - length * std::cos(angle);
    caps.push_back({x, y, x1, y1, r, part});
    return std::array<double, 2>{x1, y1};
  };
  caps.push_back({0, 0.15, 0, 0.55, 0.16, 17});   // torso
  caps.push_back({0, 0.72, 0, 0.78, 0.11, 0});    // head
  const double sway = (rng.unit() - 0.5) * 0.6;
  for (int side = 0; side < 2; ++side) {
    const double s = side ? 1 : -1;
    const auto elbow = limb(0.2 * s, 0.6, s * (0.3 + 2.4 * rng.unit()) + sway, 0.28, 0.05, 7 + side);
    limb(elbow[0], elbow[1], s * (0.1 + 2.8 * rng.unit()) + sway, 0.26, 0.04, 9 + side);
    const auto knee = limb(0.1 * s, 0.1, s * (0.05 + 0.5 * rng.unit()), 0.42, 0.07, 21 + side);
    limb(knee[0], knee[1], s * (0.6 * rng.unit() - 0.2), 0.42, 0.055, 23 + side);
  }
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const double x = (u - cx) / px_per_m, y = (cy - v) / px_per_m + 0.9;
      double best = 1e9;
      int label = 255;
      for (const Capsule& c : caps) {
        const double dx = c.x1 - c.x0, dy = c.y1 - c.y0;
        const double len2 = dx * dx + dy * dy;
        double t = len2 > 0 ? ((x - c.x0) * dx + (y - c.y0) * dy) / len2 : 0;
        t = std::fmax(0, std::fmin(1, t));
        const double ex = x - (c.x0 + t * dx), ey = y - (c.y0 + t * dy);
        const double d2 = ex * ex + ey * ey;
        if (d2 >= c.r * c.r) continue;
        const double surface = z - std::sqrt(c.r * c.r - d2) + (c.part >= 21 ? 0.05 : c.part >= 7 ? -0.1 : 0);
        if (surface < best) {
          best = surface;
          // Halves along the capsule and left/right of its axis give distinct labels.
          const int half = (t < 0.5 ? 0 : 2) + ((ex * dy - ey * dx) > 0 ? 1 : 0);
          label = std::min(30, c.part + half % 2 + (c.part == 17 ? half : 0));
        }
      }
      if (label != 255) {
        im.depth[size_t(v) * width + u] = static_cast<uint16_t>(best * 1000);
        im.parts[size_t(v) * width + u] = static_cast<uint8_t>(label);
      }
    }
  for (int j = 0; j < 16; ++j) {
    const Capsule& c = caps[std::min<size_t>(j % caps.size(), caps.size() - 1)];
    const double x = j % 2 ? c.x1 : c.x0, y = j % 2 ? c.y1 : c.y0;
    im.joints.insert(im.joints.end(), {float(x + (cx - width / 2.0) / px_per_m), float(y - 0.9), float(z + 0.05)});
  }
  return im;
}

// A training set of `images` stick bodies, one tree, `pixels_per_image` pixels per image.
inline TrainingSet stick_body_set(int images, int pixels_per_image, int trees = 1, uint64_t seed = 1) {
  TrainingSet set;
  set.has_labels = set.has_joints = true;
  set.reference_focal_px = 285;
  for (int p = 0; p < 31; ++p) set.part_names.push_back("p" + std::to_string(p));
  for (int j = 0; j < 16; ++j) set.joint_names.push_back("j" + std::to_string(j));
  set.tree_pixels.resize(trees);
  const CameraIntrinsics cam{285, 285, 159.5, 119.5};
  for (int i = 0; i < images; ++i) {
    BodyImage b = make_stick_body(seed * 100003 + i);
    set.images.push_back(make_training_image(b.depth.data(), b.parts.data(), b.width, b.height, cam, 285,
                                             b.joints, "body " + std::to_string(i)));
    for (int t = 0; t < trees; ++t)
      sample_pixels(set.images.back(), b.parts.data(), i, t, pixels_per_image, seed, set.tree_pixels[t]);
  }
  return set;
}

}  // namespace dp::train::testing_bodies
