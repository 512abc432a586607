// The trained-forest file: round trip, refusal of corrupt/truncated/inconsistent files, the
// describe text, and the reference evaluator's padded-slot helper.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <sstream>

#include "runtime/fixed_point.h"
#include "tests/train_toy_data.h"
#include "tools/cli/command.h"
#include "tools/common/error.h"
#include "tools/train/forest_file.h"

namespace dp::train {
namespace {

TrainedForest small_forest() {
  TrainedForest f;
  f.method = "ojr";
  f.reference_focal_px = 285.5f;
  f.depth = 3;
  f.part_names = {"p0", "p1"};
  f.joint_names = {"j0"};
  f.votes_per_joint = 2;
  f.has_part_distributions = true;
  f.has_votes = true;
  f.training_json = R"({"offsets":10})";
  f.datasets_json = R"([{"dir":"x"}])";
  f.timings_json = R"({"structure":1.5})";
  TrainedTree t;
  // root 0 splits; 1 is a leaf; 2 splits into leaves 5 and 6.
  TrainedNode root;
  root.heap_index = 0;
  root.du1 = 10;
  root.dv1 = -20;
  root.threshold_mm = 150;
  TrainedNode a;
  a.heap_index = 1;
  a.leaf = 0;
  TrainedNode b;
  b.heap_index = 2;
  b.du1 = -5;
  b.dv1 = 7;
  b.du2 = 3;
  b.dv2 = 1;
  b.threshold_mm = -42;
  TrainedNode c;
  c.heap_index = 5;
  c.leaf = 2;
  TrainedNode d;
  d.heap_index = 6;
  d.leaf = 1;
  t.nodes = {root, a, b, c, d};
  t.leaf_pixel_counts = {10, 20, 30};
  t.part_probabilities = {1, 0, 0.25f, 0.75f, 0.5f, 0.5f};
  t.votes = {{0.1f, 0.2f, 0.3f, 5}, {0, 0, 0, 0}, {-0.1f, 0, 0.05f, 3}, {0.2f, 0.1f, 0, 1},
             {0, 0, 0.1f, 7}, {0, 0, 0, 0}};
  f.trees.push_back(t);
  link_and_validate(f, "small");
  return f;
}

TEST(TrainForestFile, RoundTripsEveryField) {
  const TrainedForest f = small_forest();
  const std::vector<uint8_t> bytes = serialize_forest(f);
  const TrainedForest g = parse_forest(bytes.data(), bytes.size(), "mem");
  EXPECT_EQ(g.method, "ojr");
  EXPECT_EQ(g.reference_focal_px, 285.5f);
  EXPECT_EQ(g.depth, 3);
  EXPECT_EQ(g.part_names, f.part_names);
  EXPECT_EQ(g.joint_names, f.joint_names);
  EXPECT_EQ(g.votes_per_joint, 2);
  EXPECT_EQ(g.training_json, R"({"offsets":10})");
  ASSERT_EQ(g.trees.size(), 1u);
  const TrainedTree& t = g.trees[0];
  ASSERT_EQ(t.nodes.size(), 5u);
  EXPECT_EQ(t.nodes[2].du1, -5);
  EXPECT_EQ(t.nodes[2].dv2, 1);
  EXPECT_EQ(t.nodes[2].threshold_mm, -42);
  EXPECT_EQ(t.nodes[2].left, 3);
  EXPECT_EQ(t.nodes[2].right, 4);
  EXPECT_EQ(t.nodes[4].leaf, 1);
  EXPECT_EQ(t.leaf_pixel_counts, f.trees[0].leaf_pixel_counts);
  EXPECT_EQ(t.part_probabilities, f.trees[0].part_probabilities);
  ASSERT_EQ(t.votes.size(), 6u);
  EXPECT_EQ(t.votes[4].dz, 0.1f);
  EXPECT_EQ(t.votes[4].weight, 7);
  EXPECT_EQ(serialize_forest(g), bytes) << "serialization is not deterministic";

  testing_toy::TempDir tmp;
  write_forest(tmp.path + "/f.forest", f);
  EXPECT_EQ(serialize_forest(read_forest(tmp.path + "/f.forest")), bytes);
}

void expect_refused(const std::vector<uint8_t>& bytes, const std::string& needle) {
  try {
    parse_forest(bytes.data(), bytes.size(), "bad.forest");
    ADD_FAILURE() << "accepted a file that should fail with '" << needle << "'";
  } catch (const tools::ToolError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("bad.forest"), std::string::npos) << m;
    EXPECT_NE(m.find(needle), std::string::npos) << m;
  }
}

// Rewrites the CRC so that the structural checks, not the checksum, must catch the problem.
void fix_crc(std::vector<uint8_t>& bytes) {
  if (bytes.size() < 4) {
    ADD_FAILURE() << "fix_crc: " << bytes.size() << " bytes hold no CRC";
    return;
  }
  bytes.resize(bytes.size() - 4);
  uint32_t crc = 0xFFFFFFFFu;
  for (uint8_t b : bytes) {
    crc ^= b;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  crc ^= 0xFFFFFFFFu;
  for (int i = 0; i < 4; ++i) bytes.push_back(uint8_t(crc >> (8 * i)));
}

TEST(TrainForestFile, RefusesCorruptTruncatedAndInconsistentFiles) {
  const std::vector<uint8_t> good = serialize_forest(small_forest());
  expect_refused({good.begin(), good.begin() + 10}, "truncated");
  expect_refused({good.begin(), good.end() - 9}, "CRC");
  std::vector<uint8_t> b = good;
  b[0] = 'X';
  expect_refused(b, "magic");
  b = good;
  b[b.size() / 2] ^= 0x40;
  expect_refused(b, "CRC");
  b = good;
  b[8] = 2;  // major version 2
  fix_crc(b);
  expect_refused(b, "newer");

  // Structural problems with a valid CRC.
  uint32_t header = 0;
  for (int i = 0; i < 4; ++i) header |= uint32_t(good[12 + i]) << (8 * i);
  const size_t nodes_at = 16 + header + 8;  // after node_count and leaf_count
  b = good;
  b[nodes_at + 20 * 3] = 7;  // node 5 → heap 7: its parent 3 does not exist
  fix_crc(b);
  expect_refused(b, "parent");
  b = good;
  // Threshold of the root to 150.5 (not a whole number).
  const float half = 150.5f;
  uint32_t bits;
  std::memcpy(&bits, &half, 4);
  for (int i = 0; i < 4; ++i) b[nodes_at + 12 + i] = uint8_t(bits >> (8 * i));
  fix_crc(b);
  expect_refused(b, "threshold");
  b = good;
  b[nodes_at + 20 * 4 + 16] = 0;  // node 6 uses leaf 0, already used by node 1
  fix_crc(b);
  expect_refused(b, "leaf");

  // Too-short files and missing files name the file.
  EXPECT_THROW(read_forest("/nonexistent/x.forest"), tools::ToolError);
}

TEST(TrainForestFile, DescribeNamesTheEssentials) {
  std::ostringstream out;
  describe_forest(small_forest(), out);
  const std::string s = out.str();
  EXPECT_NE(s.find("method ojr"), std::string::npos) << s;
  EXPECT_NE(s.find("1 tree"), std::string::npos) << s;
  EXPECT_NE(s.find("5 nodes, 3 leaves"), std::string::npos) << s;
  EXPECT_NE(s.find("285.5"), std::string::npos) << s;
  EXPECT_NE(s.find("deepest leaf level 2"), std::string::npos) << s;
}

TEST(TrainForestFile, ReferenceEvaluatorAndPaddedSlots) {
  TrainedForest f = small_forest();
  // A 9×9 probe image: background except the centre column at 1000 mm.
  std::vector<uint16_t> depth(81, 0);
  for (int v = 0; v < 9; ++v) depth[v * 9 + 4] = 1000;
  const std::vector<uint16_t> probe = make_probe_image(depth.data(), nullptr, 9, 9);
  EXPECT_EQ(probe[0], kBackgroundDepthMm);
  EXPECT_EQ(probe[4], 1000);
  // Root: δ1 = (10,−20) at 1 m with matching focal: probe off the column → 32767 − 1000 > 150 → right
  // (heap 2). Node 2: δ1 = (−5,7), δ2 = (3,1): both background → 0 > −42 → right (heap 6, leaf 1).
  const int node = leaf_node_for_pixel(f.trees[0], probe.data(), 9, 9, 4, 4, 1000);
  EXPECT_EQ(f.trees[0].nodes[node].heap_index, 6u);
  EXPECT_EQ(f.trees[0].nodes[node].leaf, 1);
  // Padded slots at depth 3: heap 1 (level 1) pads left to heap 7 → slot 0; heap 6 → slot 13−7=6.
  EXPECT_EQ(padded_leaf_slot(1, 3), 0u);
  EXPECT_EQ(padded_leaf_slot(6, 3), 6u);
  EXPECT_EQ(padded_leaf_slot(5, 3), 4u);
  EXPECT_EQ(heap_level(0), 0);
  EXPECT_EQ(heap_level(6), 2);
  EXPECT_EQ(heap_level(7), 3);
}

}  // namespace
}  // namespace dp::train

namespace dp::train {
namespace {

TEST(TrainForestFile, InfoCommandDescribesForestFiles) {
  const cli::Command* info = cli::find_command("info");
  ASSERT_NE(info, nullptr);
  testing_toy::TempDir tmp;
  write_forest(tmp.path + "/f.forest", small_forest());
  std::string name = "info", path = tmp.path + "/f.forest";
  char* argv[] = {name.data(), path.data()};
  ::testing::internal::CaptureStdout();
  const int rc = info->run(2, argv);
  const std::string out = ::testing::internal::GetCapturedStdout();
  EXPECT_EQ(rc, 0);
  EXPECT_NE(out.find("trained forest: method ojr"), std::string::npos) << out;
}

}  // namespace
}  // namespace dp::train
