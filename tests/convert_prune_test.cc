// Pruning a trained forest to a size budget: collapsed subtrees merge their leaves' distributions by
// pixel count, untouched paths keep their leaves, the budget search meets its budget with the
// smallest threshold or refuses, pruning by information gain keeps the splits that separate parts
// and spends a budget across trees, and the command lines refuse bad values.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "runtime/fixed_point.h"
#include "tests/convert_test_support.h"
#include "tools/common/error.h"
#include "tools/convert/forest_convert.h"
#include "tools/train/forest_truncate.h"

using namespace dp;

namespace {

// Root (heap 0) → leaf 1 (40 pixels, all part 0) and split 2 → leaf 5 (2 pixels, parts 0/1 half
// and half) and leaf 6 (10 pixels, 0.1 / 0.9). Subtree pixel counts: root 52, node 2 12.
train::TrainedForest tiny_forest() {
  train::TrainedForest f;
  f.method = "bpc";
  f.reference_focal_px = 262.5f;
  f.depth = 20;
  f.part_names = {"neck", "head"};  // names of joints, so a blob can map them
  f.has_part_distributions = true;
  train::TrainedTree t;
  for (uint32_t h : {0u, 1u, 2u, 5u, 6u}) {
    train::TrainedNode n;
    n.heap_index = h;
    n.du1 = 7;
    n.threshold_mm = 100;
    t.nodes.push_back(n);
  }
  t.nodes[1].leaf = 0;
  t.nodes[3].leaf = 1;
  t.nodes[4].leaf = 2;
  t.leaf_pixel_counts = {40, 2, 10};
  t.part_probabilities = {1.0f, 0.0f, 0.5f, 0.5f, 0.1f, 0.9f};
  f.trees.push_back(t);
  train::link_and_validate(f, "tiny forest");
  return f;
}

// random_trained_forest with pixel counts 0..60 per leaf (so thresholds cut at many levels).
train::TrainedForest random_counted_forest(uint32_t seed, int trees, int depth) {
  train::TrainedForest f = random_trained_forest(seed, "bpc", trees, depth, 0.8);
  std::mt19937 rng(seed + 100);
  for (auto& t : f.trees)
    for (uint32_t& c : t.leaf_pixel_counts) c = rng() % 61;
  return f;
}

// Root → split 1 → leaves 3, 4 (100 pixels each, both parts half and half: the split separates
// nothing) and split 2 → leaves 5 (5 pixels, all part 0), 6 (5 pixels, all part 1: a perfect
// split of few pixels). Gains: split 1 zero bits, split 2 ten bits.
train::TrainedForest gain_forest() {
  train::TrainedForest f;
  f.method = "bpc";
  f.reference_focal_px = 262.5f;
  f.depth = 20;
  f.part_names = {"neck", "head"};
  f.has_part_distributions = true;
  train::TrainedTree t;
  for (uint32_t h : {0u, 1u, 2u, 3u, 4u, 5u, 6u}) {
    train::TrainedNode n;
    n.heap_index = h;
    n.du1 = 7;
    n.threshold_mm = 100;
    t.nodes.push_back(n);
  }
  for (int i = 3; i < 7; ++i) t.nodes[size_t(i)].leaf = i - 3;
  t.leaf_pixel_counts = {100, 100, 5, 5};
  t.part_probabilities = {0.5f, 0.5f, 0.5f, 0.5f, 1.0f, 0.0f, 0.0f, 1.0f};
  f.trees.push_back(t);
  train::link_and_validate(f, "gain forest");
  return f;
}

size_t blob_bytes_at(const train::TrainedForest& f, uint64_t min_pixels) {
  const train::TrainedForest p = min_pixels ? train::prune_forest(f, min_pixels) : f;
  return blob::write_blob(tools::convert_forest(p, {}, "test", nullptr)).size();
}

}  // namespace

