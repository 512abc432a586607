#include "runtime/skeleton_filter.h"

#include <math.h>

namespace dp {

namespace {
constexpr float kTwoPi = 6.28318530718f;
float smoothing_factor(float cutoff_hz, float dt_s) { return 1.0f / (1.0f + 1.0f / (kTwoPi * cutoff_hz * dt_s)); }
}  // namespace

SkeletonFilterParams skeleton_filter_preset(SkeletonFilterPreset preset) {
  // Chosen by `depthpose skeleton-eval --filter-sweep` on the validation sequences (docs/skeleton.md,
  // "Temporal filter"): default = the least still-joint jitter whose lag on fast motion stays under
  // one frame and whose within-0.1 m rate stays within 0.01 of no filter; strong = the least jitter
  // with a lag under 1.5 frames (both swept without an offset limit).
  // The default's offset limit: where the raw joint jumped back onto a proposal that fits, the
  // filter's lag moved correct joints more than 0.1 m away (486 of the 2083 joint-frames lost
  // against the first proposal on the validation sequences with tall clutter, seeds 191–196). There,
  // with the default cutoffs, limits of 0.02 / 0.03 / 0.05 / 0.07 m / none gave within 0.1 m 0.544 /
  // 0.543 / 0.538 / 0.536 / 0.534 with the previous depth-13 OJR forest and still-joint jitter 25.5 / 24.5 / 23.5 /
  // 23.0 / 22.6 mm (the previous depth-16 BPC forest 0.562 / 0.560 / 0.557 / 0.556 / 0.553, jitter 28.4 / 27.5 / 26.3 /
  // 25.6 / 23.7 mm): 0.03 m is the knee. The strong preset has none: it is for users who want the
  // least jitter (with the 0.03 m limit its jitter was 29.4 mm on held-out set A against 16.2 mm).
  switch (preset) {
    case SkeletonFilterPreset::kOff: return {0, 1.0f, 0.0f, 1.0f, 0.0f};
    case SkeletonFilterPreset::kDefault: return {1, 0.5f, 2.0f, 1.0f, 0.03f};
    case SkeletonFilterPreset::kStrong: return {1, 0.5f, 0.5f, 1.0f, 0.0f};
  }
  return {0, 1.0f, 0.0f, 1.0f, 0.0f};
}

bool skeleton_filter_params_valid(const SkeletonFilterParams& p) {
  if (!p.enabled) return true;
  return p.min_cutoff_hz > 0.0f && p.min_cutoff_hz <= 100.0f && p.beta >= 0.0f && p.beta <= 1000.0f &&
         p.d_cutoff_hz > 0.0f && p.d_cutoff_hz <= 100.0f && p.max_offset_m >= 0.0f && p.max_offset_m <= 1.0f;
}

void JointFilter::update(const SkeletonFilterParams& p, float dt_s, const float in[3], float out[3]) {
  if (!p.enabled || !primed) {
    for (int a = 0; a < 3; ++a) x[a] = out[a] = in[a];
    speed = 0.0f;
    primed = 1;
    return;
  }
  const float dx = in[0] - x[0], dy = in[1] - x[1], dz = in[2] - x[2];
  const float raw_speed = sqrtf(dx * dx + dy * dy + dz * dz) / dt_s;
  speed += smoothing_factor(p.d_cutoff_hz, dt_s) * (raw_speed - speed);
  const float alpha = smoothing_factor(p.min_cutoff_hz + p.beta * speed, dt_s);
  for (int a = 0; a < 3; ++a) out[a] = x[a] = x[a] + alpha * (in[a] - x[a]);
}

void JointFilter::limit_offset(const float in[3], float max_offset_m, float out[3]) {
  const float dx = out[0] - in[0], dy = out[1] - in[1], dz = out[2] - in[2];
  const float offset = sqrtf(dx * dx + dy * dy + dz * dz);
  if (!(offset > max_offset_m)) return;
  const float scale = max_offset_m / offset;
  const float d[3] = {dx, dy, dz};
  for (int a = 0; a < 3; ++a) out[a] = x[a] = in[a] + scale * d[a];
}

}  // namespace dp
