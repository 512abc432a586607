// Runs a blob, exactly as deployed (dp::Pipeline), over a dataset in layout v1 and measures it with
// the paper's metrics (tools/eval/metrics.h). Shared by `depthpose eval` and `depthpose tune`.
// Errors (unreadable blob or dataset, mismatched names, runtime refusals) throw ToolError.
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "platform/arena_memory.h"
#include "runtime/depthpose.h"
#include "tools/common/budget_options.h"
#include "tools/common/dataset.h"
#include "tools/eval/metrics.h"

namespace dp::tools {

using NameMap = std::vector<std::pair<std::string, std::string>>;  // dataset name → blob name
// Parses "a=b,c=d", or "@FILE" holding such pairs separated by commas, spaces or newlines
// (ToolError naming `option` when a piece has no '=' or the file is unreadable).
NameMap parse_name_map(const std::string& text, const std::string& option);

struct EvalOptions {
  double d_tp_m = 0.1;              // true-positive radius in metres (depth mode)
  double d_tp_px = 10.0;            // true-positive radius in pixels (silhouette mode)
  bool penalize_occluded = false;   // invisible joints count as positives
  bool silhouette = false;          // foreground flattened to kSilhouetteDepthMm, D_tp in pixels
  long max_frames = 0;              // evaluate the first N frames (0 = all)
  KernelIsa kernel = KernelIsa::kBest;
  NameMap joint_map, part_map;      // given ⇒ unmatched names are skipped instead of refused
  int overlay_frames = 4;           // frames kept for example overlays
  BudgetOverrides budget;           // --pixel-budget / --cycle-budget over the blob's config
};
constexpr uint16_t kSilhouetteDepthMm = 2000;

// One frame kept for overlays; positions in pixels (u, v, 0).
struct OverlayFrame {
  std::string id;
  int width = 0, height = 0;
  std::vector<uint16_t> depth_mm;         // as given to the runtime
  std::vector<int16_t> part;              // per pixel: predicted blob part (BPC) or ground-truth
                                          // dataset label (OJR), −1 = none
  bool part_is_prediction = false;
  std::vector<std::vector<ScoredPoint>> proposals;  // per evaluated joint
  std::vector<JointSamples::Truth> truth;           // per evaluated joint
};

// Joint accuracy over one group of frames (a motion category or a mocap subject).
struct GroupAccuracy {
  std::string name;                      // "martial arts", "135", "(none)" for frames without the key
  long frames = 0;
  std::vector<std::optional<double>> ap; // per evaluated joint at d_tp
  std::optional<double> mean_ap;
};

// Per-group AP at `options`: frames are grouped by group_of_frame[f] (one entry per frame of
// `samples`), groups sorted by name. Each group is matched on its own frames only, so a group's
// AP is what `eval` reports for a dataset holding just those frames.
std::vector<GroupAccuracy> accuracy_by_group(const std::vector<JointSamples>& samples,
                                             const std::vector<std::string>& group_of_frame,
                                             const MatchOptions& options);

// The frame groups a dataset's frames.jsonl records carry (synth writes "clip" and "category"):
// category = the "category" key, subject = the "clip" key up to its '_' ("135_04" → "135").
// Frames without the key are "(none)"; an empty vector when no frame has it.
enum class FrameGroupKey { kCategory, kSubject };
std::vector<std::string> frame_groups(const Dataset& dataset, long frames, FrameGroupKey key);

struct EvalReport {
  std::string method;                    // "BPC" or "OJR"
  long frames = 0;
  bool silhouette = false, penalize_occluded = false;
  double d_tp = 0.1;                     // in d_tp_unit
  std::string d_tp_unit = "m";
  std::vector<std::string> joint_names;  // evaluated joints (blob names)
  std::vector<std::optional<double>> ap; // per evaluated joint at d_tp
  std::optional<double> mean_ap;
  std::vector<PrCurve> curves;           // per evaluated joint at d_tp
  std::vector<int64_t> positives;        // per evaluated joint
  std::vector<double> dtp_grid;          // AP against D_tp (same unit as d_tp)
  std::vector<std::vector<std::optional<double>>> ap_vs_dtp;  // [grid][joint]
  std::vector<std::optional<double>> map_vs_dtp;
  // At d_tp, per motion category and per mocap subject of the frames (frame_groups); empty when the
  // dataset's frames do not say.
  std::vector<GroupAccuracy> by_category, by_subject;
  // BPC with a labelled dataset: ground truth (blob part order) against the most likely part.
  bool has_confusion = false;
  std::vector<std::string> part_names;
  ConfusionMatrix confusion;
  std::optional<double> class_accuracy;
  // Speed of Pipeline::process alone (no PNG decoding), wall clock.
  double fps = 0, ms_per_frame = 0;
  std::array<double, kStageCount> stage_ms{};  // mean per frame
  std::string kernel;
  double mean_evaluated_pixels = 0;
  std::string budget;                    // the overrides in force ("" = the blob's config)
  std::array<long, kFrameFlagBits> flag_frames{};  // frames with each FrameFlag bit
  std::vector<OverlayFrame> overlays;
};

// Forest output of one frame, cached so tune re-runs only votes and mean shift.
struct CachedFrame {
  CameraIntrinsics intrinsics{};
  std::vector<EvaluatedPixel> pixels;
  std::vector<uint32_t> leaves;  // tree-major, pixels.size() per tree
};

class EvalSession {
 public:
  // Validates the blob bytes, opens the dataset and matches names (ToolError on mismatch).
  EvalSession(std::vector<uint8_t> blob_bytes, std::string blob_label, const std::string& dataset_dir,
              const EvalOptions& options);
  ~EvalSession();
  EvalSession(const EvalSession&) = delete;
  EvalSession& operator=(const EvalSession&) = delete;