TEST(ConvertPrune, CollapsedSubtreeMergesDistributionsByPixelCount) {
  const train::TrainedForest f = tiny_forest();
  train::PruneReport rep;
  const train::TrainedForest p = train::prune_forest(f, 13, &rep);
  ASSERT_EQ(p.trees[0].nodes.size(), 3u);
  EXPECT_EQ(p.trees[0].nodes[2].heap_index, 2u);
  EXPECT_EQ(p.trees[0].nodes[2].leaf, 1);
  EXPECT_EQ(p.trees[0].nodes[2].threshold_mm, 0.0f) << "a collapsed split keeps no feature";
  EXPECT_EQ(p.trees[0].nodes[1].leaf, 0);
  EXPECT_EQ(p.trees[0].leaf_pixel_counts, (std::vector<uint32_t>{40, 12}));
  EXPECT_FLOAT_EQ(p.trees[0].part_probabilities[2], (2 * 0.5f + 10 * 0.1f) / 12);
  EXPECT_FLOAT_EQ(p.trees[0].part_probabilities[3], (2 * 0.5f + 10 * 0.9f) / 12);
  EXPECT_FLOAT_EQ(p.trees[0].part_probabilities[0], 1.0f);
  EXPECT_EQ(rep.collapsed_splits, 1u);
  EXPECT_EQ(rep.leaves_before, 3u);
  EXPECT_EQ(rep.leaves_after, 2u);
  EXPECT_EQ(rep.depth_before, 2);
  EXPECT_EQ(rep.depth_after, 1);
  EXPECT_EQ(p.depth, 20) << "the requested depth is kept; the blob records the deepest leaf";

  // At 12 the subtree of node 2 holds enough pixels: nothing changes.
  const train::TrainedForest same = train::prune_forest(f, 12);
  EXPECT_EQ(same.trees[0].nodes.size(), 5u);
  EXPECT_EQ(same.trees[0].part_probabilities, f.trees[0].part_probabilities);
  // Above the root's 52 pixels the tree becomes one leaf with the whole tree's distribution.
  EXPECT_EQ(train::prune_everything_threshold(f), 53u);
  const train::TrainedForest root = train::prune_forest(f, 53);
  ASSERT_EQ(root.trees[0].nodes.size(), 1u);
  EXPECT_FLOAT_EQ(root.trees[0].part_probabilities[0], (40 + 1 + 1) / 52.0f);
  EXPECT_FLOAT_EQ(root.trees[0].part_probabilities[1], (1 + 9) / 52.0f);
  // A one-leaf tree still makes a valid blob (depth 1: the root's self-loop).
  const std::vector<uint8_t> bytes = blob::write_blob(tools::convert_forest(root, {}, "test", nullptr));
  blob::LoadedBlob b;
  EXPECT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);

  // A subtree without pixels merges to the zero distribution its empty leaves had.
  train::TrainedForest empty = f;
  empty.trees[0].leaf_pixel_counts = {40, 0, 0};
  empty.trees[0].part_probabilities = {1.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  const train::TrainedForest pe = train::prune_forest(empty, 1);
  EXPECT_EQ(pe.trees[0].part_probabilities, (std::vector<float>{1.0f, 0.0f, 0.0f, 0.0f}));
}

