// Checkpoint and resume: a run stopped right after a checkpoint (in tree 0 or in tree 1, after
// tree 0 is complete) and resumed, with another thread count, gives the byte-identical forest of
// an uninterrupted run, for BPC (classification) and OJR (regression structure + vote leaves);
// a checkpoint of other options or data, or a damaged one, is refused with a clear message.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "tests/train_stick_bodies.h"
#include "tests/train_toy_data.h"
#include "tools/common/error.h"
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

}  // namespace
}  // namespace dp::train
