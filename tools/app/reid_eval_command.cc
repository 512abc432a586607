// `depthpose reid-eval`: argument parsing and the report of evaluate_reid (tools/app/reid_eval.h),
// a Markdown table per sequence and the totals that docs/skeleton.md quotes.
#include <cstdio>

#include "tools/app/reid_eval.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"

namespace dp::tools {
namespace {

const char* kUsage =
    "usage: depthpose reid-eval --data DIR[,DIR...] [--leave N] [--gap N] [--no-reid]\n"
    "  Measures the people finder's ids across leaving and re-entering on synthetic sequences with\n"
    "  two or more people (depthpose synth --sequence --people 2 ...): person 1 is taken out of view\n"
    "  (its pixels set to no reading) after --leave frames (default 30) for --gap frames (default 60)\n"
    "  and comes back: does it get its id again? And, in a second run, person 2 enters only after the\n"
    "  gap while person 1 stays gone: does the newcomer take person 1's id (a false re-identification)?\n"
    "  Prints one row per sequence and the totals (docs/skeleton.md, \"Ids across leaving\").\n"
    "  --no-reid   the people finder without re-identification (reid_window_frames = 0), to compare\n";

int reid_eval_main(int argc, char** argv) {
  Args args(argc, argv, kUsage, {"--data", "--leave", "--gap"}, {"--no-reid"});
  if (args.help_requested()) {
    std::printf("%s", kUsage);
    return 0;
  }
  ReidEvalOptions o;
  o.datasets = split_list(args.get("--data"));
  o.leave_frame = int(args.get_int("--leave", 30));
  o.gap_frames = int(args.get_int("--gap", 60));
  o.reid = !args.flag("--no-reid");
  const std::vector<ReidSequenceResult> results = evaluate_reid(o);
  std::printf("| sequence | person 1 returns | person 2 enters | height 1 m (before, back) | height 2 m |\n|---|---|---|---|---|\n");
  int returns[kReidOutcomes] = {}, newcomers[kReidOutcomes] = {};
  for (const ReidSequenceResult& r : results) {
    std::printf("| %s | %s | %s | %.3f, %.3f | %.3f |\n", r.dataset.c_str(), reid_outcome_name(r.return_outcome),
                reid_outcome_name(r.newcomer_outcome), r.person1_height_m, r.person1_back_height_m, r.person2_height_m);
    ++returns[r.return_outcome];
    ++newcomers[r.newcomer_outcome];
  }
  std::printf("\nreturns (leave after %d frames, back after %d): ", o.leave_frame, o.gap_frames);
  for (int k = 0; k < kReidOutcomes; ++k) std::printf("%s%s %d", k ? ", " : "", reid_outcome_name(k), returns[k]);
  std::printf("\nnewcomers: ");
  for (int k = 0; k < kReidOutcomes; ++k) std::printf("%s%s %d", k ? ", " : "", reid_outcome_name(k), newcomers[k]);
  std::printf("\n");
  return 0;
}

}  // namespace
}  // namespace dp::tools

DP_REGISTER_COMMAND(reid_eval, "reid-eval",
                    "measure ids across leaving and re-entering on synthetic sequences (re-identification)",
                    dp::tools::reid_eval_main);