  const blob::LoadedBlob& blob() const { return blob_; }
  const Dataset& dataset() const { return dataset_; }
  long frame_count() const { return frame_count_; }
  const std::vector<int>& evaluated_joints() const { return eval_joints_; }  // blob joint indices

  // Runs the blob with `config` (the blob's own when null) over every frame.
  EvalReport evaluate(const blob::RuntimeConfig* config = nullptr);

  // Runs the forest once per frame and keeps its output.
  std::vector<CachedFrame> cache_forest();
  // Votes + mean shift on cached frames with `config`; per evaluated joint, AP at the session's
  // D_tp. `threads` pipelines share the frames.
  std::vector<std::optional<double>> joint_ap_from_cache(const std::vector<CachedFrame>& cache,
                                                          const blob::RuntimeConfig& config, int threads);

 private:
  struct PreparedFrame;
  PreparedFrame prepare(long index) const;
  JointSamples::Truth truth_of(long frame, int eval_joint) const;
  ScoredPoint to_metric_space(const JointProposal& p) const;
  std::vector<JointSamples> empty_samples() const;
  void collect(long frame, const FrameResult& r, std::vector<JointSamples>& samples) const;
  MatchOptions match_options(double d_tp) const;

  std::vector<uint8_t> bytes_;
  std::string blob_label_;
  blob::LoadedBlob blob_{};
  Dataset dataset_;
  EvalOptions options_;
  long frame_count_ = 0;
  std::vector<int> eval_joints_;         // blob joint index per evaluated joint
  std::vector<int> dataset_joint_;       // dataset joint index per evaluated joint
  std::vector<int> blob_part_of_label_;  // dataset label → blob part (−1: not scored)
  platform::ArenaMemory arena_;
  size_t arena_bytes_ = 0;
  Pipeline pipeline_;
};

// Loads the blob file (checked) and builds a session.
std::unique_ptr<EvalSession> open_eval_session(const std::string& blob_path, const std::string& dataset_dir,
                                               const EvalOptions& options);

}  // namespace dp::tools
