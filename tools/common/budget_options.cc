#include "tools/common/budget_options.h"

#include "tools/common/error.h"

namespace dp::tools {

const char* const kBudgetOptionNames[2] = {"--pixel-budget", "--cycle-budget"};
const char* const kBudgetOptionsUsage =
    "  --pixel-budget N     evaluate at most N foreground pixels per frame (strided above; at most the blob's)\n"
    "  --cycle-budget C     per-frame budget in counter ticks (0 = none; x86-64: TSC cycles, aarch64: generic-timer\n"
    "                       ticks, runtime/cycle_counter.h): the pipeline degrades to fit and flags it\n";

BudgetOverrides budget_overrides_from_args(const Args& a) {
  BudgetOverrides o;
  if (a.has("--pixel-budget")) {
    o.pixel_budget = a.get_int("--pixel-budget", -1);
    if (o.pixel_budget < 1) fail("--pixel-budget must be at least 1 pixel");
  }
  if (a.has("--cycle-budget")) {
    o.cycle_budget = a.get_int("--cycle-budget", -1);
    if (o.cycle_budget < 0) fail("--cycle-budget must be ≥ 0 counter ticks (0 = no budget)");
  }
  return o;
}

blob::RuntimeConfig with_budget(const blob::RuntimeConfig& config, const BudgetOverrides& o,
                                uint32_t blob_pixel_budget) {
  blob::RuntimeConfig c = config;
  if (o.pixel_budget >= 0) {
    if (o.pixel_budget > (long long)blob_pixel_budget)
      fail("--pixel-budget " + std::to_string(o.pixel_budget) + " exceeds the blob's pixel budget " +
           std::to_string(blob_pixel_budget) + " (the runtime's arena is sized for it)");
    c.max_evaluated_pixels = uint32_t(o.pixel_budget);
  }
  if (o.cycle_budget >= 0) c.cycle_budget = uint64_t(o.cycle_budget);
  return c;
}

std::string describe_budget(const BudgetOverrides& o) {
  std::string s;
  if (o.pixel_budget >= 0) s += "pixel budget " + std::to_string(o.pixel_budget);
  if (o.cycle_budget >= 0) s += std::string(s.empty() ? "" : ", ") + "cycle budget " + std::to_string(o.cycle_budget);
  return s;
}

}  // namespace dp::tools
