#include "tools/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace dp::tools {

int64_t ConfusionMatrix::row_total(int truth) const {
  int64_t s = 0;
  for (int p = 0; p < classes_; ++p) s += count(truth, p);
  return s;
}

double ConfusionMatrix::row_normalized(int truth, int predicted) const {
  const int64_t total = row_total(truth);
  return total > 0 ? double(count(truth, predicted)) / double(total) : 0.0;
}

std::optional<double> ConfusionMatrix::class_accuracy() const {
  double sum = 0;
  int rows = 0;
  for (int c = 0; c < classes_; ++c) {
    if (row_total(c) == 0) continue;
    sum += row_normalized(c, c);
    ++rows;
  }
  if (rows == 0) return std::nullopt;
  return sum / rows;
}

void ConfusionMatrix::merge(const ConfusionMatrix& other) {
  for (size_t i = 0; i < counts_.size() && i < other.counts_.size(); ++i) counts_[i] += other.counts_[i];
}

float distance(const Point3& a, const Point3& b) {
  const float dx = a.x - b.x, dy = a.y - b.y, dz = a.z - b.z;
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

JointMatches match_joint(const JointSamples& s, const MatchOptions& o) {
  JointMatches m;
  std::vector<size_t> order;
  for (size_t f = 0; f < s.truth.size(); ++f) {
    const JointSamples::Truth& t = s.truth[f];
    const bool counts = t.visible || o.penalize_occluded;
    if (counts) ++m.positives;
    if (f >= s.proposals.size()) continue;
    const std::vector<ScoredPoint>& props = s.proposals[f];
    order.resize(props.size());
    std::iota(order.begin(), order.end(), size_t(0));
    // Most confident first; equal confidences keep the runtime's order.
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return props[a].confidence > props[b].confidence; });
    bool matched = false;
    for (size_t k : order) {
      RankedDetection d{props[k].confidence, MatchLabel::kFalsePositive};
      if (!matched && distance(props[k].position, t.position) <= o.d_tp) {
        matched = true;
        d.label = counts ? MatchLabel::kTruePositive : MatchLabel::kIgnored;
      }
      m.detections.push_back(d);
    }
  }
  return m;
}

PrCurve pr_curve(const JointMatches& m) {
  std::vector<RankedDetection> d;
  for (const RankedDetection& r : m.detections)
    if (r.label != MatchLabel::kIgnored) d.push_back(r);
  std::stable_sort(d.begin(), d.end(), [](const RankedDetection& a, const RankedDetection& b) {
    return a.confidence > b.confidence;
  });
  PrCurve c;
  int64_t tp = 0, fp = 0;
  for (size_t i = 0; i < d.size(); ++i) {
    (d[i].label == MatchLabel::kTruePositive ? tp : fp) += 1;
    if (i + 1 < d.size() && d[i + 1].confidence == d[i].confidence) continue;  // same threshold
    c.threshold.push_back(d[i].confidence);
    c.recall.push_back(m.positives > 0 ? float(double(tp) / double(m.positives)) : 0.0f);
    c.precision.push_back(float(double(tp) / double(tp + fp)));
  }
  return c;
}

std::optional<double> average_precision(const JointMatches& m) {
  if (m.positives == 0) return std::nullopt;
  const PrCurve c = pr_curve(m);
  const size_t n = c.recall.size();
  std::vector<double> envelope(n);
  double best = 0;
  for (size_t k = n; k-- > 0;) envelope[k] = best = std::max(best, double(c.precision[k]));
  double ap = 0, previous_recall = 0;
  for (size_t k = 0; k < n; ++k) {
    ap += (double(c.recall[k]) - previous_recall) * envelope[k];
    previous_recall = c.recall[k];
  }
  return ap;
}

std::optional<double> mean_average_precision(const std::vector<std::optional<double>>& per_joint) {
  double sum = 0;
  int n = 0;
  for (const auto& ap : per_joint)
    if (ap) {
      sum += *ap;
      ++n;
    }
  if (n == 0) return std::nullopt;
  return sum / n;
}

Point3 project_to_pixels(const Point3& p, double fx, double fy, double cx, double cy) {
  if (!(p.z > 0.0f)) return Point3{1e9f, 1e9f, 0.0f};
  return Point3{float(cx + fx * p.x / p.z), float(cy - fy * p.y / p.z), 0.0f};
}

}  // namespace dp::tools
