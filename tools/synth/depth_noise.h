// Sensor noise applied to a clean synthetic depth render, after the paper (section 2: "we add
// ... noise") and the Kinect v1's structured-light principle. docs/synthetic_data.md describes
// the model and its default numbers. The order is fixed: projector shadows, edge and grazing
// dropouts, random dropouts, disparity jitter + quantization, spot holes.
#pragma once
#include <cstdint>
#include <vector>

#include "tools/common/png_io.h"
#include "tools/synth/rasterizer.h"
#include "tools/synth/random.h"

namespace dp::synth {

struct NoiseConfig {
  bool enabled = true;
  double baseline_m = 0.075;            // projector to the right (+x) of the camera
  double focal_640 = 580.0;             // IR focal length at 640 px width (disparity units)
  double disparity_step_px = 1.0 / 8;   // quantization of disparity at 640 px width
  double disparity_jitter_px = 0.06;    // Gaussian sigma before quantization (640 px units)
  double edge_dropout = 0.35;           // probability to drop a pixel at a depth discontinuity
  double edge_jump_m = 0.06;            // neighbour depth difference that counts as an edge
  double grazing_slope_start = 2.5;     // |grad z| * f / z above which pixels start to drop
  double grazing_slope_full = 6.0;      // ... and all drop
  double random_dropout = 0.002;        // per valid pixel
  double spots_mean = 3.0;              // mean number of hole spots per frame (at 320x240)
  double spot_radius_max_px = 3.0;      // at 320x240; scales with width
  double max_range_m = 8.0;             // farther readings are 0
};

// Converts the clean render (metres) into a depth image in millimetres (0 = no reading) with the
// noise applied. Deterministic for a given rng state. The output has the render's size.
void apply_sensor_noise(const Intrinsics& k, const NoiseConfig& config, const std::vector<float>& clean_depth_m,
                        Rng& rng, dp::tools::ImageU16& depth_mm);

}  // namespace dp::synth
