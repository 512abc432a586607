// Checkpoint and resume: a run stopped right after a checkpoint (in tree 0 or in tree 1, after
// tree 0 is complete) and resumed, with another thread count, gives the byte-identical forest of
// an uninterrupted run, for BPC (classification) and OJR (regression structure + vote leaves);
// a checkpoint of other options or data, or a damaged one, is refused with a clear message.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "tests/cli_test_support.h"
#include "tests/train_stick_bodies.h"
#include "tests/train_toy_data.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/train/checkpoint.h"
#include "tools/train/forest_trainer.h"

namespace dp::train {
namespace {

struct Stop {};  // thrown by the after_checkpoint hook: the "kill"

ForestOptions resume_options(const std::string& method, Objective objective) {
  ForestOptions fo;
  fo.method = method;
  fo.tree.max_depth = 8;
  fo.tree.offset_candidates = 32;
  fo.tree.threshold_candidates = 16;
  fo.tree.max_offset_pxm = 65;
  fo.tree.min_samples = 6;
  fo.tree.objective = objective;
  fo.tree.seed = 9;
  fo.tree.threads = 2;
  fo.leaf.reservoir = 25;
  fo.leaf.seed = 9;
  return fo;
}

std::vector<uint8_t> bytes_without_timings(TrainedForest f) {
  f.timings_json = "{}";
  return serialize_forest(f);
}

std::string what_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const tools::ToolError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(TrainResume, StoppedAndResumedRunEqualsUninterruptedRun) {
  testing_toy::TempDir tmp;
  const TrainingSet set = testing_bodies::stick_body_set(16, 300, 2, 3);
  struct Case {
    std::string method;
    Objective objective;
  };
  for (const Case& c : {Case{"bpc", Objective::kClassification}, Case{"ojr", Objective::kRegression}}) {
    const ForestOptions base = resume_options(c.method, c.objective);
    const std::vector<uint8_t> expected = bytes_without_timings(train_forest(set, base, {}));
    // Stop points: (tree, levels done).
    for (const auto& [stop_tree, stop_levels] : {std::pair{0, 1}, std::pair{0, 4}, std::pair{1, 2}}) {
      const std::string what = c.method + " stopped at tree " + std::to_string(stop_tree) + " after " +
                               std::to_string(stop_levels) + " level(s)";
      ForestOptions fo = base;
      fo.checkpoint_path = tmp.path + "/" + c.method + ".checkpoint";
      std::filesystem::remove(fo.checkpoint_path);
      fo.tree.threads = 1;
      int checkpoints = 0;
      fo.after_checkpoint = [&](int tree, int levels) {
        ++checkpoints;
        if (tree == stop_tree && levels == stop_levels) throw Stop{};
      };
      EXPECT_THROW(train_forest(set, fo, {}), Stop) << what;
      ASSERT_TRUE(std::filesystem::exists(fo.checkpoint_path)) << what;
      EXPECT_FALSE(std::filesystem::exists(fo.checkpoint_path + ".tmp")) << what;
      const TrainingCheckpoint written = read_checkpoint(fo.checkpoint_path);
      ASSERT_EQ(written.trees.size(), size_t(stop_tree + 1)) << what;
      EXPECT_EQ(written.trees.back().levels_done, stop_levels) << what;
      if (stop_tree == 1) {
        EXPECT_TRUE(written.trees[0].complete) << what;
      }

      // Resume with another thread count; levels replayed from the checkpoint are not checkpointed again.
      fo.tree.threads = 2;
      fo.resume = true;
      int resumed_checkpoints = 0;
      int first_level_after_resume = -1;
      fo.after_checkpoint = [&](int tree, int levels) {
        if (resumed_checkpoints++ == 0) {
          EXPECT_EQ(tree, stop_tree) << what;
          first_level_after_resume = levels;
        }
      };
      const TrainedForest resumed = train_forest(set, fo, {});
      EXPECT_EQ(first_level_after_resume, stop_levels + 1) << what;
      EXPECT_TRUE(bytes_without_timings(resumed) == expected) << what << ": resumed forest differs";
      EXPECT_GT(checkpoints, 0);
    }
  }
}

TEST(TrainResume, RefusesCheckpointOfOtherOptionsOrDataOrDamagedFile) {
  testing_toy::TempDir tmp;
  const TrainingSet set = testing_bodies::stick_body_set(12, 200, 1, 3);
  ForestOptions fo = resume_options("bpc", Objective::kClassification);
  fo.checkpoint_path = tmp.path + "/bpc.checkpoint";
  fo.after_checkpoint = [](int, int levels) {
    if (levels == 2) throw Stop{};
  };
  EXPECT_THROW(train_forest(set, fo, {}), Stop);
  fo.after_checkpoint = {};
  fo.resume = true;

  ForestOptions deeper = fo;
  deeper.tree.max_depth = 9;
  const std::string e1 = what_of([&] { train_forest(set, deeper, {}); });
  EXPECT_NE(e1.find("other options"), std::string::npos) << e1;
  EXPECT_NE(e1.find("depth: checkpoint 8, this run 9"), std::string::npos) << e1;
  EXPECT_NE(e1.find(fo.checkpoint_path), std::string::npos) << e1;

  ForestOptions reseeded = fo;
  reseeded.tree.seed = 10;
  EXPECT_NE(what_of([&] { train_forest(set, reseeded, {}); }).find("seed: checkpoint 9, this run 10"),
            std::string::npos);

  const TrainingSet other = testing_bodies::stick_body_set(12, 200, 1, 4);
  const std::string e2 = what_of([&] { train_forest(other, fo, {}); });
  EXPECT_NE(e2.find("other training data"), std::string::npos) << e2;

  // The thread count is not an option of the forest: resuming with another one is accepted.
  ForestOptions threads = fo;
  threads.tree.threads = 1;
  EXPECT_EQ(what_of([&] { train_forest(set, threads, {}); }), "(no error)");

  // Damaged: truncated by a byte.
  fo.after_checkpoint = [](int, int levels) {
    if (levels == 2) throw Stop{};
  };
  fo.resume = false;
  EXPECT_THROW(train_forest(set, fo, {}), Stop);
  const auto size = std::filesystem::file_size(fo.checkpoint_path);
  std::filesystem::resize_file(fo.checkpoint_path, size - 1);
  fo.resume = true;
  fo.after_checkpoint = {};
  const std::string e3 = what_of([&] { train_forest(set, fo, {}); });
  EXPECT_NE(e3.find("CRC-32 mismatch"), std::string::npos) << e3;
  // Not a checkpoint at all.
  std::ofstream(fo.checkpoint_path) << "hello";
  EXPECT_NE(what_of([&] { train_forest(set, fo, {}); }).find("bad magic"), std::string::npos);
}

TEST(TrainResume, ResumeWithoutCheckpointStartsOver) {
  testing_toy::TempDir tmp;
  const TrainingSet set = testing_bodies::stick_body_set(8, 200, 1, 3);
  ForestOptions fo = resume_options("bpc", Objective::kClassification);
  const std::vector<uint8_t> expected = bytes_without_timings(train_forest(set, fo, {}));
  fo.checkpoint_path = tmp.path + "/none.checkpoint";
  fo.resume = true;
  EXPECT_TRUE(bytes_without_timings(train_forest(set, fo, {})) == expected);
  EXPECT_TRUE(read_checkpoint(fo.checkpoint_path).trees.at(0).complete);
}

TEST(TrainResume, CommandWritesRemovesAndChecksItsCheckpoint) {
  testing_toy::TempDir tmp;
  const std::string data = tmp.path + "/toy";
  testing_toy::ToyOptions o;
  o.stripes = true;
  testing_toy::write_toy_dataset(data, o);
  const std::vector<std::string> base = {"train", "--data", data, "--method", "bpc", "--trees", "1", "--depth", "5",
                                         "--offsets", "20", "--quiet"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = base;
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  // A finished run leaves the forest and no checkpoint (nor its temp file); --resume without a
  // checkpoint starts over and writes the same trees.
  ASSERT_EQ(0, testsupport::run_cli(with({"--out", tmp.path + "/a.forest"})));
  EXPECT_FALSE(std::filesystem::exists(tmp.path + "/a.forest.checkpoint"));
  EXPECT_FALSE(std::filesystem::exists(tmp.path + "/a.forest.checkpoint.tmp"));
  ASSERT_EQ(0, testsupport::run_cli(with({"--out", tmp.path + "/b.forest", "--resume"})));
  EXPECT_TRUE(bytes_without_timings(read_forest(tmp.path + "/a.forest")) ==
              bytes_without_timings(read_forest(tmp.path + "/b.forest")));
  // A damaged checkpoint at --checkpoint is refused, naming the file.
  std::ofstream(tmp.path + "/c.ckpt") << "not a checkpoint";
  const std::string e = what_of([&] {
    testsupport::run_cli(with({"--out", tmp.path + "/c.forest", "--checkpoint", tmp.path + "/c.ckpt", "--resume"}));
  });
  EXPECT_NE(e.find(tmp.path + "/c.ckpt"), std::string::npos) << e;
  EXPECT_NE(e.find("bad magic"), std::string::npos) << e;
  // An OJR retro-fit stopped after its first checkpoint (exit 75) and resumed writes the forest of
  // an uninterrupted retro-fit and removes its checkpoint.
  const std::vector<std::string> retrofit = {"train", "--data", data, "--method", "ojr", "--structure",
                                             tmp.path + "/a.forest", "--quiet", "--no-timings"};
  auto retro = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = retrofit;
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  ASSERT_EQ(0, testsupport::run_cli(retro({"--out", tmp.path + "/d.forest"})));
  ASSERT_EQ(75, testsupport::run_cli(retro({"--out", tmp.path + "/e.forest", "--stop-after", "1"})));
  ASSERT_TRUE(std::filesystem::exists(tmp.path + "/e.forest.checkpoint"));
  EXPECT_EQ(read_checkpoint(tmp.path + "/e.forest.checkpoint").retrofit.size(), 1u);
  ASSERT_EQ(0, testsupport::run_cli(retro({"--out", tmp.path + "/e.forest", "--resume"})));
  EXPECT_FALSE(std::filesystem::exists(tmp.path + "/e.forest.checkpoint"));
  EXPECT_TRUE(tools::read_file_bytes(tmp.path + "/d.forest") == tools::read_file_bytes(tmp.path + "/e.forest"));
  // A grown forest's checkpoint does not resume a retro-fit.
  ASSERT_EQ(75, testsupport::run_cli(with({"--out", tmp.path + "/f.forest", "--stop-after", "1"})));
  EXPECT_NE(what_of([&] {
              testsupport::run_cli(retro({"--out", tmp.path + "/g.forest", "--checkpoint",
                                          tmp.path + "/f.forest.checkpoint", "--resume"}));
            }).find("other options"),
            std::string::npos);
}

TEST(TrainResume, StoppedAndResumedRetrofitEqualsUninterruptedRetrofit) {
  testing_toy::TempDir tmp;
  const TrainingSet set = testing_bodies::stick_body_set(16, 300, 2, 3);
  const TrainedForest structure = train_forest(set, resume_options("bpc", Objective::kClassification), {});
  ForestOptions base = resume_options("ojr", Objective::kClassification);
  base.structure = &structure;
  base.leaf.leaf_block = 7;  // several checkpoints per tree
  const std::vector<uint8_t> expected = bytes_without_timings(train_forest(set, base, {}));
  size_t leaves0 = structure.trees[0].leaf_count();
  ASSERT_GT(leaves0, 14u) << "the structure must have several blocks of leaves";
  // Stop points: (tree, leaves done): inside tree 0, tree 0 complete, inside tree 1.
  for (const auto& [stop_tree, stop_leaves] : {std::pair{0, 7}, std::pair{0, int(leaves0)}, std::pair{1, 14}}) {
    const std::string what = "retro-fit stopped at tree " + std::to_string(stop_tree) + " after " +
                             std::to_string(stop_leaves) + " leaves";
    ForestOptions fo = base;
    fo.checkpoint_path = tmp.path + "/ojr.checkpoint";
    fo.retrofit_checkpoint_seconds = 0;
    std::filesystem::remove(fo.checkpoint_path);
    fo.tree.threads = 1;
    fo.after_checkpoint = [&](int tree, int leaves) {
      if (tree == stop_tree && leaves == stop_leaves) throw Stop{};
    };
    EXPECT_THROW(train_forest(set, fo, {}), Stop) << what;
    const TrainingCheckpoint written = read_checkpoint(fo.checkpoint_path);
    ASSERT_EQ(written.retrofit.size(), size_t(stop_tree + 1)) << what;
    EXPECT_TRUE(written.trees.empty()) << what;
    EXPECT_EQ(written.retrofit.back().leaves_done, size_t(stop_leaves)) << what;
    EXPECT_EQ(written.retrofit.back().complete, size_t(stop_leaves) == structure.trees[size_t(stop_tree)].leaf_count())
        << what;

    fo.tree.threads = 2;
    fo.resume = true;
    int first_after_resume = -1;
    fo.after_checkpoint = [&](int tree, int leaves) {
      if (first_after_resume < 0) first_after_resume = tree * 100000 + leaves;
    };
    const TrainedForest resumed = train_forest(set, fo, {});
    const int next = stop_leaves == int(leaves0) ? 100000 + 7 : stop_tree * 100000 + stop_leaves + 7;
    EXPECT_EQ(first_after_resume, next) << what << ": the resumed fit continues at the next block";
    EXPECT_TRUE(bytes_without_timings(resumed) == expected) << what << ": resumed forest differs";
  }
  // A checkpoint of another structure is refused.
  ForestOptions fo = base;
  fo.checkpoint_path = tmp.path + "/ojr.checkpoint";
  fo.retrofit_checkpoint_seconds = 0;
  fo.after_checkpoint = [&](int, int) { throw Stop{}; };
  std::filesystem::remove(fo.checkpoint_path);
  EXPECT_THROW(train_forest(set, fo, {}), Stop);
  TrainedForest other = structure;
  other.trees[0].nodes[0].threshold_mm += 1;
  fo.structure = &other;
  fo.resume = true;
  fo.after_checkpoint = {};
  EXPECT_NE(what_of([&] { train_forest(set, fo, {}); }).find("structure"), std::string::npos);
}

}  // namespace
}  // namespace dp::train
