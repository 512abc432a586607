// The paper's metrics (tools/eval/metrics.h) against hand-computed examples.
#include <gtest/gtest.h>

#include "tools/eval/metrics.h"

using namespace dp::tools;

namespace {

// One frame per proposal: each frame's truth at the origin, its proposal at distance `d`.
JointSamples one_proposal_per_frame(const std::vector<std::pair<float, float>>& confidence_and_distance) {
  JointSamples s;
  for (auto [conf, d] : confidence_and_distance) {
    s.truth.push_back({Point3{0, 0, 0}, true});
    s.proposals.push_back({ScoredPoint{Point3{d, 0, 0}, conf}});
  }
  return s;
}

}  // namespace

TEST(EvalMetrics, ConfusionMatrixMeanDiagonalSkipsEmptyRows) {
  ConfusionMatrix m(3);
  m.add(0, 0, 8);
  m.add(0, 1, 2);
  m.add(1, 0, 1);
  m.add(1, 1, 1);
  m.add(1, 2, 2);
  // Row 0: 8/10 = 0.8; row 1: 1/4 = 0.25; row 2 has no ground truth and is left out.
  ASSERT_TRUE(m.class_accuracy().has_value());
  EXPECT_NEAR(*m.class_accuracy(), (0.8 + 0.25) / 2, 1e-12);
  EXPECT_NEAR(m.row_normalized(1, 2), 0.5, 1e-12);
  EXPECT_EQ(m.row_total(2), 0);
  EXPECT_FALSE(ConfusionMatrix(4).class_accuracy().has_value());
}

TEST(EvalMetrics, ConfusionWeightsClassesEquallyNotByPixels) {
  ConfusionMatrix m(2);
  m.add(0, 0, 1000);  // a large, perfectly recognised part
  m.add(1, 0, 10);    // a small part always mistaken
  EXPECT_NEAR(*m.class_accuracy(), 0.5, 1e-12);
}

TEST(EvalMetrics, AveragePrecisionOfAKnownRanking) {
  // Ranked: TP, FP, TP, FP, TP with 3 positives. Curve points (r, p): (1/3, 1), (1/3, 1/2),
  // (2/3, 2/3), (2/3, 1/2), (1, 3/5). Envelope at the recall steps: 1, 2/3, 3/5.
  // AP = 1/3·1 + 1/3·2/3 + 1/3·3/5 = 0.755555...
  const JointSamples s = one_proposal_per_frame({{0.9f, 0.01f}, {0.8f, 0.5f}, {0.7f, 0.02f}, {0.6f, 0.3f}, {0.5f, 0.05f}});
  const JointMatches m = match_joint(s, MatchOptions{0.1f, false});
  EXPECT_EQ(m.positives, 5);  // five frames, each with a visible joint: two are never found
  // The same ranking with exactly 3 positives (every true positive found).
  JointMatches hand;
  hand.positives = 3;
  for (auto [c, tp] : std::vector<std::pair<float, bool>>{{0.9f, true}, {0.8f, false}, {0.7f, true}, {0.6f, false}, {0.5f, true}})
    hand.detections.push_back({c, tp ? MatchLabel::kTruePositive : MatchLabel::kFalsePositive});
  ASSERT_TRUE(average_precision(hand).has_value());
  EXPECT_NEAR(*average_precision(hand), (1.0 + 2.0 / 3.0 + 0.6) / 3.0, 1e-6);
  // Five positives, TPs at ranks 1, 3, 5: AP = 1/5·1 + 1/5·2/3 + 1/5·3/5.
  EXPECT_NEAR(*average_precision(m), (1.0 + 2.0 / 3.0 + 0.6) / 5.0, 1e-6);
  const PrCurve c = pr_curve(hand);
  ASSERT_EQ(c.recall.size(), 5u);
  EXPECT_NEAR(c.precision[3], 0.5, 1e-6);
  EXPECT_NEAR(c.recall[4], 1.0, 1e-6);
}

TEST(EvalMetrics, OnlyTheMostConfidentNearbyProposalIsATruePositive) {
  JointSamples s;
  s.truth.push_back({Point3{0, 0, 0}, true});
  // Three proposals within D_tp and one far away, in scrambled order.
  s.proposals.push_back({ScoredPoint{{0.05f, 0, 0}, 2.0f}, ScoredPoint{{0.0f, 0.02f, 0}, 5.0f},
                         ScoredPoint{{1.0f, 0, 0}, 9.0f}, ScoredPoint{{0, 0, 0.01f}, 1.0f}});
  const JointMatches m = match_joint(s, MatchOptions{0.1f, false});
  ASSERT_EQ(m.detections.size(), 4u);
  int tp = 0;
  for (const RankedDetection& d : m.detections) {
    if (d.label == MatchLabel::kTruePositive) {
      ++tp;
      EXPECT_EQ(d.confidence, 5.0f);  // the most confident one within D_tp
    }
  }
  EXPECT_EQ(tp, 1);
  // Ranking: FP(9), TP(5), FP(2), FP(1): points (0, 0), (1, 1/2), ...: AP = 1 · 1/2.
  EXPECT_NEAR(*average_precision(m), 0.5, 1e-6);
}