TEST(ConvertPrune, PixelsAvoidingCollapsedNodesKeepTheirLeaf) {
  const train::TrainedForest f = random_counted_forest(11, 2, 12);
  train::PruneReport rep;
  const train::TrainedForest p = train::prune_forest(f, 120, &rep);
  ASSERT_GT(rep.collapsed_splits, 0u);
  ASSERT_LT(rep.leaves_after, rep.leaves_before);
  const int width = 160, height = 120;
  const auto frames = tools::sample_frames(width, height, 3);
  const int32_t focal_factor = dp::focal_factor_mm(131.25f, f.reference_focal_px);
  uint64_t same = 0, merged = 0;
  for (const auto& depth : frames) {
    const std::vector<uint16_t> probe = train::make_probe_image(depth.data(), nullptr, width, height);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) {
        if (probe[size_t(v) * width + u] >= 32767) continue;
        for (size_t t = 0; t < f.trees.size(); ++t) {
          const train::TrainedNode& full = f.trees[t].nodes[size_t(
              train::leaf_node_for_pixel(f.trees[t], probe.data(), width, height, u, v, focal_factor))];
          const train::TrainedNode& cut = p.trees[t].nodes[size_t(
              train::leaf_node_for_pixel(p.trees[t], probe.data(), width, height, u, v, focal_factor))];
          // The pruned leaf is the full leaf or one of its ancestors.
          uint32_t h = full.heap_index;
          while (h > cut.heap_index) h = (h - 1) / 2;
          ASSERT_EQ(h, cut.heap_index);
          if (cut.heap_index != full.heap_index) {
            ++merged;
            continue;
          }
          ++same;
          for (size_t c = 0; c < f.part_names.size(); ++c)
            ASSERT_EQ(p.trees[t].part_probabilities[size_t(cut.leaf) * f.part_names.size() + c],
                      f.trees[t].part_probabilities[size_t(full.leaf) * f.part_names.size() + c]);
        }
      }
  }
  EXPECT_GT(same, 1000u);
  EXPECT_GT(merged, 1000u);
  // The pruned blob loads and its kernels reach the pruned forest's leaves.
  tools::QuantizationReport q;
  const std::vector<uint8_t> bytes = blob::write_blob(tools::convert_forest(p, {}, "test", &q));
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  EXPECT_EQ(b.depth(), rep.depth_after);
  EXPECT_EQ(tools::check_leaves(p, bytes, frames, width, height, 131.25f).mismatches, 0u);
}

TEST(ConvertPrune, BudgetIsMetWithTheSmallestThresholdOrRefused) {
  const train::TrainedForest f = random_counted_forest(12, 3, 11);
  const size_t lossless = blob_bytes_at(f, 0), smallest = blob_bytes_at(f, train::prune_everything_threshold(f));
  ASSERT_LT(smallest, lossless / 4);
  const uint64_t budget = lossless / 2;
  const tools::BudgetedBlob b = tools::convert_within_budget(f, {}, {0, budget}, "test");
  EXPECT_LE(b.bytes.size(), budget);
  ASSERT_GT(b.min_leaf_pixels, 1u);
  EXPECT_GT(blob_bytes_at(f, b.min_leaf_pixels - 1), budget) << "the smallest fitting threshold";
  EXPECT_EQ(b.bytes, blob::write_blob(tools::convert_forest(train::prune_forest(f, b.min_leaf_pixels), {}, "t", nullptr)));
  EXPECT_LT(b.prune.leaves_after, b.prune.leaves_before);
  // A budget the lossless blob meets prunes nothing; a floor above the search's start is kept.
  EXPECT_EQ(tools::convert_within_budget(f, {}, {0, lossless}, "test").min_leaf_pixels, 0u);
  EXPECT_EQ(tools::convert_within_budget(f, {}, {5000, budget}, "test").min_leaf_pixels, 5000u);
  // Too small for even one leaf per tree: refused, naming that size.
  try {
    tools::convert_within_budget(f, {}, {0, smallest - 1}, "f.forest");
    ADD_FAILURE() << "an impossible budget was accepted";
  } catch (const tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("--max-bytes " + std::to_string(smallest - 1) + " cannot be met"),
              std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(std::to_string(smallest) + " bytes"), std::string::npos) << e.what();
  }
  EXPECT_EQ(tools::convert_within_budget(f, {}, {0, smallest}, "test").bytes.size(), smallest);
  // OJR votes do not merge: pruning is refused, and a budget only checked.
  const train::TrainedForest ojr = random_trained_forest(13, "ojr", 1, 8, 0.8);
  EXPECT_THROW(tools::convert_within_budget(ojr, {}, {10, 0}, "test"), tools::ToolError);
  EXPECT_THROW(train::prune_forest(ojr, 10), tools::ToolError);
  try {
    tools::convert_within_budget(ojr, {}, {0, 1000}, "o.forest");
    ADD_FAILURE() << "an OJR blob above its budget was accepted";
  } catch (const tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("--structure-min-pixels"), std::string::npos) << e.what();
  }
}

