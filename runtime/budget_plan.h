// The cycle-budget plan (docs/budget.md): before the forest runs, a worst-case cost model predicts a
// frame's cost in counter ticks (runtime/cycle_counter.h) from its size, its foreground and the
// config; when config.cycle_budget (≠ 0) is exceeded, the plan degrades in a fixed order — pixels
// (stride), Nsub, mean-shift starts, iterations — each down to its floor, until the prediction fits
// or everything is at its floor (kFlagBudgetInfeasible).
// The model is the same for every kernel (calibrated on the fastest, in x86-64 TSC cycles), so a
// budget degrades a frame identically whichever kernel runs and results stay bit-identical across
// kernels; a slower kernel overruns and says so (kFlagOverCycleBudget). On other platforms the
// counter ticks at another rate (aarch64: CNTFRQ_EL0), so a budget there is set in that unit and the
// model's constants are uncalibrated for it (docs/arm64.md).
#pragma once
#include <stdint.h>

#include "forest_blob/blob_loader.h"

namespace dp {

namespace budget_model {
constexpr uint64_t kPerFramePixel = 3;      // foreground scan, per frame pixel
constexpr uint64_t kPerNodeVisit = 5;       // forest, per pixel × tree × level
constexpr uint64_t kPerBpcPixel = 60;       // BPC votes, per evaluated pixel
constexpr uint64_t kPerOjrVote = 8;         // OJR votes, per pixel × tree × joint × K
constexpr uint64_t kPerKernelEval = 3;      // mean shift, per start × iteration × vote (4 lanes)
constexpr uint64_t kPerJoint = 20000;       // aggregation fixed cost per joint (sort, modes)
constexpr int32_t kMinPixels = 1000;        // degrade floors (or the configured value if lower)
constexpr int32_t kMinVotes = 32;
constexpr int32_t kMinStarts = 4;
constexpr int32_t kMinIterations = 2;
}  // namespace budget_model

struct BudgetPlan {
  int32_t pixels;          // pixels to evaluate, ≥ 1
  int32_t votes;           // Nsub
  int32_t starts;          // mean-shift starts per joint
  int32_t iterations;      // mean-shift iterations
  uint64_t predicted;      // the model's cost of this plan
  uint32_t flags;          // kFlagBudget* bits
};

// The plan for a frame of `frame_pixels` pixels with `foreground` foreground pixels, at most
// `pixel_cap` of which may be evaluated. Deterministic; no state.
BudgetPlan plan_budget(const blob::LoadedBlob& blob, const blob::RuntimeConfig& config, int32_t frame_pixels,
                       int32_t foreground, int32_t pixel_cap);

}  // namespace dp
