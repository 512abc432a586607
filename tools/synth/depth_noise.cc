#include "tools/synth/depth_noise.h"

#include <algorithm>
#include <cmath>

namespace dp::synth {

void apply_sensor_noise(const Intrinsics& k, const NoiseConfig& c, const std::vector<float>& clean, Rng& rng,
                        dp::tools::ImageU16& out) {
  const int W = k.width, H = k.height;
  out.width = W;
  out.height = H;
  out.pixels.assign(size_t(W) * H, 0);
  thread_local std::vector<float> z;
  z.assign(clean.begin(), clean.end());
  for (float& v : z)
    if (v > c.max_range_m) v = 0;
  if (!c.enabled) {
    for (size_t i = 0; i < z.size(); ++i) out.pixels[i] = uint16_t(std::min(65535.0f, std::round(z[i] * 1000.0f)));
    return;
  }
  const double scale = W / 640.0;  // pixel size relative to 640 wide
  const double f = k.fx;

  // 1. Projector shadows: the projector sits baseline_m to the right; a surface point is lit only
  // if no nearer surface crosses its projector ray. Along a row, its projector column is
  // u - f*b/z; scanning from the projector side, a column behind the running minimum is hidden.
  thread_local std::vector<uint8_t> drop;
  drop.assign(z.size(), 0);
  const double fb = f * c.baseline_m;
  for (int y = 0; y < H; ++y) {
    const float* row = &z[size_t(y) * W];
    double min_up = 1e30;
    for (int x = W - 1; x >= 0; --x) {
      if (row[x] <= 0) continue;
      const double up = x - fb / row[x];
      if (up > min_up + 1e-6) drop[size_t(y) * W + x] = 1;
      min_up = std::min(min_up, up);
    }
  }
  // 2. Edge and grazing-angle dropouts.
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      const float d = z[i];
      if (d <= 0 || drop[i]) continue;
      const float l = x > 0 ? z[i - 1] : 0, r = x + 1 < W ? z[i + 1] : 0;
      const float u = y > 0 ? z[i - W] : 0, b = y + 1 < H ? z[i + W] : 0;
      const float jump = float(c.edge_jump_m);
      const bool edge = l <= 0 || r <= 0 || u <= 0 || b <= 0 || std::fabs(l - d) > jump ||
                        std::fabs(r - d) > jump || std::fabs(u - d) > jump || std::fabs(b - d) > jump;
      if (edge) {
        if (rng.chance(c.edge_dropout)) drop[i] = 1;
        continue;
      }
      const double gx = 0.5 * (r - l), gy = 0.5 * (b - u);
      const double slope = std::sqrt(gx * gx + gy * gy) * f / d;
      if (slope > c.grazing_slope_start) {
        const double p = (slope - c.grazing_slope_start) / (c.grazing_slope_full - c.grazing_slope_start);
        if (rng.chance(std::min(1.0, p))) drop[i] = 1;
      }
    }
  }
  // 3-4. Random dropouts, disparity jitter and quantization (depth step grows with z^2).
  const double fb640 = c.focal_640 * c.baseline_m;
  for (size_t i = 0; i < z.size(); ++i) {
    if (z[i] <= 0 || drop[i]) continue;
    if (rng.chance(c.random_dropout)) continue;
    double disparity = fb640 / z[i] + c.disparity_jitter_px * rng.gaussian();
    disparity = std::round(disparity / c.disparity_step_px) * c.disparity_step_px;
    if (disparity <= 0) continue;
    const double depth_mm = 1000.0 * fb640 / disparity;
    if (depth_mm / 1000.0 > c.max_range_m) continue;
    out.pixels[i] = uint16_t(std::min(65535.0, std::round(depth_mm)));
  }
  // 5. Spot holes (specular / absorbing patches): small discs set to no reading.
  const int spots = rng.poisson(c.spots_mean * (W * H) / (320.0 * 240.0));
  const double rmax = std::max(1.0, c.spot_radius_max_px * scale * 2.0);
  for (int s = 0; s < spots; ++s) {
    const int cx = int(rng.below(uint64_t(W))), cy = int(rng.below(uint64_t(H)));
    const double r = rng.uniform(1.0, rmax);
    const int ri = int(std::ceil(r));
    for (int dy = -ri; dy <= ri; ++dy)
      for (int dx = -ri; dx <= ri; ++dx) {
        const int x = cx + dx, y = cy + dy;
        if (x < 0 || y < 0 || x >= W || y >= H || dx * dx + dy * dy > r * r) continue;
        out.pixels[size_t(y) * W + x] = 0;
      }
  }
}

}  // namespace dp::synth