TEST(ConvertPrune, GainOrderCollapsesTheSplitThatSeparatesNothingFirst) {
  const train::TrainedForest f = gain_forest();
  // By pixel count the small, informative split goes first ...
  const train::TrainedForest by_pixels = train::prune_forest(f, 20);
  ASSERT_EQ(by_pixels.trees[0].leaf_count(), 3u);
  EXPECT_EQ(by_pixels.trees[0].nodes[2].heap_index, 2u);
  EXPECT_TRUE(by_pixels.trees[0].nodes[2].is_leaf());
  // ... by gain the large split whose children carry the same distribution does.
  const train::GainPruneOrder order(f);
  EXPECT_EQ(order.leaf_count(), 4u);
  EXPECT_EQ(order.min_leaves(), 1u);
  train::PruneReport rep;
  const train::TrainedForest three = order.prune_to(3, &rep);
  const train::TrainedTree& t = three.trees[0];
  ASSERT_EQ(t.leaf_count(), 3u);
  EXPECT_EQ(rep.leaves_after, 3u);
  EXPECT_EQ(rep.collapsed_splits, 1u);
  ASSERT_EQ(t.nodes.size(), 5u);
  EXPECT_TRUE(t.nodes[1].is_leaf()) << "split 1 collapsed";
  EXPECT_FALSE(t.nodes[2].is_leaf()) << "split 2 kept";
  EXPECT_EQ(t.leaf_pixel_counts, (std::vector<uint32_t>{200, 5, 5}));
  EXPECT_EQ(t.part_probabilities, (std::vector<float>{0.5f, 0.5f, 1.0f, 0.0f, 0.0f, 1.0f}));
  // Nested: two leaves = both splits collapsed (only split 2 is left to go); one leaf = the root.
  EXPECT_EQ(order.prune_to(2).trees[0].leaf_count(), 2u);
  const train::TrainedForest root = order.prune_to(1);
  ASSERT_EQ(root.trees[0].nodes.size(), 1u);
  EXPECT_FLOAT_EQ(root.trees[0].part_probabilities[0], 105.0f / 210.0f);
  EXPECT_EQ(order.prune_to(4).trees[0].nodes.size(), 7u) << "as many leaves as trained: nothing collapsed";
  EXPECT_EQ(order.prune_to(1000).trees[0].part_probabilities, f.trees[0].part_probabilities);
  EXPECT_THROW(order.prune_to(0), tools::ToolError);
  // Forests the order cannot rank are refused.
  EXPECT_THROW(train::GainPruneOrder(random_trained_forest(13, "ojr", 1, 8, 0.8)), tools::ToolError);
  train::TrainedForest bare = f;
  bare.has_part_distributions = false;
  bare.trees[0].part_probabilities.clear();
  EXPECT_THROW(train::GainPruneOrder{bare}, tools::ToolError);
}

