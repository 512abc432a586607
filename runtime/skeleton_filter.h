// Temporal smoothing of one tracked joint: the 1€ filter (Casiez, Roussel, Vogel, CHI 2012), an
// exponential smoother whose cutoff rises with the joint's speed, so a still joint is smoothed hard
// (little jitter) while a fast one follows closely (little lag).
//
// Per update, with dt the frame period:
//   speed   = |x − x̂_prev| / dt, itself smoothed at d_cutoff_hz        (m/s)
//   cutoff  = min_cutoff_hz + beta · speed                              (Hz)
//   α       = 1 / (1 + 1 / (2π · cutoff · dt))
//   x̂       = x̂_prev + α · (x − x̂_prev)                                 (each axis, metres)
// One cutoff per joint (from the 3D speed), so the three axes stay in step.
// Presets (SkeletonFilterPreset) and the measurement that chose the default: docs/skeleton.md.
// No allocation; constant work per update.
#pragma once
#include <stdint.h>

namespace dp {

struct SkeletonFilterParams {
  int32_t enabled;       // 0 = off: the output is the input
  float min_cutoff_hz;   // cutoff of a still joint, (0, 100]
  float beta;            // cutoff increase per m/s of speed, [0, 1000]
  float d_cutoff_hz;     // cutoff of the speed estimate, (0, 100]
  // The skeleton tracker keeps a well-fitting tracked joint at most this far (metres) from its chosen
  // proposal (JointFilter::limit_offset; skeleton_tracker.cc says which joints); 0 = no limit, [0, 1].
  float max_offset_m;
};

enum class SkeletonFilterPreset : int32_t { kOff = 0, kDefault = 1, kStrong = 2 };
SkeletonFilterParams skeleton_filter_preset(SkeletonFilterPreset preset);
// True when the values are within the ranges above (disabled params are always valid).
bool skeleton_filter_params_valid(const SkeletonFilterParams& params);

// One joint's filter state. reset() before the first sample of a new track.
struct JointFilter {
  float x[3];       // last output (metres)
  float speed;      // smoothed speed (m/s)
  int32_t primed;   // 0 until the first sample

  void reset() { primed = 0; }
  // Filters `in` (metres) over a frame period `dt_s` > 0 into `out`; the first sample is returned unchanged.
  void update(const SkeletonFilterParams& params, float dt_s, const float in[3], float out[3]);
  // Pulls `out` (this update's output) and the filter's state to within `max_offset_m` of `in`
  // along the line between them; nothing changes when they are that close already.
  void limit_offset(const float in[3], float max_offset_m, float out[3]);
};

}  // namespace dp
