#include "runtime/budget_plan.h"

#include "runtime/depthpose.h"

namespace dp {

BudgetPlan plan_budget(const blob::LoadedBlob& blob, const blob::RuntimeConfig& cfg, int32_t frame_pixels, int32_t fg,
                       int32_t pixel_cap) {
  namespace bm = budget_model;
  const blob::ForestMeta& m = *blob.meta;
  BudgetPlan plan{};
  int64_t n = fg < pixel_cap ? fg : pixel_cap;
  int64_t votes = cfg.max_votes_per_joint, starts = cfg.max_starts_per_joint, iters = cfg.mean_shift_iterations;
  const int64_t joints = m.joint_count;
  const uint64_t per_pixel = bm::kPerNodeVisit * uint64_t(m.tree_count) * m.depth +
                             (blob.method() == blob::Method::kBpc
                                  ? bm::kPerBpcPixel
                                  : bm::kPerOjrVote * uint64_t(m.tree_count) * uint64_t(joints) * m.votes_per_joint);
  const uint64_t fixed = bm::kPerFramePixel * uint64_t(frame_pixels) + bm::kPerJoint * uint64_t(joints);
  auto mean_shift = [&](int64_t v, int64_t s, int64_t it) { return bm::kPerKernelEval * uint64_t(joints * s * it * ((v + 3) & ~3)); };
  auto total = [&]() { return fixed + per_pixel * uint64_t(n) + mean_shift(votes, starts, iters); };
  const uint64_t budget = cfg.cycle_budget;
  if (budget != 0 && total() > budget) {
    // 1. pixels (stride), down to the floor.
    const int64_t floor_n = n < bm::kMinPixels ? n : bm::kMinPixels;
    const uint64_t rest = fixed + mean_shift(votes, starts, iters);
    const int64_t fit = budget > rest ? int64_t((budget - rest) / per_pixel) : 0;
    const int64_t new_n = fit > floor_n ? fit : floor_n;
    if (new_n < n) { n = new_n; plan.flags |= kFlagBudgetPixels; }
    // 2.–4. Nsub, starts, iterations, each down to its floor while still over.
    int64_t* knobs[3] = {&votes, &starts, &iters};
    const int64_t floors[3] = {bm::kMinVotes, bm::kMinStarts, bm::kMinIterations};
    const uint32_t flags[3] = {kFlagBudgetVotes, kFlagBudgetStarts, kFlagBudgetIterations};
    for (int k = 0; k < 3 && total() > budget; ++k) {
      int64_t& knob = *knobs[k];
      const int64_t lowest = knob < floors[k] ? knob : floors[k];
      const int64_t original = knob;
      while (knob > lowest && total() > budget) knob = knob - 1 - (knob - lowest) / 8;  // ~12% steps
      if (knob < lowest) knob = lowest;
      if (knob < original) plan.flags |= flags[k];
    }
    if (total() > budget) plan.flags |= kFlagBudgetInfeasible;
  }
  plan.pixels = int32_t(n > 0 ? n : 1);
  plan.votes = int32_t(votes);
  plan.starts = int32_t(starts);
  plan.iterations = int32_t(iters);
  plan.predicted = total();
  return plan;
}

}  // namespace dp
