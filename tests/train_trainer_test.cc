// Tree-structure training: the toy split, the objectives against hand-computed values,
// determinism across thread counts, and agreement of the trainer's pixel routing with the
// runtime's exact feature rule (the reference evaluator).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>

#include "runtime/fixed_point.h"
#include "tests/train_toy_data.h"
#include "tools/train/forest_trainer.h"

namespace dp::train {
namespace {
using testing_toy::TempDir;
using testing_toy::ToyOptions;
using testing_toy::write_toy_dataset;

TEST(TrainObjectives, EntropyMatchesHandComputedValue) {
  // H(3/4, 1/4) = 0.75·ln(4/3) + 0.25·ln 4 = 0.5623351446.
  const uint32_t left[2] = {3, 1}, right[2] = {0, 4};
  EXPECT_NEAR(weighted_entropy(left, 2), 4 * 0.5623351446, 1e-9);
  EXPECT_NEAR(weighted_entropy(right, 2), 0.0, 1e-12);
  EXPECT_NEAR(classification_objective(left, right, 2), 4 * 0.5623351446 / 8, 1e-9);
  // Three balanced classes: H = ln 3.
  const uint32_t even[3] = {5, 5, 5}, none[3] = {0, 0, 0};
  EXPECT_NEAR(classification_objective(even, none, 3), std::log(3.0), 1e-12);
  // Large counts go through the non-table path.
  const uint32_t big[2] = {10000, 30000};
  EXPECT_NEAR(weighted_entropy(big, 2) / 40000, 0.5623351446, 1e-9);
}

TEST(TrainObjectives, RegressionMatchesHandComputedValue) {
  // Joint 0, left: offsets (1,0,0) and (3,0,0): mean (2,0,0), SSD 2.
  // Joint 1, left: (0,1,0), (0,1,0), (0,4,0): mean (0,2,0), SSD 1+1+4 = 6.
  // Joint 0, right: (0,0,2): SSD 0. Joint 1, right: (1,1,1) and (3,3,3): SSD 3+3 = 6.
  auto stats = [](std::initializer_list<std::array<double, 3>> offsets) {
    JointOffsetStats s;
    for (const auto& o : offsets) {
      s.n += 1;
      s.sx += o[0];
      s.sy += o[1];
      s.sz += o[2];
      s.sq += o[0] * o[0] + o[1] * o[1] + o[2] * o[2];
    }
    return s;
  };
  const JointOffsetStats left[2] = {stats({{1, 0, 0}, {3, 0, 0}}), stats({{0, 1, 0}, {0, 1, 0}, {0, 4, 0}})};
  const JointOffsetStats right[2] = {stats({{0, 0, 2}}), stats({{1, 1, 1}, {3, 3, 3}})};
  EXPECT_NEAR(sum_squared_deviation(left, 2), 8.0, 1e-12);
  EXPECT_NEAR(sum_squared_deviation(right, 2), 6.0, 1e-12);
  EXPECT_NEAR(regression_objective(left, right, 2, 3, 2), 14.0 / 5, 1e-12);
  // A joint with no offsets inside ρ contributes nothing.
  const JointOffsetStats empty[1] = {JointOffsetStats{}};
  EXPECT_EQ(sum_squared_deviation(empty, 1), 0.0);
}

SamplingOptions toy_sampling(int trees = 1) {
  SamplingOptions so;
  so.pixels_per_image = 300;
  so.trees = trees;
  so.seed = 7;
  so.threads = 2;
  return so;
}

TreeParams toy_params(int depth) {
  TreeParams p;
  p.max_depth = depth;
  p.offset_candidates = 60;
  p.threshold_candidates = 20;
  p.max_offset_pxm = 120;
  p.min_samples = 4;
  p.seed = 11;
  p.threads = 2;
  return p;
}

// The threshold samples' column sort (every size a node's sample can have, with many ties, odd
// column counts whose padding columns are sorted too) equals std::sort of each column.
TEST(TrainThresholds, ColumnSortEqualsStdSortOfEachColumn) {
  std::vector<uint16_t> network;
  uint32_t state = 12345;
  auto next = [&] { return state = state * 1664525u + 1013904223u; };
  for (int n = 1; n <= 255; n += (n < 40 ? 1 : 23)) {
    for (int lanes : {1, 16, 37}) {
      const size_t stride = size_t(lanes + 15) / 16 * 16;
      std::vector<int16_t> rows(size_t(n) * stride);
      // Values from a narrow range (many ties) in odd columns, the full int16 range in even ones.
      for (size_t i = 0; i < rows.size(); ++i)
        rows[i] = static_cast<int16_t>(i % 2 ? int(next() >> 28) - 8 : int(next() >> 16) - 32768);
      std::vector<int16_t> expected = rows;
      for (size_t c = 0; c < stride; ++c) {
        std::vector<int16_t> column(n);
        for (int r = 0; r < n; ++r) column[r] = expected[r * stride + c];
        std::sort(column.begin(), column.end());
        for (int r = 0; r < n; ++r) expected[r * stride + c] = column[r];
      }
      sort_int16_columns(rows.data(), n, stride, lanes, network);
      for (int c = 0; c < lanes; ++c)
        for (int r = 0; r < n; ++r)
          ASSERT_EQ(rows[r * stride + c], expected[r * stride + c]) << "n " << n << " lanes " << lanes << " column " << c
                                                                    << " row " << r;
    }
  }
}

TEST(TrainTree, RecoversTheDepthStepSplitExactly) {
  TempDir tmp;
  write_toy_dataset(tmp.path + "/toy");
  SamplingOptions so = toy_sampling();
  so.pixels_per_image = 0;  // every foreground pixel, so a perfect split on them is exact
  const TrainingSet set = load_training_set({tmp.path + "/toy"}, so);
  ASSERT_EQ(set.part_names.size(), 2u);
  GrownTree g = grow_tree(set, set.tree_pixels[0], 0, toy_params(8));
  // One split separates the halves perfectly, so both children are pure leaves.
  ASSERT_EQ(g.tree.nodes.size(), 3u);
  const TrainedNode& root = g.tree.nodes[0];
  ASSERT_FALSE(root.is_leaf());
  ASSERT_EQ(g.leaf_ranges.size(), 2u);
  for (size_t l = 0; l < 2; ++l) {
    const auto [b, e] = g.leaf_ranges[l];
    ASSERT_LT(b, e);
    for (uint32_t i = b; i < e; ++i) EXPECT_EQ(g.pixels[i].label, g.pixels[b].label) << "leaf " << l << " not pure";
  }
  EXPECT_NE(g.pixels[g.leaf_ranges[0].first].label, g.pixels[g.leaf_ranges[1].first].label);
  // Every foreground pixel of every frame (not only the sampled ones) is routed by the exact runtime
  // rule to the leaf of its own part.
  const int left_part = g.pixels[g.leaf_ranges[0].first].label;
  for (size_t f = 0; f < set.images.size(); ++f) {
    testing_toy::ToyFrame frame = testing_toy::make_toy_frame(ToyOptions{}, static_cast<int>(f));
    const int w = frame.depth.width, h = frame.depth.height;
    const std::vector<uint16_t> probe = make_probe_image(frame.depth.pixels.data(), frame.parts.pixels.data(), w, h);
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        const uint8_t part = frame.parts.pixels[size_t(v) * w + u];
        if (part == 255) continue;
        const int leaf =
            g.tree.nodes[leaf_node_for_pixel(g.tree, probe.data(), w, h, u, v, set.images[f].focal_factor)].leaf;
        ASSERT_EQ(leaf == 0 ? left_part : 1 - left_part, part) << "frame " << f << " pixel " << u << "," << v;
      }
  }
}

TEST(TrainTree, TrainerRoutingEqualsReferenceEvaluator) {
  TempDir tmp;
  ToyOptions o;
  o.frames = 5;
  write_toy_dataset(tmp.path + "/toy", o);
  SamplingOptions so = toy_sampling();
  so.pixels_per_image = 0;  // every foreground pixel
  TrainingSet set = load_training_set({tmp.path + "/toy"}, so);
  // Regression on joint offsets splits far deeper than the two-part labels, exercising many
  // features; ρ large enough to keep every offset.
  TreeParams p = toy_params(7);
  p.objective = Objective::kRegression;
  p.rho_m = 5;
  GrownTree g = grow_tree(set, set.tree_pixels[0], 0, p);
  ASSERT_GT(g.tree.nodes.size(), 20u);
  TrainedForest forest;
  forest.reference_focal_px = set.reference_focal_px;
  forest.depth = p.max_depth;
  forest.trees.push_back(g.tree);
  link_and_validate(forest, "grown");
  size_t checked = 0;
  for (size_t l = 0; l < g.leaf_ranges.size(); ++l)
    for (uint32_t i = g.leaf_ranges[l].first; i < g.leaf_ranges[l].second; ++i) {
      const TrainingPixel& px = g.pixels[i];
      const TrainingImage& im = set.images[px.image];
      const int node = leaf_node_for_pixel(forest.trees[0], im.probe.data(), im.width, im.height, px.u, px.v,
                                           im.focal_factor);
      ASSERT_EQ(forest.trees[0].nodes[node].leaf, int(l));
      ++checked;
    }
  EXPECT_EQ(checked, set.tree_pixels[0].size());
}

TEST(TrainTree, RegressionObjectiveLowersOffsetDeviation) {
  TempDir tmp;
  write_toy_dataset(tmp.path + "/toy");
  SamplingOptions so = toy_sampling();
  so.need_joints = true;
  const TrainingSet set = load_training_set({tmp.path + "/toy"}, so);
  TreeParams p = toy_params(1);
  p.objective = Objective::kRegression;
  p.rho_m = 5;
  GrownTree g = grow_tree(set, set.tree_pixels[0], 0, p);
  ASSERT_EQ(g.tree.nodes.size(), 3u);
  // The best single split for joint offsets is the depth step too: a part's pixels share a joint
  // 1 m in depth closer than the other part's.
  for (const auto& [b, e] : g.leaf_ranges)
    for (uint32_t i = b; i < e; ++i) EXPECT_EQ(g.pixels[i].label, g.pixels[b].label);
}

TEST(TrainTree, RegressionIgnoresOffsetsLongerThanRho) {
  TempDir tmp;
  write_toy_dataset(tmp.path + "/toy");
  const TrainingSet set = load_training_set({tmp.path + "/toy"}, toy_sampling());
  TreeParams p = toy_params(4);
  p.objective = Objective::kRegression;
  // Every pixel is ≥ 5 cm from both joints (they sit 5 cm behind the surface): with ρ = 4 cm no
  // offset counts, Eq. 9 is 0 everywhere and the root stays a leaf.
  p.rho_m = 0.04f;
  EXPECT_EQ(grow_tree(set, set.tree_pixels[0], 0, p).tree.nodes.size(), 1u);
  p.rho_m = 5;
  EXPECT_GT(grow_tree(set, set.tree_pixels[0], 0, p).tree.nodes.size(), 1u);
}

bool same_trees(const TrainedForest& a, const TrainedForest& b) {
  TrainedForest x = a, y = b;
  x.timings_json = y.timings_json = "{}";
  return serialize_forest(x) == serialize_forest(y);
}

TEST(TrainTree, SameForestForOneAndTwoThreads) {
  TempDir tmp;
  ToyOptions o;
  o.frames = 8;
  o.stripes = true;
  write_toy_dataset(tmp.path + "/toy", o);
  SamplingOptions so = toy_sampling(2);
  so.need_joints = true;
  const TrainingSet set = load_training_set({tmp.path + "/toy"}, so);
  for (Objective objective : {Objective::kClassification, Objective::kRegression}) {
    ForestOptions fo;
    fo.method = "ojr";
    fo.tree = toy_params(6);
    fo.tree.objective = objective;
    fo.tree.min_samples = 2;
    fo.tree.max_offset_pxm = 30;  // short probes: many splits before the leaves are pure
    fo.leaf.reservoir = 20;
    fo.tree.threads = 1;
    const TrainedForest one = train_forest(set, fo, {});
    fo.tree.threads = 2;
    const TrainedForest two = train_forest(set, fo, {});
    EXPECT_TRUE(same_trees(one, two));
    EXPECT_GT(one.trees[0].nodes.size(), 15u);
    fo.tree.seed = 12;
    const TrainedForest other = train_forest(set, fo, {});
    EXPECT_FALSE(same_trees(one, other)) << "the seed has no effect";
  }
  // Loading with one thread samples the same pixels.
  SamplingOptions single = so;
  single.threads = 1;
  const TrainingSet again = load_training_set({tmp.path + "/toy"}, single);
  ASSERT_EQ(again.tree_pixels.size(), set.tree_pixels.size());
  for (size_t t = 0; t < set.tree_pixels.size(); ++t)
    EXPECT_EQ(0, std::memcmp(again.tree_pixels[t].data(), set.tree_pixels[t].data(),
                             set.tree_pixels[t].size() * sizeof(TrainingPixel)));
}

TEST(TrainTree, StopsAtDepthAndMinSamples) {
  TempDir tmp;
  write_toy_dataset(tmp.path + "/toy");
  const TrainingSet set = load_training_set({tmp.path + "/toy"}, toy_sampling());
  TreeParams p = toy_params(3);
  p.objective = Objective::kRegression;
  p.rho_m = 5;
  p.min_samples = 200;
  // Regression keeps finding gains, so only depth and min-samples stop it.
  ASSERT_TRUE(set.has_joints);
  GrownTree g = grow_tree(set, set.tree_pixels[0], 0, p);
  for (const TrainedNode& n : g.tree.nodes) {
    EXPECT_LE(heap_level(n.heap_index), 3);
    if (!n.is_leaf()) {
      const auto it = std::find_if(g.tree.nodes.begin(), g.tree.nodes.end(),
                                   [&](const TrainedNode& c) { return c.heap_index == 2 * n.heap_index + 1; });
      ASSERT_NE(it, g.tree.nodes.end());
    }
  }
  // Every split node had at least min_samples pixels: sum of its leaves' pixels.
  TrainedForest f;
  f.reference_focal_px = 1;
  f.depth = 3;
  f.trees.push_back(g.tree);
  link_and_validate(f, "grown");
  std::function<uint32_t(int)> pixels_under = [&](int pos) -> uint32_t {
    const TrainedNode& n = f.trees[0].nodes[pos];
    if (n.is_leaf()) return f.trees[0].leaf_pixel_counts[n.leaf];
    const uint32_t total = pixels_under(n.left) + pixels_under(n.right);
    EXPECT_GE(total, 200u) << "split node " << n.heap_index;
    return total;
  };
  EXPECT_EQ(pixels_under(0), set.tree_pixels[0].size());
}

}  // namespace
}  // namespace dp::train
