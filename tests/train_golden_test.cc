// The trainer's output is pinned: small forests grown with fixed options and seed must serialize
// to the bytes recorded below (FNV-1a 64 of the forest file with the timings blanked). The digests
// were computed by the trainer before its split search was restructured for speed, so any change
// that alters a chosen split, threshold, tie-break or leaf shows up here. If a deliberate change
// of the training rule alters them, record the new digests and say why in the commit.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "tests/train_stick_bodies.h"
#include "tools/train/forest_trainer.h"

namespace dp::train {
namespace {

uint64_t forest_digest(TrainedForest forest) {
  forest.timings_json = "{}";
  uint64_t h = 0xCBF29CE484222325ull;
  for (uint8_t b : serialize_forest(forest)) h = (h ^ b) * 0x100000001B3ull;
  return h;
}

std::string hex(uint64_t v) {
  char b[20];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(v));
  return b;
}

ForestOptions golden_options(const std::string& method, Objective objective, int threads) {
  ForestOptions fo;
  fo.method = method;
  fo.tree.max_depth = 9;
  fo.tree.offset_candidates = 48;
  fo.tree.threshold_candidates = 20;
  fo.tree.max_offset_pxm = 65;
  fo.tree.min_samples = 8;
  fo.tree.objective = objective;
  fo.tree.seed = 5;
  fo.tree.threads = threads;
  fo.leaf.reservoir = 30;
  fo.leaf.seed = 5;
  return fo;
}

// A small set grown deep with the shipped recipe's 400 candidates (an OJR forest, so that both
// objectives apply): nearly every node below the first levels is small enough to store its
// features (the comparisons of kernels below).
ForestOptions deep_options(Objective objective) {
  ForestOptions fo = golden_options("ojr", objective, 2);
  fo.tree.max_depth = 12;
  fo.tree.offset_candidates = 400;
  fo.tree.min_samples = 4;
  fo.leaf.reservoir = 8;
  return fo;
}

struct GoldenCase {
  const char* name;
  std::string method;
  Objective objective;
  const char* digest;
};
const GoldenCase kGoldenCases[] = {
    {"bpc classification", "bpc", Objective::kClassification, "9a34ff0291d3cc00"},
    {"ojr classification", "ojr", Objective::kClassification, "a2919b5797450184"},
    // Regression offsets are summed in fixed point (2^-12 m) so that sums over pixel ranges,
    // threads and MPI ranks are exact; that rounding chose this forest.
    {"ojr regression", "ojr", Objective::kRegression, "8f202944ec9d93f7"},
};

TEST(TrainGolden, ForestsEqualTheRecordedDigests) {
  const TrainingSet set = testing_bodies::stick_body_set(24, 400, 2, 3);
  for (const GoldenCase& c : kGoldenCases)
    for (int threads : {1, 2}) {
      const TrainedForest f = train_forest(set, golden_options(c.method, c.objective, threads), {});
      size_t nodes = 0;
      for (const TrainedTree& t : f.trees) nodes += t.nodes.size();
      EXPECT_GT(nodes, 100u) << c.name << ": the golden forest should be deep enough to pin many splits";
      EXPECT_EQ(hex(forest_digest(f)), c.digest) << c.name << ", " << threads << " thread(s)";
    }
}

// The portable feature kernel (DEPTHPOSE_TRAIN_NO_AVX2, read when a tree's growth starts) grows
// the same forest as the AVX2 one that the test above uses on x86 machines with AVX2. Both
// objectives share the kernel, so the BPC case suffices.
TEST(TrainGolden, PortableKernelGrowsTheSameForest) {
  const TrainingSet set = testing_bodies::stick_body_set(24, 400, 2, 3);
  const GoldenCase& c = kGoldenCases[0];
  ASSERT_EQ(setenv("DEPTHPOSE_TRAIN_NO_AVX2", "1", 1), 0);
  const TrainedForest f = train_forest(set, golden_options(c.method, c.objective, 1), {});
  unsetenv("DEPTHPOSE_TRAIN_NO_AVX2");
  EXPECT_EQ(hex(forest_digest(f)), c.digest) << c.name << ", portable kernel";
}

// Nodes whose pixels' features fit the trainer's stored-feature budget (a few hundred pixels at
// 400 candidates) compute them once and take their threshold samples from them; the portable
// kernel evaluates the samples separately. On a small set grown deep with the shipped recipe's
// 400 candidates nearly every node below the first levels takes the stored path, so equal forests
// for both kernels (both objectives, whose histograms differ) show that path changes no split.
// The deep forests of deep_options, both objectives, grown with the default kernel and again with
// `disable` set: equal digests, and deep enough to have many small nodes.
void expect_same_deep_forests_without(const char* disable) {
  const TrainingSet set = testing_bodies::stick_body_set(6, 120, 1, 7);
  for (Objective objective : {Objective::kClassification, Objective::kRegression}) {
    const ForestOptions fo = deep_options(objective);
    const TrainedForest by_default = train_forest(set, fo, {});
    ASSERT_EQ(setenv(disable, "1", 1), 0);
    const TrainedForest other = train_forest(set, fo, {});
    unsetenv(disable);
    EXPECT_GT(by_default.trees[0].nodes.size(), 100u) << "the tree should be deep enough to have many small nodes";
    EXPECT_EQ(hex(forest_digest(by_default)), hex(forest_digest(other)))
        << (objective == Objective::kClassification ? "classification" : "regression") << ", " << disable;
  }
}

TEST(TrainGolden, StoredFeaturesOfSmallNodesGrowTheSameForest) {
  expect_same_deep_forests_without("DEPTHPOSE_TRAIN_NO_AVX2");
}

// The AVX-512 kernels (gathered probes, 32-lane binning, vector cell indices; the default where the
// CPU has AVX-512 F/BW/VL/DQ) grow the same forests as the AVX2 ones (DEPTHPOSE_TRAIN_NO_AVX512),
// deep, with the shipped recipe's 400 candidates, both objectives. Skipped, saying so, on a CPU
// without AVX-512 (the default there is the AVX2 kernel, which the tests above pin).
TEST(TrainGolden, Avx512KernelGrowsTheSameForestAsAvx2) {
  if (!(__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
        __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq")))
    GTEST_SKIP() << "this CPU has no AVX-512 F/BW/VL/DQ: the AVX-512 training kernel cannot run here";
  expect_same_deep_forests_without("DEPTHPOSE_TRAIN_NO_AVX512");
  // And the golden BPC forest, with 1 and 2 threads.
  for (int threads : {1, 2})
    EXPECT_EQ(hex(forest_digest(train_forest(testing_bodies::stick_body_set(24, 400, 2, 3),
                                             golden_options("bpc", Objective::kClassification, threads), {}))),
              kGoldenCases[0].digest);
}

// training_kernel_name() names the kernel the environment and the CPU select.
TEST(TrainGolden, KernelNameFollowsTheCpuAndTheEnvironment) {
  const bool avx2 = __builtin_cpu_supports("avx2");
  const bool avx512 = avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                      __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq");
  EXPECT_STREQ(training_kernel_name(), avx512 ? "avx512" : avx2 ? "avx2" : "portable");
  ASSERT_EQ(setenv("DEPTHPOSE_TRAIN_NO_AVX512", "1", 1), 0);
  EXPECT_STREQ(training_kernel_name(), avx2 ? "avx2" : "portable");
  ASSERT_EQ(setenv("DEPTHPOSE_TRAIN_NO_AVX2", "1", 1), 0);
  EXPECT_STREQ(training_kernel_name(), "portable");
  unsetenv("DEPTHPOSE_TRAIN_NO_AVX512");
  EXPECT_STREQ(training_kernel_name(), "portable");
  unsetenv("DEPTHPOSE_TRAIN_NO_AVX2");
}

// Training images are padded with kProbePadding background elements (the AVX-512 kernel reads
// 32-bit words at 16-bit elements); a set built without the padding (by hand) is read from padded
// copies and grows the same forest.
TEST(TrainGolden, ImagesWithoutPaddingGrowTheSameForest) {
  TrainingSet set = testing_bodies::stick_body_set(24, 400, 2, 3);
  for (const TrainingImage& im : set.images)
    ASSERT_EQ(im.probe.size(), size_t(im.width) * im.height + kProbePadding) << im.name;
  for (TrainingImage& im : set.images) im.probe.resize(size_t(im.width) * im.height);
  const GoldenCase& c = kGoldenCases[0];
  EXPECT_EQ(hex(forest_digest(train_forest(set, golden_options(c.method, c.objective, 2), {}))), c.digest);
}

// Deep levels walk their nodes' pixels in image order, in batches of nodes whose features fit a
// byte budget (1 GiB by default, so the forests above take one batch per level). With a budget of
// a few dozen pixels, every deep level takes many batches and the nodes larger than the budget
// keep the node-major walk: the forest must still be the recorded one, with 1 and 2 threads.
TEST(TrainGolden, SmallFeatureBatchesGrowTheSameForest) {
  const TrainingSet set = testing_bodies::stick_body_set(24, 400, 2, 3);
  const GoldenCase& c = kGoldenCases[0];
  for (int threads : {1, 2}) {
    ForestOptions fo = golden_options(c.method, c.objective, threads);
    fo.tree.level_feature_bytes = 40 * 48 * sizeof(int16_t);
    EXPECT_EQ(hex(forest_digest(train_forest(set, fo, {}))), c.digest) << threads << " thread(s)";
  }
}

}  // namespace
}  // namespace dp::train
