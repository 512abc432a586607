// Learning the runtime hyper-parameters by grid search on a validation set (paper section 3.5.3),
// maximizing mAP at the session's D_tp. The forest runs once per frame (EvalSession::cache_forest);
// every grid point re-runs only votes and mean shift (Pipeline::aggregate_from_leaves).
//
// Search: coordinate ascent, `passes` times over the parameters
//   BPC: bandwidth b_j, push-back ζ_j, probability threshold λ_c (per joint)
//   OJR: vote length λ_j, bandwidth b_j (per joint), then Nsub (global)
// A per-joint parameter's grid value v is tried for all joints at once (a joint's proposals depend
// only on its own JointConfig and the global budget), and each joint keeps v only when it raises
// that joint's AP strictly; so no joint's AP, and not the mAP, ever drops below the start.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "forest_blob/blob_format.h"
#include "tools/eval/evaluator.h"

namespace dp::tools {

struct TuneGrids {
  std::vector<int> bandwidth_mm{30, 40, 50, 60, 70, 80, 90, 100};
  std::vector<int> push_back_mm{0, 10, 20, 30, 40, 50, 60, 70, 80};
  std::vector<double> prob_threshold{0.05, 0.10, 0.15, 0.20, 0.25, 0.30};
  std::vector<int> vote_length_mm{50, 100, 150, 200, 250, 300, 350, 400, 450, 500, 550, 600};
  std::vector<int> nsub{25, 50, 100, 200, 400, 800};
};

struct TuneOptions {
  TuneGrids grids;
  int passes = 2;
  int threads = 0;        // 0 = hardware concurrency
  bool tune_nsub = true;  // OJR only
  // Nsub: the smallest value whose mAP is within this of the best (speed/accuracy trade-off;
  // 0 keeps the guarantee that mAP never drops).
  double nsub_tolerance = 0.0;
  bool verbose = false;   // log every grid point
};

struct TuneResult {
  blob::RuntimeConfig config{};
  std::vector<std::string> joint_names;  // evaluated joints
  std::vector<std::optional<double>> ap_before, ap_after;
  std::optional<double> map_before, map_after;
  long frames = 0;
  int grid_points = 0;      // aggregations run
  double cache_seconds = 0, search_seconds = 0;
  std::vector<std::string> log;
};

// Tunes starting from the blob's own config. ToolError when the session has no evaluated joint.
TuneResult tune_runtime_config(EvalSession& session, const TuneOptions& options);

}  // namespace dp::tools
