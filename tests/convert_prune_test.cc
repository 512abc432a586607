// Pruning a trained forest to a size budget: collapsed subtrees merge their leaves' distributions by
// pixel count, untouched paths keep their leaves, the budget search meets its budget with the
// smallest threshold or refuses, and the command lines refuse bad values.
#include <gtest/gtest.h>

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
  const size_t budget = blob_bytes_at(f, 0) * 2 / 3;
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
  // Blobs carry no pixel counts: the options are refused with --upgrade-blob.
  try {
    run_cli({"convert", "--upgrade-blob", out, "--out", dir.path + "/bad.blob", "--max-bytes", "1000"});
    ADD_FAILURE() << "--max-bytes with --upgrade-blob was accepted";
  } catch (const tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("prune a trained FOREST"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path + "/bad.blob"));
}
