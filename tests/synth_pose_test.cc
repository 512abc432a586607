// Pose pruning (furthest-neighbour selection) on points with a known answer, and MakeHuman's
// macro-target weighting.
#include <gtest/gtest.h>

#include <cmath>

#include "tools/synth/posing.h"

namespace dp::synth {
namespace {

JointSet at(double x, double y = 0, double z = 0) {
  JointSet j;
  for (auto& p : j) p = {x, y, z};
  return j;
}

TEST(SynthPosePruning, DistanceIsMaxOverJoints) {
  JointSet a = at(0), b = at(0);
  b[5] = {0.03, 0.04, 0};  // 5 cm at one joint
  b[9] = {0.01, 0, 0};
  EXPECT_DOUBLE_EQ(pose_distance(a, b), 0.05);
  EXPECT_DOUBLE_EQ(pose_distance(b, a), 0.05);
  EXPECT_DOUBLE_EQ(pose_distance(a, a), 0.0);
}

TEST(SynthPosePruning, ThreeTightClustersKeepOnePoseEach) {
  std::vector<JointSet> items;
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < 10; ++i) items.push_back(at(c * 1.0 + i * 0.002, i * 0.001));
  std::vector<size_t> kept = furthest_neighbour_selection(items, 0.05);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_EQ(kept[0], 0u);                 // starts from the first item
  EXPECT_EQ(kept[1] / 10, 2u);            // then the farthest cluster
  EXPECT_EQ(kept[1], 29u);                // ... its farthest member from item 0
  EXPECT_EQ(kept[2] / 10, 1u);
}

TEST(SynthPosePruning, LineOfPointsKnownSelection) {
  // 11 points at 0, 0.1, ..., 1.0 m. At D = 0.05 every point stays (all 0.1 apart); at D = 0.3
  // the selection is 0, 1.0, 0.5, then 0.2 (or 0.3), 0.7 (or 0.8)... stopping when the farthest
  // remaining point is < 0.3 from the selection: 0, 1.0, 0.5 leaves max distance 0.2 -> 3 kept.
  std::vector<JointSet> items;
  for (int i = 0; i <= 10; ++i) items.push_back(at(i * 0.1));
  EXPECT_EQ(furthest_neighbour_selection(items, 0.05).size(), 11u);
  std::vector<size_t> kept = furthest_neighbour_selection(items, 0.3);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_EQ(kept[0], 0u);
  EXPECT_EQ(kept[1], 10u);
  EXPECT_EQ(kept[2], 5u);
  // D = 0.25: after {0, 1, 0.5} the farthest is 0.2 < 0.25, still 3; D = 0.15 adds more.
  EXPECT_EQ(furthest_neighbour_selection(items, 0.25).size(), 3u);
  EXPECT_GE(furthest_neighbour_selection(items, 0.15).size(), 4u);
}

TEST(SynthPosePruning, CoverageAndSeparationOnRandomPoints) {
  std::vector<JointSet> items;
  uint64_t s = 12345;
  auto rnd = [&]() {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return double(s >> 11) / double(1ull << 53);
  };
  for (int i = 0; i < 400; ++i) {
    JointSet j;
    for (auto& p : j) p = {rnd() * 0.3, rnd() * 0.3, rnd() * 0.3};
    items.push_back(j);
  }
  const double d = 0.25;
  std::vector<size_t> kept = furthest_neighbour_selection(items, d);
  ASSERT_GT(kept.size(), 1u);
  ASSERT_LT(kept.size(), items.size());
  for (size_t i = 0; i < kept.size(); ++i)
    for (size_t j = i + 1; j < kept.size(); ++j) EXPECT_GE(pose_distance(items[kept[i]], items[kept[j]]), d);
  for (const JointSet& it : items) {
    double nearest = 1e9;
    for (size_t k : kept) nearest = std::min(nearest, pose_distance(it, items[k]));
    EXPECT_LT(nearest, d);
  }
}

TEST(SynthShape, MacroWeightsFollowMakeHumanRules) {
  HumanAssets a;  // names only: weights are computed for targets that exist
  for (const char* n : {"universal-female-young-averagemuscle-averageweight", "universal-male-young-averagemuscle-averageweight",
                        "universal-male-young-maxmuscle-averageweight", "universal-male-old-averagemuscle-averageweight",
                        "universal-male-child-averagemuscle-averageweight", "height/male-young-averagemuscle-averageweight-maxheight",
                        "african-male-young", "asian-male-young", "caucasian-male-young"}) {
    ShapeTarget t;
    t.name = n;
    a.targets.push_back(t);
  }
  auto weight_of = [&](const ShapeControls& c, const std::string& name) {
    double w = 0;
    for (auto& [t, tw] : target_weights(a, c))
      if (t->name == name) w += tw;
    return w;
  };
  ShapeControls c;
  c.gender = 1.0;
  c.age = 0.5;
  c.african = 1;
  c.asian = c.caucasian = 0;
  EXPECT_NEAR(weight_of(c, "universal-male-young-averagemuscle-averageweight"), 1.0, 1e-6);
  EXPECT_NEAR(weight_of(c, "universal-female-young-averagemuscle-averageweight"), 0.0, 1e-6);
  EXPECT_NEAR(weight_of(c, "african-male-young"), 1.0, 1e-6);
  EXPECT_NEAR(weight_of(c, "asian-male-young"), 0.0, 1e-6);
  c.muscle = 0.75;  // halfway from average to max
  EXPECT_NEAR(weight_of(c, "universal-male-young-maxmuscle-averageweight"), 0.5, 1e-6);
  EXPECT_NEAR(weight_of(c, "universal-male-young-averagemuscle-averageweight"), 0.5, 1e-6);
  c.muscle = 0.5;
  c.age = 0.75;  // halfway from 25 to 90 years
  EXPECT_NEAR(weight_of(c, "universal-male-old-averagemuscle-averageweight"), 0.5, 1e-6);
  c.age = 0.1875;  // 11 years: pure child
  EXPECT_NEAR(weight_of(c, "universal-male-child-averagemuscle-averageweight"), 1.0, 1e-4);
  c.age = 0.5;
  c.height = 1.0;  // max height target at full weight, times the other factors
  EXPECT_NEAR(weight_of(c, "height/male-young-averagemuscle-averageweight-maxheight"), 1.0, 1e-6);
  c.height = 0.5;
  EXPECT_NEAR(weight_of(c, "height/male-young-averagemuscle-averageweight-maxheight"), 0.0, 1e-6);
}

}  // namespace
}  // namespace dp::synth
