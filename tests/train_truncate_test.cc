// truncate_structure: a cut structure keeps the upper splits, turns level-D splits into leaves and
// routes every pixel to the ancestor of the leaf it reached in the full tree.
#include <gtest/gtest.h>

#include "tools/common/error.h"
#include "tools/train/forest_truncate.h"

using namespace dp::train;

namespace {
// A full binary tree of the given depth whose nodes split at threshold = heap index.
TrainedForest full_forest(int depth) {
  TrainedForest f;
  f.method = "bpc";
  f.reference_focal_px = 262.5f;
  f.depth = depth;
  f.part_names = {"a", "b"};
  f.has_part_distributions = true;
  TrainedTree t;
  const uint32_t first_leaf = (1u << depth) - 1;
  for (uint32_t h = 0; h < (2u << depth) - 1; ++h) {
    TrainedNode n;
    n.heap_index = h;
    n.du1 = int16_t(h % 7);
    n.threshold_mm = float(h);
    if (h >= first_leaf) n.leaf = int32_t(h - first_leaf);
    t.nodes.push_back(n);
  }
  t.leaf_pixel_counts.assign(1u << depth, 5);
  t.part_probabilities.assign(size_t(2) << depth, 0.5f);
  f.trees.push_back(t);
  link_and_validate(f, "test");
  return f;
}
}  // namespace

TEST(TrainTruncate, CutsAtDepthAndRenumbersLeaves) {
  const TrainedForest f = full_forest(5);
  const TrainedForest c = truncate_structure(f, 3);
  EXPECT_EQ(c.depth, 3);
  ASSERT_EQ(c.trees.size(), 1u);
  EXPECT_EQ(c.trees[0].nodes.size(), 15u);  // levels 0..3
  EXPECT_EQ(c.trees[0].leaf_count(), 8u);
  EXPECT_FALSE(c.has_part_distributions);
  for (const TrainedNode& n : c.trees[0].nodes) {
    EXPECT_EQ(n.is_leaf(), heap_level(n.heap_index) == 3) << n.heap_index;
    if (!n.is_leaf()) {
      EXPECT_EQ(n.threshold_mm, float(n.heap_index));  // splits kept as they were
    }
  }
  // Leaves numbered in heap order.
  EXPECT_EQ(c.trees[0].nodes[7].leaf, 0);
  EXPECT_EQ(c.trees[0].nodes[14].leaf, 7);
}

TEST(TrainTruncate, DeeperThanTheForestKeepsStructure) {
  const TrainedForest f = full_forest(3);
  const TrainedForest c = truncate_structure(f, 10);
  EXPECT_EQ(c.depth, 3);
  EXPECT_EQ(c.trees[0].nodes.size(), f.trees[0].nodes.size());
  EXPECT_THROW(truncate_structure(f, 0), dp::tools::ToolError);
}