TEST(ConvertPrune, GainOrderIsNestedAndSpendsTheBudgetAcrossTrees) {
  const train::TrainedForest f = random_counted_forest(16, 3, 11);
  const train::GainPruneOrder order(f);
  size_t previous = SIZE_MAX;
  std::vector<uint64_t> per_tree_before;
  for (const auto& t : f.trees) per_tree_before.push_back(t.leaf_count());
  for (uint64_t k = order.leaf_count(); k >= order.min_leaves(); k = k > 40 ? k - 37 : k - 1) {
    train::PruneReport rep;
    const train::TrainedForest p = order.prune_to(k, &rep);
    EXPECT_EQ(rep.leaves_after, k);
    const size_t bytes = blob::write_blob(tools::convert_forest(p, {}, "test", nullptr)).size();
    EXPECT_LE(bytes, previous) << "the blob never grows as leaves go, at " << k;
    previous = bytes;
    if (k == order.min_leaves()) break;
  }
  // A budget: the largest leaf count whose blob fits; one leaf more does not.
  const size_t lossless = blob::write_blob(tools::convert_forest(f, {}, "test", nullptr)).size();
  tools::PruneBudget budget;
  budget.max_bytes = lossless / 2;
  budget.by_gain = true;
  const tools::BudgetedBlob b = tools::convert_within_budget(f, {}, budget, "test");
  EXPECT_LE(b.bytes.size(), budget.max_bytes);
  ASSERT_GT(b.max_leaves, 0u);
  EXPECT_EQ(b.prune.leaves_after, b.max_leaves);
  EXPECT_GT(blob::write_blob(tools::convert_forest(order.prune_to(b.max_leaves + 1), {}, "t", nullptr)).size(),
            budget.max_bytes);
  EXPECT_EQ(b.bytes, blob::write_blob(tools::convert_forest(order.prune_to(b.max_leaves), {}, "t", nullptr)));
  // The leaves are not cut evenly: each tree keeps what its own splits gain.
  std::vector<uint64_t> kept;
  for (const auto& t : b.forest.trees) kept.push_back(t.leaf_count());
  EXPECT_NE(kept[0] * per_tree_before[1], kept[1] * per_tree_before[0]);
  // A budget the lossless blob meets prunes nothing; an impossible one is refused; OJR is refused.
  budget.max_bytes = lossless;
  EXPECT_EQ(tools::convert_within_budget(f, {}, budget, "test").max_leaves, 0u);
  budget.max_bytes = 100;
  EXPECT_THROW(tools::convert_within_budget(f, {}, budget, "test"), tools::ToolError);
  budget.max_bytes = lossless / 2;
  EXPECT_THROW(tools::convert_within_budget(random_trained_forest(13, "ojr", 1, 8, 0.8), {}, budget, "test"),
               tools::ToolError);
  budget.min_leaf_pixels = 10;
  EXPECT_THROW(tools::convert_within_budget(f, {}, budget, "test"), tools::ToolError);
}

TEST(ConvertPrune, StructureByGainCarriesNoLeafData) {
  const train::TrainedForest f = random_counted_forest(17, 2, 10);
  train::PruneReport rep;
  const train::TrainedForest s = train::prune_structure_by_gain(f, 50, &rep);
  EXPECT_FALSE(s.has_part_distributions);
  EXPECT_FALSE(s.has_votes);
  EXPECT_EQ(rep.leaves_after, 50u);
  EXPECT_EQ(s.trees[0].leaf_count() + s.trees[1].leaf_count(), 50u);
  for (const auto& t : s.trees) EXPECT_TRUE(t.part_probabilities.empty());
  EXPECT_THROW(train::prune_structure_by_gain(f, 1), tools::ToolError) << "two trees keep two roots";
  EXPECT_THROW(train::prune_structure_by_gain(random_trained_forest(13, "ojr", 1, 8, 0.8), 10), tools::ToolError);
}

TEST(ConvertPrune, StructureForRetroFittingCarriesNoLeafData) {
  train::TrainedForest ojr = random_trained_forest(14, "ojr", 2, 10, 0.8);
  std::mt19937 rng(3);
  for (auto& t : ojr.trees)
    for (uint32_t& c : t.leaf_pixel_counts) c = rng() % 61;
  train::PruneReport rep;
  const train::TrainedForest s = train::prune_structure(ojr, 100, &rep);
  EXPECT_FALSE(s.has_votes);
  EXPECT_FALSE(s.has_part_distributions);
  EXPECT_LT(rep.leaves_after, rep.leaves_before);
  size_t leaves = 0;
  for (const auto& t : s.trees) {
    leaves += t.leaf_count();
    EXPECT_TRUE(t.votes.empty());
  }
  EXPECT_EQ(leaves, rep.leaves_after);
  EXPECT_THROW(train::prune_structure(ojr, 0), tools::ToolError);
}

