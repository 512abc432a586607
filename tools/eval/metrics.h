// The paper's accuracy metrics (Shotton et al., PAMI 2012, section 4.2), independent of the runtime:
// per-class segmentation accuracy from a confusion matrix, and per-joint average precision of
// confidence-ranked joint proposals. docs/evaluation.md states the protocol in full.
#pragma once
#include <cstdint>
#include <optional>
#include <vector>

namespace dp::tools {

// Counts of (ground-truth class, predicted class) pairs over evaluated pixels.
class ConfusionMatrix {
 public:
  explicit ConfusionMatrix(int classes = 0) : classes_(classes), counts_(size_t(classes) * classes, 0) {}
  int classes() const { return classes_; }
  void add(int truth, int predicted, int64_t n = 1) { counts_[size_t(truth) * classes_ + predicted] += n; }
  int64_t count(int truth, int predicted) const { return counts_[size_t(truth) * classes_ + predicted]; }
  int64_t row_total(int truth) const;
  // count / row_total, 0 for empty rows.
  double row_normalized(int truth, int predicted) const;
  // Mean of the diagonal of the row-normalized matrix over the classes that occur in the ground
  // truth (empty rows are left out: a part absent from the test set has no accuracy). nullopt when
  // no class occurs.
  std::optional<double> class_accuracy() const;
  void merge(const ConfusionMatrix& other);

 private:
  int classes_;
  std::vector<int64_t> counts_;
};

// A position in the space where distances are measured: metres (camera frame) for depth, or
// pixels (u, v, 0) in silhouette mode.
struct Point3 {
  float x = 0, y = 0, z = 0;
};
float distance(const Point3& a, const Point3& b);

struct ScoredPoint {
  Point3 position;
  float confidence = 0;
};

// One joint over a test set: frame f has ground truth truth[f] and proposals proposals[f].
struct JointSamples {
  struct Truth {
    Point3 position;
    bool visible = true;
  };
  std::vector<Truth> truth;
  std::vector<std::vector<ScoredPoint>> proposals;
};

struct MatchOptions {
  float d_tp = 0.1f;               // true-positive radius, in the units of the positions
  bool penalize_occluded = false;  // count invisible joints as positives (FN when missed)
};

enum class MatchLabel : uint8_t { kTruePositive, kFalsePositive, kIgnored };
struct RankedDetection {
  float confidence = 0;
  MatchLabel label = MatchLabel::kFalsePositive;
};
struct JointMatches {
  std::vector<RankedDetection> detections;  // every proposal of the test set, labelled
  int64_t positives = 0;                    // ground-truth joints that count (recall denominator)
};

// Labels every proposal (section 4.2): in each frame the most confident proposal within d_tp of
// the ground truth is a true positive, every other proposal is a false positive. An invisible
// joint is not a positive unless penalize_occluded; its first proposal within d_tp is then
// neither TP nor FP (ignored, as PASCAL VOC treats "difficult" objects) — others are still FP.
JointMatches match_joint(const JointSamples& samples, const MatchOptions& options);

// Recall–precision curve: one point per distinct confidence threshold, thresholds decreasing
// (proposals with equal confidence enter together). Ignored detections are left out.
struct PrCurve {
  std::vector<float> threshold, recall, precision;
};
PrCurve pr_curve(const JointMatches& matches);

// Area under the recall–precision curve with all-point interpolation (PASCAL VOC 2010+):
// AP = Σ_k (r_k − r_{k−1}) · max_{k' ≥ k} p_{k'}, r_0 = 0. nullopt when there are no positives;
// 0 when there are positives but no true positive.
std::optional<double> average_precision(const JointMatches& matches);

// Mean of the defined per-joint APs; nullopt when none is defined.
std::optional<double> mean_average_precision(const std::vector<std::optional<double>>& per_joint);

// Image position of a camera-frame point (x right, y up): u = cx + fx·x/z, v = cy − fy·y/z.
// Points with z ≤ 0 project far outside the image (never within any pixel radius).
Point3 project_to_pixels(const Point3& metres, double fx, double fy, double cx, double cy);

}  // namespace dp::tools
