// `depthpose tune`: grid search of the runtime hyper-parameters on a validation set (paper 3.5.3),
// written into a new blob whose forest is unchanged.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "forest_blob/blob_writer.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/eval/blob_rebuild.h"
#include "tools/eval/evaluator.h"
#include "tools/eval/tune.h"

namespace dp::tools {

EvalOptions eval_options_from_args(const Args& a);  // eval_command.cc

static const char* const kTuneUsage =
    "usage: depthpose tune --blob BLOB --data VALIDATION --out BLOB2 [--dtp D] [--silhouette]\n"
    "                      [--penalize-occluded] [--frames N] [--passes 2] [--threads N] [--no-nsub]\n"
    "                      [--nsub-tolerance T] [--json OUT.json] [--verbose] [--kernel K]\n"
    "                      [--map-joints DS=BLOB,...] [--map-parts DS=BLOB,...]\n"
    "  Learns the runtime hyper-parameters by grid search maximizing mAP on a validation set (paper 3.5.3):\n"
    "  BPC: bandwidths b_j, push-backs zeta_j, probability thresholds lambda_c; OJR: vote lengths lambda_j\n"
    "  (0.05-0.60 m), bandwidths b_j, Nsub. The forest runs once per frame; the grid re-runs votes and mean\n"
    "  shift only. Writes BLOB2 (same forest, tuned config), re-evaluates it end to end and reports the gain.\n"
    "  --nsub-tolerance T  take the smallest Nsub within T of the best mAP (faster; default 0)";

static int run_tune(int argc, char** argv) {
  Args a(argc, argv, kTuneUsage,
         {"--blob", "--data", "--out", "--dtp", "--frames", "--kernel", "--map-joints", "--map-parts", "--passes",
          "--threads", "--nsub-tolerance", "--json"},
         {"--penalize-occluded", "--silhouette", "--no-nsub", "--verbose"});
  if (a.help_requested()) {
    std::printf("%s\n", a.usage().c_str());
    return 0;
  }
  const std::string out = a.get("--out");
  EvalOptions eo = eval_options_from_args(a);
  eo.overlay_frames = 0;
  TuneOptions to;
  to.passes = int(a.get_int("--passes", 2));
  if (to.passes < 1 || to.passes > 10) fail("--passes must be 1..10");
  to.threads = int(a.get_int("--threads", 0));
  to.tune_nsub = !a.flag("--no-nsub");
  to.nsub_tolerance = a.get_double("--nsub-tolerance", 0.0);
  to.verbose = a.flag("--verbose");

  auto session = open_eval_session(a.get("--blob"), a.get("--data"), eo);
  const TuneResult r = tune_runtime_config(*session, to);
  for (const std::string& line : r.log) std::printf("%s\n", line.c_str());
  const std::vector<uint8_t> bytes = blob_with_config(session->blob(), r.config);
  blob::save_blob_file(out, bytes);

  // The tuned blob, run end to end exactly as deployed, must reproduce the searched mAP.
  auto check = std::make_unique<EvalSession>(bytes, out, a.get("--data"), eo);
  const EvalReport full = check->evaluate();
  const auto fmt = [](const std::optional<double>& v) {
    char b[16];
    std::snprintf(b, sizeof b, "%.4f", v.value_or(0));
    return v ? std::string(b) : std::string("n/a");
  };
  std::printf("joint            AP before  AP after\n");
  for (size_t k = 0; k < r.joint_names.size(); ++k)
    std::printf("  %-14s %9s  %8s\n", r.joint_names[k].c_str(), fmt(r.ap_before[k]).c_str(), fmt(r.ap_after[k]).c_str());
  const double gain = r.map_after.value_or(0) - r.map_before.value_or(0);
  std::printf("mAP %s -> %s (gain %+.4f) on %ld validation frames; %d grid points, forest cache %.2f s, search %.2f s\n",
              fmt(r.map_before).c_str(), fmt(r.map_after).c_str(), gain, r.frames, r.grid_points, r.cache_seconds,
              r.search_seconds);
  std::printf("wrote %s; end-to-end re-evaluation of it: mAP %s\n", out.c_str(), fmt(full.mean_ap).c_str());
  if (full.mean_ap.has_value() != r.map_after.has_value() ||
      (full.mean_ap && std::fabs(*full.mean_ap - *r.map_after) > 1e-9))
    std::fprintf(stderr, "tune: warning: the end-to-end mAP differs from the cached search (%s vs %s)\n",
                 fmt(full.mean_ap).c_str(), fmt(r.map_after).c_str());
  if (a.has("--json")) {
    nlohmann::json j;
    j["mAP_before"] = r.map_before ? nlohmann::json(*r.map_before) : nlohmann::json(nullptr);
    j["mAP_after"] = r.map_after ? nlohmann::json(*r.map_after) : nlohmann::json(nullptr);
    j["mAP_end_to_end"] = full.mean_ap ? nlohmann::json(*full.mean_ap) : nlohmann::json(nullptr);
    j["gain"] = gain;
    j["frames"] = r.frames;
    j["grid_points"] = r.grid_points;
    nlohmann::json joints = nlohmann::json::object();
    for (size_t k = 0; k < r.joint_names.size(); ++k) {
      const int bj = check->evaluated_joints()[k];
      const blob::JointConfig& c = r.config.joints[bj];
      joints[r.joint_names[k]] = {{"ap_before", r.ap_before[k] ? nlohmann::json(*r.ap_before[k]) : nlohmann::json(nullptr)},
                                  {"ap_after", r.ap_after[k] ? nlohmann::json(*r.ap_after[k]) : nlohmann::json(nullptr)},
                                  {"bandwidth_mm", c.bandwidth_mm},
                                  {"push_back_mm", c.push_back_mm},
                                  {"prob_threshold", c.prob_threshold_q15 / 32768.0},
                                  {"vote_length_mm", c.vote_length_mm}};
    }
    j["joints"] = joints;
    j["nsub"] = r.config.max_votes_per_joint;
    write_file_atomic(a.get("--json"), j.dump(2) + "\n");
  }
  check_output_stream();
  return 0;
}

DP_REGISTER_COMMAND(tune, "tune", "learn runtime hyper-parameters by grid search on a validation set", run_tune);

}  // namespace dp::tools
