// Merging trained forests (`train --merge`): the trees of runs with other seeds concatenated; a
// tree is decided by its key (seed, index in its run), so a one-tree run equals the first tree of a
// longer run of its seed; forests of other options, data or shape, or holding one tree twice, are
// refused naming what differs.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tests/app_test_support.h"
#include "tests/cli_test_support.h"
#include "tests/train_toy_data.h"
#include "tools/train/forest_file.h"
#include "tools/train/forest_merge.h"

namespace dp::train {
namespace {

std::vector<uint8_t> tree_bytes(const TrainedForest& f, size_t t) {
  TrainedForest one = f;
  one.trees = {f.trees[t]};
  one.training_json = "{}";
  one.timings_json = "{}";
  return serialize_forest(one);
}

using apptest::error_of;

class TrainMerge : public ::testing::Test {
 protected:
  void SetUp() override {
    data_ = tmp_.path + "/toy";
    testing_toy::ToyOptions o;
    o.stripes = true;
    testing_toy::write_toy_dataset(data_, o);
  }
  std::string train(const std::string& name, std::vector<std::string> extra) {
    std::vector<std::string> a = {"train", "--data", data_, "--method", "bpc", "--depth", "5", "--offsets", "20",
                                  "--quiet", "--out", tmp_.path + "/" + name};
    a.insert(a.end(), extra.begin(), extra.end());
    if (testsupport::run_cli(a) != 0) ADD_FAILURE() << "training " << name << " failed";
    return tmp_.path + "/" + name;
  }
  testing_toy::TempDir tmp_;
  std::string data_;
};

TEST_F(TrainMerge, OneTreeRunsMergeIntoAForestOfTheirTrees) {
  const std::string s1 = train("s1.forest", {"--trees", "1", "--seed", "1"});
  const std::string s2 = train("s2.forest", {"--trees", "1", "--seed", "2"});
  const std::string joint = train("joint.forest", {"--trees", "2", "--seed", "1"});
  const std::string merged_path = tmp_.path + "/m.forest";
  ASSERT_EQ(0, testsupport::run_cli({"train", "--merge", s1 + "," + s2, "--out", merged_path, "--quiet"}));

  const TrainedForest a = read_forest(s1), b = read_forest(s2), j = read_forest(joint), m = read_forest(merged_path);
  ASSERT_EQ(m.trees.size(), 2u);
  EXPECT_EQ(tree_bytes(m, 0), tree_bytes(a, 0));
  EXPECT_EQ(tree_bytes(m, 1), tree_bytes(b, 0));
  EXPECT_NE(tree_bytes(a, 0), tree_bytes(b, 0));  // another seed grows another tree
  // The key decides the tree: seed 1's first tree is the same in a one-tree and a two-tree run.
  EXPECT_EQ(tree_bytes(j, 0), tree_bytes(a, 0));
  EXPECT_NE(tree_bytes(j, 1), tree_bytes(b, 0));

  const std::vector<TreeKey> keys = tree_keys(m, "m");
  ASSERT_EQ(keys.size(), 2u);
  EXPECT_TRUE((keys[0] == TreeKey{1, 0}) && (keys[1] == TreeKey{2, 0}));
  const auto cfg = nlohmann::json::parse(m.training_json);
  const auto ca = nlohmann::json::parse(a.training_json), cb = nlohmann::json::parse(b.training_json);
  EXPECT_FALSE(cfg.contains("seed"));
  EXPECT_EQ(cfg["trees"], 2);
  EXPECT_EQ(cfg["training_pixels"].get<uint64_t>(),
            ca["training_pixels"].get<uint64_t>() + cb["training_pixels"].get<uint64_t>());
  EXPECT_EQ(cfg["offsets"], 20);
  EXPECT_EQ(m.datasets_json, a.datasets_json);

  // A merged forest merges again.
  const std::string s3 = train("s3.forest", {"--trees", "1", "--seed", "3"});
  ASSERT_EQ(0, testsupport::run_cli({"train", "--merge", merged_path + "," + s3, "--out", tmp_.path + "/m3.forest",
                                     "--quiet"}));
  const TrainedForest m3 = read_forest(tmp_.path + "/m3.forest");
  ASSERT_EQ(m3.trees.size(), 3u);
  EXPECT_EQ(tree_bytes(m3, 2), tree_bytes(read_forest(s3), 0));
  EXPECT_TRUE(tree_keys(m3, "m3")[2] == (TreeKey{3, 0}));
}

TEST_F(TrainMerge, RefusesTheSameTreeTwiceOtherOptionsOtherDataAndOtherShapes) {
  const std::string s1 = train("s1.forest", {"--trees", "1", "--seed", "1"});
  const std::string joint = train("joint.forest", {"--trees", "2", "--seed", "1"});
  const TrainedForest a = read_forest(s1), j = read_forest(joint);

  std::string e = error_of([&] { merge_forests({a, j}, {"s1", "joint"}); });
  EXPECT_NE(e.find("seed 1, index 0"), std::string::npos) << e;
  EXPECT_NE(e.find("same tree twice"), std::string::npos) << e;

  const TrainedForest fewer = read_forest(train("o.forest", {"--trees", "1", "--seed", "2", "--thresholds", "7"}));
  e = error_of([&] { merge_forests({a, fewer}, {"s1", "o"}); });
  EXPECT_NE(e.find("'thresholds': 50 against 7"), std::string::npos) << e;

  const TrainedForest deeper =
      read_forest(train("d.forest", {"--trees", "1", "--seed", "2", "--depth", "6"}));
  e = error_of([&] { merge_forests({a, deeper}, {"s1", "d"}); });
  EXPECT_NE(e.find("requested depth (5 against 6)"), std::string::npos) << e;

  TrainedForest other_data = read_forest(train("s2.forest", {"--trees", "1", "--seed", "2"}));
  EXPECT_EQ(error_of([&] { merge_forests({a, other_data}, {"s1", "s2"}); }), "(no error)");
  other_data.datasets_json = "[{\"other\": 1}]";
  e = error_of([&] { merge_forests({a, other_data}, {"s1", "s2"}); });
  EXPECT_NE(e.find("training data"), std::string::npos) << e;

  TrainedForest ojr = a;
  ojr.method = "ojr";
  e = error_of([&] { merge_forests({a, ojr}, {"s1", "x"}); });
  EXPECT_NE(e.find("method (bpc against ojr)"), std::string::npos) << e;

  TrainedForest unkeyed = read_forest(train("s4.forest", {"--trees", "1", "--seed", "4"}));
  unkeyed.training_json = "{}";
  e = error_of([&] { merge_forests({a, unkeyed}, {"s1", "s4"}); });
  EXPECT_NE(e.find("names no seed"), std::string::npos) << e;

  e = error_of([&] { merge_forests({a}, {"s1"}); });
  EXPECT_NE(e.find("at least two"), std::string::npos) << e;
  // The command refuses training options beside --merge.
  e = error_of([&] {
    testsupport::run_cli({"train", "--merge", s1 + "," + joint, "--data", data_, "--out", tmp_.path + "/x.forest"});
  });
  EXPECT_NE(e.find("not --data"), std::string::npos) << e;
}

}  // namespace
}  // namespace dp::train
