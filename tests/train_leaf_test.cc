// Leaf models: reservoir sampling is uniform, mean shift finds known modes, vote selection obeys
// K and λ, OJR leaves fitted on a known geometry, BPC distributions, and retro-fitting.
#include <gtest/gtest.h>

#include <cmath>

#include "tests/train_toy_data.h"
#include "tools/train/forest_trainer.h"
#include "tools/train/leaf_models.h"

namespace dp::train {
namespace {

TEST(TrainLeaves, ReservoirSamplingIsUniform) {
  // 20000 reservoirs of capacity 100 over a stream of 1000 items: each item should be kept with
  // probability 0.1, i.e. 2000 ± 42 (σ) times. A sampler favouring early or late items (e.g.
  // keeping the first 100, or replacing with probability 1/capacity) misses by thousands.
  constexpr int kStream = 1000, kCapacity = 100, kTrials = 20000;
  std::vector<int> kept(kStream, 0);
  for (int t = 0; t < kTrials; ++t) {
    Rng rng = Rng::keyed(2024, t);
    ReservoirSampler<int> r(kCapacity);
    for (int i = 0; i < kStream; ++i) r.offer(i, rng);
    ASSERT_EQ(r.items().size(), size_t(kCapacity));
    ASSERT_EQ(r.seen(), uint64_t(kStream));
    for (int i : r.items()) ++kept[i];
  }
  const double expected = double(kTrials) * kCapacity / kStream;
  const double sigma = std::sqrt(kTrials * 0.1 * 0.9);
  double chi2 = 0, first_half = 0;
  for (int i = 0; i < kStream; ++i) {
    EXPECT_NEAR(kept[i], expected, 6 * sigma) << "item " << i;
    chi2 += (kept[i] - expected) * (kept[i] - expected) / expected;
    if (i < kStream / 2) first_half += kept[i];
  }
  // Counts are not independent (they sum to kTrials·kCapacity), so chi2 ≈ (1 − 0.1)·999 ± 40;
  // 6σ bands on both sides.
  EXPECT_GT(chi2, 0.9 * 999 - 6 * 42) << "too regular to be random";
  EXPECT_LT(chi2, 0.9 * 999 + 6 * 42) << "not uniform";
  // Early vs late items: half of all kept items expected in each half (σ ≈ 0.5·√(2e6)/... ≈ 300).
  EXPECT_NEAR(first_half / (double(kTrials) * kCapacity), 0.5, 0.005);
}

TEST(TrainLeaves, ReservoirKeepsEverythingWhenStreamIsShort) {
  Rng rng(1);
  ReservoirSampler<int> r(10);
  for (int i = 0; i < 7; ++i) r.offer(i, rng);
  ASSERT_EQ(r.items().size(), 7u);
  for (int i = 0; i < 7; ++i) EXPECT_EQ(r.items()[i], i);
}

std::vector<std::array<float, 3>> cluster(std::array<float, 3> centre, int n, float spread, uint64_t seed) {
  Rng rng(seed);
  std::vector<std::array<float, 3>> pts;
  for (int i = 0; i < n; ++i)
    pts.push_back({centre[0] + float(rng.unit() * 2 - 1) * spread, centre[1] + float(rng.unit() * 2 - 1) * spread,
                   centre[2] + float(rng.unit() * 2 - 1) * spread});
  return pts;
}

TEST(TrainLeaves, MeanShiftFindsKnownModes) {
  auto pts = cluster({0.10f, 0.0f, 0.02f}, 60, 0.01f, 1);
  auto b = cluster({-0.20f, 0.10f, 0.0f}, 30, 0.01f, 2);
  auto c = cluster({0.0f, -0.30f, 0.1f}, 10, 0.01f, 3);
  pts.insert(pts.end(), b.begin(), b.end());
  pts.insert(pts.end(), c.begin(), c.end());
  const std::vector<Mode> modes = mean_shift_modes(pts, 0.05f);
  ASSERT_EQ(modes.size(), 3u);
  EXPECT_EQ(modes[0].weight, 60);
  EXPECT_EQ(modes[1].weight, 30);
  EXPECT_EQ(modes[2].weight, 10);
  EXPECT_NEAR(modes[0].position[0], 0.10f, 0.006);
  EXPECT_NEAR(modes[0].position[1], 0.0f, 0.006);
  EXPECT_NEAR(modes[0].position[2], 0.02f, 0.006);
  EXPECT_NEAR(modes[1].position[0], -0.20f, 0.006);
  EXPECT_NEAR(modes[1].position[1], 0.10f, 0.006);
  EXPECT_NEAR(modes[2].position[1], -0.30f, 0.006);

  // K = 2 keeps the two heaviest; λ = 0.15 m drops the 0.224 m mode and keeps the 0.316 m one out too.
  std::vector<LeafVote> v = select_votes(modes, 0.0f, 2);
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(v[0].weight, 60);
  EXPECT_EQ(v[1].weight, 30);
  v = select_votes(modes, 0.15f, 2);
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(v[0].weight, 60);
  EXPECT_EQ(v[1].weight, 0) << "padding vote must have weight 0";
  v = select_votes(modes, 0.33f, 3);
  EXPECT_EQ(v[2].weight, 10);
}

TEST(TrainLeaves, MeanShiftMergesOneBlob) {
  const auto pts = cluster({0.3f, 0.3f, 0.3f}, 50, 0.02f, 9);
  const std::vector<Mode> modes = mean_shift_modes(pts, 0.05f);
  ASSERT_EQ(modes.size(), 1u);
  EXPECT_EQ(modes[0].weight, 50);
}

TEST(TrainLeaves, OjrVotesPointAtTheJoint) {
  // One image, a flat 5×5 patch at 2 m around the principal point; joint 0 is 10 cm behind the
  // patch centre, joint 1 40 cm to the right. With one leaf holding every pixel, the votes are the
  // mean offsets (the patch spans 2·2/60 m·2 = ±6.7 cm, inside one bandwidth).
  const int w = 21, h = 21;
  std::vector<uint16_t> depth(w * h, 0);
  for (int v = 8; v < 13; ++v)
    for (int u = 8; u < 13; ++u) depth[v * w + u] = 2000;
  CameraIntrinsics cam{60, 60, 10, 10};
  TrainingSet set;
  set.joint_names = {"a", "b"};
  set.has_joints = true;
  set.reference_focal_px = 60;
  set.images.push_back(make_training_image(depth.data(), nullptr, w, h, cam, 60, {0.f, 0.f, 2.1f, 0.4f, 0.f, 2.0f}, "img"));
  std::vector<TrainingPixel> px;
  sample_pixels(set.images[0], nullptr, 0, 0, 0, 1, px);
  ASSERT_EQ(px.size(), 25u);
  LeafParams lp;
  lp.bandwidth_m = 0.2f;
  lp.votes_per_joint = 2;
  lp.vote_length_m = {0.3f, 0.5f};
  TrainedTree tree;
  tree.leaf_pixel_counts = {25};
  fit_votes(set, px, {{0u, 25u}}, lp, 0, tree);
  ASSERT_EQ(tree.votes.size(), 4u);
  EXPECT_NEAR(tree.votes[0].dx, 0.0f, 0.01);
  EXPECT_NEAR(tree.votes[0].dy, 0.0f, 0.01);
  EXPECT_NEAR(tree.votes[0].dz, 0.1f, 0.001);
  EXPECT_EQ(tree.votes[0].weight, 25);
  EXPECT_EQ(tree.votes[1].weight, 0);
  EXPECT_NEAR(tree.votes[2].dx, 0.4f, 0.01);
  EXPECT_EQ(tree.votes[2].weight, 25);
  // λ for joint b below 0.4 m drops its only mode.
  lp.vote_length_m = {0.3f, 0.35f};
  fit_votes(set, px, {{0u, 25u}}, lp, 0, tree);
  EXPECT_EQ(tree.votes[2].weight, 0);
}

TEST(TrainLeaves, BpcDistributionsAndRetrofitMatchGrownLeaves) {
  testing_toy::TempDir tmp;
  testing_toy::ToyOptions o;
  o.stripes = true;
  testing_toy::write_toy_dataset(tmp.path + "/toy", o);
  SamplingOptions so;
  so.pixels_per_image = 200;
  so.trees = 2;
  so.threads = 2;
  so.need_joints = true;
  const TrainingSet set = load_training_set({tmp.path + "/toy"}, so);
  ForestOptions fo;
  fo.method = "bpc";
  fo.tree.max_depth = 5;
  fo.tree.offset_candidates = 40;
  fo.tree.threshold_candidates = 16;
  fo.tree.max_offset_pxm = 40;
  fo.tree.min_samples = 2;
  fo.tree.threads = 2;
  const TrainedForest bpc = train_forest(set, fo, {});
  ASSERT_TRUE(bpc.has_part_distributions);
  ASSERT_FALSE(bpc.has_votes);
  for (const TrainedTree& t : bpc.trees) {
    uint64_t pixels = 0;
    for (size_t l = 0; l < t.leaf_count(); ++l) {
      double sum = 0;
      for (size_t c = 0; c < 4; ++c) sum += t.part_probabilities[l * 4 + c];
      EXPECT_NEAR(sum, 1.0, 1e-5);
      pixels += t.leaf_pixel_counts[l];
    }
    EXPECT_EQ(pixels, set.tree_pixels[&t - bpc.trees.data()].size());
  }
  // Retro-fitting OJR leaves onto the BPC structure with the same pixels reproduces the same
  // structure, pixel counts and part distributions, and adds votes.
  ForestOptions ro = fo;
  ro.method = "ojr";
  ro.structure = &bpc;
  ro.leaf.reservoir = 30;
  const TrainedForest ojr = train_forest(set, ro, {});
  ASSERT_TRUE(ojr.has_votes);
  ASSERT_EQ(ojr.trees.size(), bpc.trees.size());
  for (size_t t = 0; t < ojr.trees.size(); ++t) {
    ASSERT_EQ(ojr.trees[t].nodes.size(), bpc.trees[t].nodes.size());
    EXPECT_EQ(ojr.trees[t].leaf_pixel_counts, bpc.trees[t].leaf_pixel_counts);
    EXPECT_EQ(ojr.trees[t].part_probabilities, bpc.trees[t].part_probabilities);
    size_t voting = 0;
    for (const LeafVote& v : ojr.trees[t].votes) {
      voting += v.weight > 0;
      EXPECT_LE(std::sqrt(v.dx * v.dx + v.dy * v.dy + v.dz * v.dz), 0.5f + 1e-6f);
      EXPECT_LE(v.weight, 30);
    }
    EXPECT_GT(voting, ojr.trees[t].leaf_count());
  }
}

}  // namespace
}  // namespace dp::train
