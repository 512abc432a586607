// Command-line overrides of a blob's per-frame budget (docs/budget.md), shared by `run` and `eval`:
//   --pixel-budget N   max_evaluated_pixels: above N foreground pixels, pixels are strided
//   --cycle-budget C   cycle_budget in counter ticks per frame (runtime/cycle_counter.h; 0 = none): the pipeline degrades its plan
//                      (stride, Nsub, starts, iterations) to fit, and flags what it did
// The blob file is never changed; the override lives in the caller's copy of the config.
#pragma once
#include <string>

#include "forest_blob/blob_format.h"
#include "tools/common/args.h"

namespace dp::tools {

struct BudgetOverrides {
  long long pixel_budget = -1;  // −1 = the blob's
  long long cycle_budget = -1;  // −1 = the blob's
  bool any() const { return pixel_budget >= 0 || cycle_budget >= 0; }
};

extern const char* const kBudgetOptionNames[2];  // "--pixel-budget", "--cycle-budget"
extern const char* const kBudgetOptionsUsage;    // usage lines for both

// Throws ToolError naming the option for a value that is not a number, a pixel budget < 1 or a
// cycle budget < 0.
BudgetOverrides budget_overrides_from_args(const Args& a);

// `config` with the overrides applied. Throws ToolError when the pixel budget exceeds
// `blob_pixel_budget` (the pipeline's arena is sized for the blob's own budget).
blob::RuntimeConfig with_budget(const blob::RuntimeConfig& config, const BudgetOverrides& o,
                                uint32_t blob_pixel_budget);

// "pixel budget 5000, cycle budget 2000000" (only the overridden ones; "" when none).
std::string describe_budget(const BudgetOverrides& o);

}  // namespace dp::tools
