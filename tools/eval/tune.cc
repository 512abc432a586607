#include "tools/eval/tune.h"

#include <chrono>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <functional>
#include <thread>

#include "tools/common/error.h"

namespace dp::tools {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::string ap_str(const std::optional<double>& v) {
  char b[16];
  std::snprintf(b, sizeof b, "%.4f", v.value_or(std::nan("")));
  return v ? b : "n/a";
}

struct Search {
  EvalSession& session;
  const TuneOptions& options;
  const std::vector<CachedFrame>& cache;
  int threads;
  TuneResult& result;
  blob::RuntimeConfig config;
  std::vector<std::optional<double>> ap;  // per evaluated joint, for `config`

  std::vector<std::optional<double>> measure(const blob::RuntimeConfig& c) {
    ++result.grid_points;
    return session.joint_ap_from_cache(cache, c, threads);
  }

  // Tries every value of a per-joint parameter; each joint keeps a value only if its AP rises.
  template <typename T>
  void per_joint(const std::string& name, const std::vector<T>& grid,
                 const std::function<void(blob::JointConfig&, T)>& set, const std::function<double(const blob::JointConfig&)>& show) {
    const std::vector<int>& joints = session.evaluated_joints();
    blob::RuntimeConfig best_config = config;
    std::vector<std::optional<double>> best_ap = ap;
    for (const T& v : grid) {
      blob::RuntimeConfig trial = config;
      for (int j : joints) set(trial.joints[j], v);
      const std::vector<std::optional<double>> trial_ap = measure(trial);
      if (options.verbose) {
        char b[96];
        std::snprintf(b, sizeof b, "  %s = %g: mAP %s", name.c_str(), double(v), ap_str(mean_average_precision(trial_ap)).c_str());
        result.log.push_back(b);
      }
      for (size_t k = 0; k < joints.size(); ++k) {
        if (!trial_ap[k] || (best_ap[k] && *trial_ap[k] <= *best_ap[k] + 1e-12)) continue;
        best_ap[k] = trial_ap[k];
        best_config.joints[joints[k]] = trial.joints[joints[k]];
      }
    }
    // Joints are independent in the runtime, so the combination scores best_ap; measuring it keeps
    // the reported figures exact, and a step that would lower the mAP is not taken.
    const std::vector<std::optional<double>> combined = measure(best_config);
    if (mean_average_precision(combined).value_or(-1) + 1e-12 >= mean_average_precision(ap).value_or(-1)) {
      config = best_config;
      ap = combined;
    }
    std::string values;
    for (int j : joints) {
      char b[32];
      std::snprintf(b, sizeof b, "%s%g", values.empty() ? "" : " ", show(config.joints[j]));
      values += b;
    }
    result.log.push_back(name + " per joint: " + values + " -> mAP " + ap_str(mean_average_precision(ap)));
  }

  void nsub() {
    std::vector<std::pair<int, std::vector<std::optional<double>>>> tried;
    tried.emplace_back(config.max_votes_per_joint, ap);
    for (int n : options.grids.nsub) {
      if (n < 1 || n > blob::kMaxVotesCap || n == config.max_votes_per_joint) continue;
      blob::RuntimeConfig trial = config;
      trial.max_votes_per_joint = uint16_t(n);
      tried.emplace_back(n, measure(trial));
      if (options.verbose)
        result.log.push_back("  Nsub = " + std::to_string(n) + ": mAP " + ap_str(mean_average_precision(tried.back().second)));
    }
    double best = -1;
    for (const auto& [n, a] : tried) best = std::max(best, mean_average_precision(a).value_or(-1));
    const double floor = best - options.nsub_tolerance - 1e-12;
    auto qualifies = [&](size_t i) { return mean_average_precision(tried[i].second).value_or(-1) >= floor; };
    // Without a tolerance the current value wins ties; otherwise the smallest qualifying Nsub.
    size_t pick = 0;
    if (options.nsub_tolerance > 0 || !qualifies(0)) {
      pick = tried.size();
      for (size_t i = 0; i < tried.size(); ++i)
        if (qualifies(i) && (pick == tried.size() || tried[i].first < tried[pick].first)) pick = i;
    }
    config.max_votes_per_joint = uint16_t(tried[pick].first);
    ap = tried[pick].second;
    result.log.push_back("Nsub: " + std::to_string(config.max_votes_per_joint) + " -> mAP " +
                         ap_str(mean_average_precision(ap)));
  }
};

}  // namespace

TuneResult tune_runtime_config(EvalSession& session, const TuneOptions& options) {
  if (session.evaluated_joints().empty()) fail("tune: no joint of the blob is in the validation set: nothing to maximize");
  TuneResult result;
  result.frames = session.frame_count();
  const blob::LoadedBlob& b = session.blob();
  for (int j : session.evaluated_joints())
    result.joint_names.emplace_back(b.meta->joint_names[j], strnlen(b.meta->joint_names[j], blob::kNameBytes));
  const int threads = options.threads > 0 ? options.threads : std::max(1, int(std::thread::hardware_concurrency()));

  auto t0 = Clock::now();
  const std::vector<CachedFrame> cache = session.cache_forest();
  result.cache_seconds = seconds_since(t0);
  t0 = Clock::now();

  Search s{session, options, cache, threads, result, *b.config, {}};
  s.ap = s.measure(s.config);
  result.ap_before = s.ap;
  result.map_before = mean_average_precision(s.ap);
  result.log.push_back("start: mAP " + ap_str(result.map_before));
  const bool bpc = b.method() == blob::Method::kBpc;
  const TuneGrids& g = options.grids;
  for (int pass = 0; pass < options.passes; ++pass) {
    result.log.push_back("pass " + std::to_string(pass + 1));
    if (bpc) {
      s.per_joint<int>("bandwidth_mm", g.bandwidth_mm, [](blob::JointConfig& j, int v) { j.bandwidth_mm = uint16_t(v); },
                       [](const blob::JointConfig& j) { return double(j.bandwidth_mm); });
      s.per_joint<int>("push_back_mm", g.push_back_mm, [](blob::JointConfig& j, int v) { j.push_back_mm = int16_t(v); },
                       [](const blob::JointConfig& j) { return double(j.push_back_mm); });
      s.per_joint<double>(
          "prob_threshold", g.prob_threshold,
          [](blob::JointConfig& j, double v) { j.prob_threshold_q15 = uint16_t(std::lround(v * 32768.0)); },
          [](const blob::JointConfig& j) { return std::round(j.prob_threshold_q15 / 32768.0 * 1000.0) / 1000.0; });
    } else {
      s.per_joint<int>("vote_length_mm", g.vote_length_mm, [](blob::JointConfig& j, int v) { j.vote_length_mm = uint16_t(v); },
                       [](const blob::JointConfig& j) { return double(j.vote_length_mm); });
      s.per_joint<int>("bandwidth_mm", g.bandwidth_mm, [](blob::JointConfig& j, int v) { j.bandwidth_mm = uint16_t(v); },
                       [](const blob::JointConfig& j) { return double(j.bandwidth_mm); });
      if (options.tune_nsub) s.nsub();
    }
  }
  result.config = s.config;
  result.ap_after = s.ap;
  result.map_after = mean_average_precision(s.ap);
  result.search_seconds = seconds_since(t0);
  return result;
}

}  // namespace dp::tools
