// `depthpose eval`: the paper's accuracy metrics (section 4.2) of a blob, run as deployed, on a
// dataset in layout v1; optional JSON and PNG plots.
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/common/kernel_option.h"
#include "tools/eval/evaluator.h"
#include "tools/eval/plots.h"
#include "tools/eval/report.h"

namespace dp::tools {

EvalOptions eval_options_from_args(const Args& a) {
  EvalOptions o;
  o.silhouette = a.flag("--silhouette");
  const double d = a.get_double("--dtp", o.silhouette ? o.d_tp_px : o.d_tp_m);
  if (!(d > 0)) fail("--dtp must be positive");
  (o.silhouette ? o.d_tp_px : o.d_tp_m) = d;
  o.penalize_occluded = a.flag("--penalize-occluded");
  o.max_frames = long(a.get_int("--frames", 0));
  if (o.max_frames < 0) fail("--frames must be ≥ 0");
  o.kernel = parse_kernel_option(a.get("--kernel", "best"));
  if (a.has("--map-joints")) o.joint_map = parse_name_map(a.get("--map-joints"), "--map-joints");
  if (a.has("--map-parts")) o.part_map = parse_name_map(a.get("--map-parts"), "--map-parts");
  o.budget = budget_overrides_from_args(a);
  return o;
}

static const std::string kUsage =
    std::string("usage: depthpose eval --blob BLOB --data DATASET [--json OUT.json] [--plots DIR] [--dtp D]\n"
    "                      [--penalize-occluded] [--silhouette] [--frames N] [--kernel K]\n"
    "                      [--map-joints DS=BLOB,...] [--map-parts DS=BLOB,...] [--pixel-budget N] [--cycle-budget C]\n"
    "  Runs the blob through the runtime over every frame of a dataset (layout v1) and reports per-joint\n"
    "  average precision and mAP (paper section 4.2), mAP against D_tp, per-class segmentation accuracy and\n"
    "  the confusion matrix (BPC, labelled datasets), and speed. Foreground = ground-truth body mask when the\n"
    "  dataset has parts/, else the blob's depth band.\n"
    "  --dtp D              true-positive radius: metres (default 0.1), pixels with --silhouette (default 10)\n"
    "  --penalize-occluded  count invisible joints as false negatives when missed\n"
    "  --silhouette         flatten the foreground to 2 m (paper 4.6.4); D_tp in pixels\n"
    "  --map-joints/--map-parts  rename dataset names to blob names (unmatched names are then skipped);\n"
    "                       the value may be @FILE (pairs separated by commas, spaces or newlines)\n") +
    kKernelOptionUsage + kBudgetOptionsUsage +
    "  --segment            measure segmentation instead (floor, background, users: foreground IoU, people\n"
    "                       found, false users per frame, joint mAP with the segmenter's mask vs the ground-truth\n"
    "                       mask); the same as `depthpose segeval` (its options: docs/segmentation.md)\n"
    "  docs/evaluation.md describes the protocol and the JSON.";

static int run_eval(int argc, char** argv) {
  // `eval --segment ...`: segmentation quality (and joint mAP with the segmenter's mask against the
  // ground-truth mask) is measured by segeval; one entry point for users, one implementation.
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--segment") {
      std::vector<char*> rest;
      for (int k = 0; k < argc; ++k)
        if (k != i) rest.push_back(argv[k]);
      const cli::Command* segeval = cli::find_command("segeval");
      if (!segeval) fail("eval --segment: the segeval command is not built in");
      return segeval->run(int(rest.size()), rest.data());
    }
  Args a(argc, argv, kUsage,
         {"--blob", "--data", "--json", "--plots", "--dtp", "--frames", "--kernel", "--map-joints", "--map-parts",
          kBudgetOptionNames[0], kBudgetOptionNames[1]},
         {"--penalize-occluded", "--silhouette"});
  if (a.help_requested()) {
    std::printf("%s\n", a.usage().c_str());
    return 0;
  }
  const EvalOptions o = eval_options_from_args(a);
  auto session = open_eval_session(a.get("--blob"), a.get("--data"), o);
  if (session->evaluated_joints().empty())
    std::fprintf(stderr, "eval: no joint of the blob is in the dataset: joint accuracy is not measured\n");
  const EvalReport r = session->evaluate();
  print_report(r, stdout);
  if (a.has("--json")) {
    const std::string path = a.get("--json");
    nlohmann::json j = report_to_json(r);
    j["blob"] = a.get("--blob");
    j["data"] = a.get("--data");
    write_file_atomic(path, j.dump(2) + "\n");  // a failed write leaves no truncated JSON
    std::printf("wrote %s\n", path.c_str());
  }
  if (a.has("--plots")) {
    for (const std::string& p : write_eval_plots(r, a.get("--plots"))) std::printf("wrote %s\n", p.c_str());
  }
  check_output_stream();  // the report on stdout: a full disk or /dev/full is an error
  return 0;
}

DP_REGISTER_COMMAND(eval, "eval", "measure a blob on a dataset: per-joint AP, mAP, class accuracy, plots", run_eval);

}  // namespace dp::tools