TEST(EvalMetrics, PerfectAndHopelessProposals) {
  EXPECT_NEAR(*average_precision(match_joint(one_proposal_per_frame({{1, 0.0f}, {2, 0.09f}}), {0.1f, false})), 1.0, 1e-9);
  EXPECT_NEAR(*average_precision(match_joint(one_proposal_per_frame({{1, 0.2f}, {2, 0.11f}}), {0.1f, false})), 0.0, 1e-9);
  // Widening D_tp turns them into true positives.
  EXPECT_NEAR(*average_precision(match_joint(one_proposal_per_frame({{1, 0.2f}, {2, 0.11f}}), {0.2f, false})), 1.0, 1e-9);
  // No proposal at all: every joint is a false negative.
  JointSamples none;
  none.truth.push_back({Point3{}, true});
  none.proposals.push_back({});
  EXPECT_NEAR(*average_precision(match_joint(none, {0.1f, false})), 0.0, 1e-9);
}

TEST(EvalMetrics, TiedConfidencesEnterTheCurveTogether) {
  JointMatches m;
  m.positives = 2;
  m.detections = {{1.0f, MatchLabel::kFalsePositive}, {1.0f, MatchLabel::kTruePositive}, {0.5f, MatchLabel::kTruePositive}};
  const PrCurve c = pr_curve(m);
  ASSERT_EQ(c.recall.size(), 2u);  // one point per distinct threshold
  EXPECT_NEAR(c.precision[0], 0.5, 1e-6);
  // Envelope: 2/3 at both steps: AP = 1/2·2/3 + 1/2·2/3.
  EXPECT_NEAR(*average_precision(m), 2.0 / 3.0, 1e-6);
}

TEST(EvalMetrics, OccludedJointSwitch) {
  // Frame 0: visible joint found. Frame 1: invisible joint, missed. Frame 2: invisible joint found.
  JointSamples s;
  s.truth = {{Point3{0, 0, 0}, true}, {Point3{0, 0, 0}, false}, {Point3{0, 0, 0}, false}};
  s.proposals = {{ScoredPoint{{0, 0, 0}, 3.0f}}, {ScoredPoint{{1, 0, 0}, 2.0f}}, {ScoredPoint{{0, 0, 0}, 1.0f}}};
  // Default: invisible joints are not positives; the proposal on frame 2 is ignored, the far one on
  // frame 1 is still a false positive. Ranking TP(3), FP(2): AP = 1 · 1.
  const JointMatches lenient = match_joint(s, MatchOptions{0.1f, false});
  EXPECT_EQ(lenient.positives, 1);
  EXPECT_EQ(lenient.detections[2].label, MatchLabel::kIgnored);
  EXPECT_NEAR(*average_precision(lenient), 1.0, 1e-6);
  // Penalized: 3 positives; ranking TP(3), FP(2), TP(1): AP = 1/3·1 + 1/3·2/3.
  const JointMatches strict = match_joint(s, MatchOptions{0.1f, true});
  EXPECT_EQ(strict.positives, 3);
  EXPECT_NEAR(*average_precision(strict), 1.0 / 3.0 + 2.0 / 9.0, 1e-6);
  // A joint never visible has no AP unless penalized.
  JointSamples hidden;
  hidden.truth = {{Point3{}, false}};
  hidden.proposals = {{}};
  EXPECT_FALSE(average_precision(match_joint(hidden, {0.1f, false})).has_value());
  EXPECT_NEAR(*average_precision(match_joint(hidden, {0.1f, true})), 0.0, 1e-9);
}

TEST(EvalMetrics, SilhouetteSwitchMeasuresInPixels) {
  // A proposal on the right ray but at the wrong depth (2 m instead of 1 m): far away in 3D, on the
  // same pixel in the image.
  const double fx = 525, fy = 525, cx = 319.5, cy = 239.5;
  const Point3 truth{0.1f, -0.05f, 1.0f};
  const Point3 proposal{0.2f, -0.1f, 2.0f};
  JointSamples metric;
  metric.truth = {{truth, true}};
  metric.proposals = {{ScoredPoint{proposal, 1.0f}}};
  EXPECT_NEAR(*average_precision(match_joint(metric, {0.1f, false})), 0.0, 1e-9);
  JointSamples pixels;
  pixels.truth = {{project_to_pixels(truth, fx, fy, cx, cy), true}};
  pixels.proposals = {{ScoredPoint{project_to_pixels(proposal, fx, fy, cx, cy), 1.0f}}};
  EXPECT_NEAR(pixels.truth[0].position.x, 319.5 + 52.5, 1e-3);
  EXPECT_NEAR(pixels.truth[0].position.y, 239.5 + 26.25, 1e-3);
  EXPECT_NEAR(*average_precision(match_joint(pixels, {10.0f, false})), 1.0, 1e-9);
  // 12 pixels off: outside D_tp = 10 px, inside 15 px.
  pixels.proposals[0][0].position.x += 12.0f;
  EXPECT_NEAR(*average_precision(match_joint(pixels, {10.0f, false})), 0.0, 1e-9);
  EXPECT_NEAR(*average_precision(match_joint(pixels, {15.0f, false})), 1.0, 1e-9);
}

TEST(EvalMetrics, MeanApSkipsUndefinedJoints) {
  EXPECT_NEAR(*mean_average_precision({1.0, std::nullopt, 0.5}), 0.75, 1e-12);
  EXPECT_FALSE(mean_average_precision({std::nullopt}).has_value());
}