TEST(ConvertPrune, CommandPrunesToTheBudgetAndRefusesBadValues) {
  TempDir dir;
  const std::string forest = dir.path + "/f.forest", out = dir.path + "/p.blob";
  const train::TrainedForest f = random_counted_forest(15, 2, 11);
  train::write_forest(forest, f);
  const size_t lossless = blob_bytes_at(f, 0), smallest = blob_bytes_at(f, train::prune_everything_threshold(f));
  ASSERT_LT(smallest, lossless);
  const size_t budget = (lossless + smallest) / 2;
  ASSERT_EQ(run_cli({"convert", forest, "--out", out, "--max-bytes", std::to_string(budget), "--check-frames", "2"}),
            0);
  EXPECT_LE(blob::read_blob_file(out).size(), budget);
  ASSERT_EQ(run_cli({"convert", forest, "--out", out, "--min-leaf-pixels", "200", "--check-frames", "2"}), 0);
  EXPECT_EQ(blob::read_blob_file(out).size(), blob_bytes_at(f, 200));
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"--max-bytes", "0"}, {"--max-bytes", "-3"}, {"--max-bytes", "16MB"},
        {"--min-leaf-pixels", "-1"}, {"--min-leaf-pixels", "x"}, {"--min-leaf-pixels", "5000000000"},
        {"--max-bytes", "10"}}) {
    std::vector<std::string> args = {"convert", forest, "--out", dir.path + "/bad.blob"};
    args.insert(args.end(), bad.begin(), bad.end());
    EXPECT_THROW(run_cli(args), tools::ToolError) << bad[0] << " " << bad[1];
  }
  ASSERT_EQ(run_cli({"convert", forest, "--out", out, "--max-bytes", std::to_string(budget), "--prune-by", "gain",
                     "--check-frames", "2"}),
            0);
  EXPECT_LE(blob::read_blob_file(out).size(), budget);
  EXPECT_THROW(run_cli({"convert", forest, "--out", dir.path + "/bad.blob", "--prune-by", "entropy", "--max-bytes",
                        std::to_string(budget)}),
               tools::ToolError);
  EXPECT_THROW(run_cli({"convert", forest, "--out", dir.path + "/bad.blob", "--prune-by", "gain"}), tools::ToolError)
      << "gain needs a budget";
  // --trees keeps the first trees: the budget then goes to their leaves alone.
  ASSERT_EQ(run_cli({"convert", forest, "--out", out, "--trees", "1", "--check-frames", "2"}), 0);
  {
    const std::vector<uint8_t> bytes = blob::read_blob_file(out);
    blob::LoadedBlob b;
    ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
    EXPECT_EQ(b.tree_count(), 1);
    train::TrainedForest first = f;
    first.trees.resize(1);
    EXPECT_EQ(bytes, blob::write_blob(tools::convert_forest(first, {}, "t", nullptr)));
  }
  for (const char* trees : {"0", "3", "x"})
    EXPECT_THROW(run_cli({"convert", forest, "--out", dir.path + "/bad.blob", "--trees", trees}), tools::ToolError)
        << "--trees " << trees << " of a 2-tree forest";
  // Blobs carry no pixel counts: the options are refused with --upgrade-blob.
  try {
    run_cli({"convert", "--upgrade-blob", out, "--out", dir.path + "/bad.blob", "--max-bytes", "1000"});
    ADD_FAILURE() << "--max-bytes with --upgrade-blob was accepted";
  } catch (const tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("prune a trained FOREST"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path + "/bad.blob"));
}
