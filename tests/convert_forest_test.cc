// `depthpose convert FOREST`: quantization bounds, padding, exact leaf agreement with the trained
// forest's reference evaluator, byte-identical output, and the command line.
#include <gtest/gtest.h>

#include <bzlib.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "tools/cli/command.h"
#include "tools/common/body_model.h"
#include "tools/common/error.h"
#include "tools/convert/forest_convert.h"
#include "tools/eval/blob_rebuild.h"
#include "tools/convert/pcl_import.h"
#include "tools/demo/fixtures.h"
#include "tools/train/forest_file.h"
#include "tests/convert_test_support.h"

using namespace dp;

namespace {

}  // namespace

TEST(ConvertForest, BpcLeavesMatchTheTrainedForestExactly) {
  const train::TrainedForest f = random_trained_forest(1, "bpc", 3, 9, 0.8);
  tools::QuantizationReport rep;
  tools::ConvertOptions lossless;
  lossless.bpc = tools::BpcCompaction{blob::kMaxParts, 1};
  const std::vector<uint8_t> bytes = blob::write_blob(tools::convert_forest(f, lossless, "test", &rep));
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  int deepest = 0;
  for (const auto& t : f.trees) deepest = std::max(deepest, t.max_leaf_level());
  EXPECT_EQ(b.depth(), deepest);
  size_t nodes = 0;
  for (const auto& t : f.trees) nodes += t.nodes.size();
  EXPECT_EQ(b.total_nodes, nodes) << "the blob stores the trained nodes, nothing padded";
  EXPECT_GT(rep.leaf_nodes, 0u);
  // Leaves: every pixel of every sample frame, both runtime kernels, at two focal lengths.
  const auto frames = tools::sample_frames(160, 120, 6);
  for (float focal : {262.5f * 160 / 320, 300.0f}) {
    const tools::LeafCheck check = tools::check_leaves(f, bytes, frames, 160, 120, focal);
    EXPECT_GT(check.pixels, 50000u);
    EXPECT_EQ(check.mismatches, 0u) << "focal " << focal;
  }
  // Quantization: below 2^-15 per probability, sums ≤ 32768.
  EXPECT_LT(rep.worst_probability_error, 1.0 / 32768.0);
  size_t record = 0;
  for (const auto& t : f.trees)
    for (size_t l = 0; l < t.leaf_count(); ++l, ++record) {
      uint32_t sum = 0, dense[blob::kMaxParts] = {};
      blob::add_bpc_leaf(b, uint32_t(record), dense);
      for (int p = 0; p < tools::kPartCount; ++p) {
        const uint32_t q = dense[p];
        sum += q;
        EXPECT_LT(std::fabs(q / 32768.0 - t.part_probabilities[l * tools::kPartCount + p]), 1.0 / 32768.0);
      }
      EXPECT_LE(sum, 32768u);
      EXPECT_GE(sum, 32767u);
    }
  // Joints: our 16 with the documented masks.
  ASSERT_EQ(b.meta->joint_count, tools::kJointCount);
  EXPECT_EQ(b.config->joints[0].part_mask, 0xFu);          // head = head_lu|head_ru|head_lw|head_rw
  EXPECT_EQ(b.config->joints[1].part_mask, 1u << 4);       // neck
  EXPECT_EQ(b.config->joints[15].part_mask, 1u << 30);     // foot_r
}

TEST(ConvertForest, TrainedNodesBecomeBreadthFirstSparseNodes) {
  const train::TrainedForest f = random_trained_forest(2, "bpc", 1, 7, 0.5);
  const blob::BlobContents c = tools::convert_forest(f, {}, "test", nullptr);
  const auto& trained = f.trees[0].nodes;
  ASSERT_EQ(c.tree_nodes[0].size(), trained.size()) << "pad-free: one blob node per trained node";
  for (size_t i = 0; i < trained.size(); ++i) {
    const train::TrainedNode& n = trained[i];
    const uint32_t m = uint32_t(i + 1), left = c.tree_left_child[0][i];
    if (n.is_leaf()) {
      EXPECT_EQ(left, m) << "a leaf node points to itself";
      EXPECT_EQ(c.tree_nodes[0][i].threshold_mm, blob::kPadThreshold);
      EXPECT_EQ(c.tree_leaf_index[0][i], uint32_t(n.leaf));
      continue;
    }
    EXPECT_EQ(c.tree_nodes[0][i].threshold_mm, int16_t(n.threshold_mm));
    ASSERT_LT(left, trained.size());
    EXPECT_EQ(trained[left - 1].heap_index, 2 * n.heap_index + 1) << "left child of heap node " << n.heap_index;
    EXPECT_EQ(trained[left].heap_index, 2 * n.heap_index + 2);
  }
}

TEST(ConvertForest, OjrVotesQuantizedWithinBounds) {
  const train::TrainedForest f = random_trained_forest(3, "ojr", 2, 8, 0.8, 6);
  tools::QuantizationReport rep;
  tools::ConvertOptions lossless;
  lossless.ojr = tools::OjrCompaction{blob::kMaxVotesPerLeafJoint, 0, 0.0};
  const blob::BlobContents c = tools::convert_forest(f, lossless, "test", &rep);
  EXPECT_EQ(c.votes_per_joint, blob::kMaxVotesPerLeafJoint);
  EXPECT_GT(rep.dropped_votes, 0u);            // K = 6 > 4
  EXPECT_LE(rep.worst_vote_offset_error_mm, 0.5);
  EXPECT_GT(rep.clamped_vote_components, 0u);  // dx up to ±2.5 m > 2000 mm
  EXPECT_LT(rep.worst_vote_weight_rel_error, 0.01);
  const std::vector<uint8_t> bytes = blob::write_blob(c);
  const tools::LeafCheck check = tools::check_leaves(f, bytes, tools::sample_frames(160, 120, 4), 160, 120, 262.5f);
  EXPECT_EQ(check.mismatches, 0u);
  // The heaviest vote of joint 0 of the first leaf is kept first, its offset rounded to mm.
  const train::LeafVote* in = &f.trees[0].votes[0];
  int heaviest = 0;
  for (int k = 1; k < 6; ++k)
    if (in[k].weight > in[heaviest].weight) heaviest = k;
  EXPECT_NEAR(c.ojr_leaves[0].dy_mm, in[heaviest].dy * 1000.0, 0.5);
  EXPECT_GT(c.ojr_leaves[0].weight, 0);
}

TEST(ConvertForest, CommandWritesByteIdenticalBlobs) {
  TempDir dir;
  const std::string forest = dir.path + "/f.forest";
  train::write_forest(forest, random_trained_forest(4, "bpc", 2, 8, 0.85));
  ASSERT_EQ(run_cli({"convert", forest, "--out", dir.path + "/a.blob", "--check-frames", "3"}), 0);
  ASSERT_EQ(run_cli({"convert", forest, "--out", dir.path + "/b.blob", "--check-frames", "3"}), 0);
  const std::vector<uint8_t> a = blob::read_blob_file(dir.path + "/a.blob");
  EXPECT_EQ(a, blob::read_blob_file(dir.path + "/b.blob"));
  blob::LoadedBlob b;
  EXPECT_EQ(blob::load_blob(a.data(), a.size(), &b), blob::BlobStatus::kOk);
  EXPECT_THROW(run_cli({"convert", dir.path + "/missing.forest", "--out", dir.path + "/c.blob"}), tools::ToolError);
  EXPECT_THROW(run_cli({"convert", forest, "--out", dir.path + "/c.blob", "--max-size", "0x9"}), tools::ToolError);
}

TEST(ConvertForest, RefusesWhatABlobCannotHold) {
  train::TrainedForest f = random_trained_forest(5, "bpc", 1, 6, 0.9);
  f.trees[0].nodes[0].du1 = 5000;  // beyond kMaxProbeOffsetPxm
  EXPECT_THROW(tools::convert_forest(f, {}, "test", nullptr), tools::ToolError);
  train::TrainedForest g = random_trained_forest(6, "bpc", 1, 6, 0.9);
  g.part_names = std::vector<std::string>(g.part_names.size(), "x");
  EXPECT_THROW(tools::convert_forest(g, {}, "test", nullptr), tools::ToolError);  // no joint maps
}

namespace {
void write_bz2(const std::string& path, const std::string& text) {
  FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  int err = 0;
  BZFILE* bz = BZ2_bzWriteOpen(&err, f, 9, 0, 0);
  BZ2_bzWrite(&err, bz, const_cast<char*>(text.data()), int(text.size()));
  BZ2_bzWriteClose(&err, bz, 0, nullptr, nullptr);
  std::fclose(f);
}
// A depth-2 PCL tree: 3 nodes, 4 leaf labels.
const char* const kSmallPclTree =
    "2\n  -86   -26   201   -24  -229\n  -75  -225    -8     5   223\n 74 -85 0 0 223\n"
    "19\n3\n10\n24\n";
}  // namespace

TEST(ConvertPcl, ReadsTheTreeFormatAndWritesABlob) {
  TempDir dir;
  write_bz2(dir.path + "/t1.bz2", kSmallPclTree);
  write_bz2(dir.path + "/t2.bz2", kSmallPclTree);
  const tools::PclTree t = tools::read_pcl_tree(dir.path + "/t1.bz2");
  ASSERT_EQ(t.depth, 2);
  ASSERT_EQ(t.nodes.size(), 3u);
  EXPECT_EQ(t.nodes[0].du1, -86);
  EXPECT_EQ(t.nodes[0].threshold_mm, -229);
  EXPECT_EQ(t.nodes[2].du1, 74);
  EXPECT_EQ(t.leaf_labels, (std::vector<uint8_t>{19, 3, 10, 24}));
  ASSERT_EQ(run_cli({"convert", "--from-pcl", dir.path + "/t1.bz2", dir.path + "/t2.bz2", "--out",
                         dir.path + "/p.blob"}),
            0);
  const std::vector<uint8_t> bytes = blob::read_blob_file(dir.path + "/p.blob");
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  EXPECT_EQ(b.tree_count(), 2);
  // One record per leaf node (blob_format.h), one-hot on the slot's label: each tree's 3 split nodes,
  // then its 4 leaf slots as nodes 4..7, records tree_first_leaf[t] + 0..3 with labels 19, 3, 10, 24.
  ASSERT_EQ(b.tree_node_count(1), 7u);
  EXPECT_EQ(b.tree_first_leaf[1], 4u);
  EXPECT_EQ(b.meta->leaf_count, 8u);
  const uint8_t labels[4] = {19, 3, 10, 24};
  for (uint32_t record = 0; record < 8; ++record) {
    ASSERT_EQ(b.leaf_size(record), 1u) << "a one-hot record stores one entry";
    EXPECT_EQ(b.bpc_probabilities()[b.leaf_first(record)], 32768);
    EXPECT_EQ(b.entry_tags[b.leaf_first(record)], labels[record % 4]) << "record " << record;
  }
  EXPECT_STREQ(b.meta->part_names[24], "Lchest");
}

TEST(ConvertPcl, RefusesBrokenFiles) {
  TempDir dir;
  write_bz2(dir.path + "/label.bz2", "1\n0 0 0 0 5\n3\n25\n");          // label 25 is not a PCL part
  write_bz2(dir.path + "/short.bz2", "2\n0 0 0 0 5\n1 1 1 1 1\n");       // ends inside the nodes
  write_bz2(dir.path + "/height.bz2", "21\n");                           // deeper than kMaxDepth
  write_bz2(dir.path + "/offset.bz2", "1\n5000 0 0 0 5\n3\n4\n");         // offset out of range
  write_bz2(dir.path + "/trail.bz2", "1\n0 0 0 0 5\n3\n4\n7\n");          // trailing data
  write_bz2(dir.path + "/text.bz2", "1\n0 0 zero 0 5\n3\n4\n");           // not a number
  for (const char* name : {"label", "short", "height", "offset", "trail", "text"})
    EXPECT_THROW(tools::read_pcl_tree(dir.path + "/" + name + ".bz2"), tools::ToolError) << name;
  std::FILE* plain = std::fopen((dir.path + "/plain.bz2").c_str(), "wb");
  std::fputs("1\n0 0 0 0 5\n3\n4\n", plain);
  std::fclose(plain);
  EXPECT_THROW(tools::read_pcl_tree(dir.path + "/plain.bz2"), tools::ToolError);  // not bzip2
  EXPECT_THROW(tools::read_pcl_tree(dir.path + "/absent.bz2"), tools::ToolError);
}

TEST(ConvertForest, BpcCompactionKeepsTheHeaviestPartsAboveTheFloor) {
  blob::BlobContents c = tools::single_part_bpc(6, 0, 1, 40);
  // One record: parts 1 and 4 tie at 8000; part 5 (300) is below a floor of 656.
  c.bpc_leaves = {0, 8000, 12000, 4000, 8000, 300};
  tools::CompactionReport r = tools::compact_bpc_leaves(&c, tools::BpcCompaction{2, 656});
  EXPECT_EQ(c.bpc_leaves, (std::vector<uint16_t>{0, 8000, 12000, 0, 0, 0})) << "ties go to the lower part";
  EXPECT_EQ(r.dropped_parts, 3u);
  EXPECT_DOUBLE_EQ(r.worst_dropped_mass, 12300 / 32768.0);
  c.bpc_leaves = {0, 8000, 12000, 4000, 8000, 300};
  r = tools::compact_bpc_leaves(&c, tools::BpcCompaction{blob::kMaxParts, 1});
  EXPECT_EQ(r.dropped_parts, 0u) << "the lossless setting keeps every nonzero part";
  EXPECT_THROW(tools::compact_bpc_leaves(&c, tools::BpcCompaction{0, 1}), tools::ToolError);
  EXPECT_THROW(tools::compact_bpc_leaves(&c, tools::BpcCompaction{4, 0}), tools::ToolError);
  // The blob stores only what is left: 2 entries.
  c.bpc_leaves = {0, 8000, 12000, 4000, 8000, 300};
  tools::compact_bpc_leaves(&c, tools::BpcCompaction{});
  std::vector<uint8_t> bytes = blob::write_blob(c);
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  EXPECT_EQ(b.meta->entry_count, 4u);  // the default keeps 4 parts ≥ 0.02: 8000, 12000, 4000, 8000
}

TEST(ConvertForest, OjrCompactionKeepsTheHeaviestShortVotes) {
  blob::BlobContents c = tools::single_vote_ojr(2, 0, 0, 0);
  c.votes_per_joint = 4;
  c.config.joints[1].vote_length_mm = 500;
  // Joint 0: weights 10, 40, 40, 5 (share 0.05 of 95); lane 2 is 300 mm long. Joint 1: one vote.
  c.ojr_leaves = {{0, 0, 100, 10}, {0, 50, 0, 40}, {300, 0, 0, 40}, {0, 0, -20, 5}, {0, 0, 0, 0}, {0, 0, 0, 0},
                  {0, 10, 0, 7}, {0, 0, 0, 0}};
  const std::vector<blob::OjrVote> original = c.ojr_leaves;
  tools::OjrCompactionReport r = tools::compact_ojr_leaves(&c, tools::OjrCompaction{2, 0, 0.0});
  EXPECT_EQ(r.votes_before, 5u);
  EXPECT_EQ(r.votes_after, 3u);
  EXPECT_EQ(r.dropped_beyond_k, 2u);
  EXPECT_EQ(c.ojr_leaves[1].weight, 40) << "ties go to the lower lane";
  EXPECT_EQ(c.ojr_leaves[2].weight, 40);
  EXPECT_EQ(c.ojr_leaves[0].weight, 0);
  EXPECT_EQ(c.ojr_leaves[3].weight, 0);
  EXPECT_EQ(c.ojr_leaves[6].weight, 7);
  EXPECT_EQ(c.config.joints[0].vote_length_mm, 0) << "no length cut: the config is untouched";

  c.ojr_leaves = original;
  r = tools::compact_ojr_leaves(&c, tools::OjrCompaction{4, 250, 0.1});
  EXPECT_EQ(r.dropped_long, 1u);   // lane 2: 300 mm
  EXPECT_EQ(r.dropped_light, 1u);  // lane 3: 5 < 0.1 · 95
  EXPECT_EQ(r.votes_after, 3u);
  EXPECT_EQ(c.ojr_leaves[2].weight, 0);
  EXPECT_EQ(c.ojr_leaves[3].weight, 0);
  EXPECT_EQ(c.ojr_leaves[0].weight, 10) << "10 ≥ 0.1 · 95 stays";
  EXPECT_EQ(c.config.joints[0].vote_length_mm, 250) << "no limit becomes the cut";
  EXPECT_EQ(c.config.joints[1].vote_length_mm, 250) << "a longer limit becomes the cut";

  c.ojr_leaves = original;
  r = tools::compact_ojr_leaves(&c, tools::OjrCompaction{blob::kMaxVotesPerLeafJoint, 0, 0.0});
  EXPECT_EQ(r.votes_after, r.votes_before) << "the lossless setting keeps every vote";
  EXPECT_THROW(tools::compact_ojr_leaves(&c, tools::OjrCompaction{0, 0, 0.0}), tools::ToolError);
  EXPECT_THROW(tools::compact_ojr_leaves(&c, tools::OjrCompaction{5, 0, 0.0}), tools::ToolError);
  EXPECT_THROW(tools::compact_ojr_leaves(&c, tools::OjrCompaction{1, 4001, 0.0}), tools::ToolError);
  EXPECT_THROW(tools::compact_ojr_leaves(&c, tools::OjrCompaction{1, 0, 1.5}), tools::ToolError);
  // Per-joint cuts: joint 0 at 250 mm (lane 2 goes), joint 1 at 5 mm (its 11 mm vote goes); each
  // joint's vote length becomes its own cut, and a cut of 0 leaves its joint alone.
  c.ojr_leaves = original;
  c.config.joints[0].vote_length_mm = 0;
  c.config.joints[1].vote_length_mm = 500;
  tools::OjrCompaction per_joint{4, 300, 0.0, {250, 5}, {}};
  r = tools::compact_ojr_leaves(&c, per_joint);
  EXPECT_EQ(r.dropped_long, 2u);
  EXPECT_EQ(c.ojr_leaves[2].weight, 0);
  EXPECT_EQ(c.ojr_leaves[6].weight, 0);
  EXPECT_EQ(c.ojr_leaves[0].weight, 10);
  EXPECT_EQ(c.config.joints[0].vote_length_mm, 250);
  EXPECT_EQ(c.config.joints[1].vote_length_mm, 5);
  c.ojr_leaves = original;
  c.config.joints[1].vote_length_mm = 500;
  r = tools::compact_ojr_leaves(&c, tools::OjrCompaction{4, 300, 0.0, {0, 5}, {}});
  EXPECT_EQ(r.dropped_long, 1u) << "joint 0 uncut, even its 300 mm vote";
  EXPECT_EQ(c.ojr_leaves[2].weight, 40);
  EXPECT_EQ(c.config.joints[1].vote_length_mm, 5);
  EXPECT_THROW(tools::compact_ojr_leaves(&c, tools::OjrCompaction{4, 0, 0.0, {100}, {}}), tools::ToolError)
      << "one length for two joints";
  EXPECT_THROW(tools::compact_ojr_leaves(&c, tools::OjrCompaction{4, 0, 0.0, {100, 4001}, {}}), tools::ToolError);
  const std::vector<std::string> names = c.joint_names;
  EXPECT_NO_THROW(tools::compact_ojr_leaves(&c, tools::OjrCompaction{4, 0, 0.0, {100, 100}, names}));
  EXPECT_THROW(tools::compact_ojr_leaves(&c, tools::OjrCompaction{4, 0, 0.0, {100, 100}, {names[1], names[0]}}),
               tools::ToolError)
      << "lengths for the joints in another order";
  // The blob stores only what is left.
  c.ojr_leaves = original;
  tools::compact_ojr_leaves(&c, tools::OjrCompaction{1, 0, 0.0});
  const std::vector<uint8_t> bytes = blob::write_blob(c);
  blob::LoadedBlob b;
  ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  EXPECT_EQ(b.meta->entry_count, 2u);
}

TEST(ConvertForest, CommandAppliesAndChecksTheOjrCompactionOptions) {
  TempDir dir;
  const std::string forest = dir.path + "/o.forest";
  train::write_forest(forest, random_trained_forest(5, "ojr", 2, 6, 0.8, 2));
  auto entries = [&](const std::string& name) {
    const std::vector<uint8_t> bytes = blob::read_blob_file(dir.path + "/" + name);
    blob::LoadedBlob b;
    EXPECT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
    return std::pair{b.meta->entry_count, b.config->joints[0].vote_length_mm};
  };
  ASSERT_EQ(run_cli({"convert", forest, "--out", dir.path + "/all.blob", "--check-frames", "0", "--ojr-max-length",
                         "0"}),
            0);
  ASSERT_EQ(run_cli({"convert", forest, "--out", dir.path + "/cut.blob", "--check-frames", "0"}), 0);
  ASSERT_EQ(run_cli({"convert", forest, "--out", dir.path + "/one.blob", "--check-frames", "0", "--ojr-max-votes",
                         "1", "--ojr-max-length", "0"}),
            0);
  const auto [all, all_len] = entries("all.blob");
  const auto [cut, cut_len] = entries("cut.blob");
  const auto [one, one_len] = entries("one.blob");
  EXPECT_LT(cut, all) << "the default drops votes longer than 0.3 m (the fixture's reach ±2.5 m)";
  EXPECT_EQ(cut_len, 300) << "and lowers the vote length to the cut";
  EXPECT_EQ(all_len, 400) << "no cut: the default config";
  EXPECT_LT(one, all);
  // Cutting at a tuned blob's lengths: a blob whose joint 0 casts 100 mm and joint 1 150 mm.
  {
    const std::vector<uint8_t> bytes = blob::read_blob_file(dir.path + "/all.blob");
    blob::LoadedBlob b;
    ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
    blob::RuntimeConfig tuned = *b.config;
    for (int j = 0; j < int(b.meta->joint_count); ++j) tuned.joints[j].vote_length_mm = 150;
    tuned.joints[0].vote_length_mm = 100;
    blob::save_blob_file(dir.path + "/tuned.blob", tools::blob_with_config(b, tuned));
  }
  ASSERT_EQ(run_cli({"convert", forest, "--out", dir.path + "/from.blob", "--check-frames", "0", "--ojr-lengths-from",
                     dir.path + "/tuned.blob"}),
            0);
  const auto [from, from_len] = entries("from.blob");
  EXPECT_LT(from, cut) << "cuts at 100 and 150 mm keep fewer votes than one at 300 mm";
  EXPECT_EQ(from_len, 100);
  {
    const std::vector<uint8_t> bytes = blob::read_blob_file(dir.path + "/from.blob");
    blob::LoadedBlob b;
    ASSERT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
    EXPECT_EQ(b.config->joints[1].vote_length_mm, 150);
    for (uint32_t e = 0; e < b.meta->entry_count; ++e) {
      const blob::OjrVote& v = b.ojr_votes()[e];
      const int joint = b.entry_tags[e] / b.meta->votes_per_joint;
      const double len = std::sqrt(double(v.dx_mm) * v.dx_mm + double(v.dy_mm) * v.dy_mm + double(v.dz_mm) * v.dz_mm);
      ASSERT_LE(len, joint == 0 ? 100.0 : 150.0) << "entry " << e << " of joint " << joint;
    }
  }
  EXPECT_THROW(run_cli({"convert", forest, "--out", dir.path + "/bad.blob", "--ojr-lengths-from",
                        dir.path + "/tuned.blob", "--ojr-max-length", "0.2"}),
               tools::ToolError);
  EXPECT_THROW(run_cli({"convert", forest, "--out", dir.path + "/bad.blob", "--ojr-lengths-from",
                        dir.path + "/missing.blob"}),
               tools::ToolError);
  for (const char* bad : {"--ojr-max-votes=5", "--ojr-max-length=4.5", "--ojr-min-share=-0.1", "--ojr-min-share=x"}) {
    const std::string option(bad);
    const size_t eq = option.find('=');
    EXPECT_THROW(run_cli({"convert", forest, "--out", dir.path + "/bad.blob", option.substr(0, eq),
                              option.substr(eq + 1)}),
                 tools::ToolError)
        << bad;
  }
}

// `convert --from-blob BLOB --trees N`: the first N trees, every leaf node still holding the record
// contents it held, only the records those trees reach (renumbered), config and names unchanged;
// N = all trees gives the same bytes; bad N and pruning options are refused.
TEST(ConvertForest, FromBlobKeepsTheFirstTreesAndTheirLeaves) {
  TempDir dir;
  for (const char* method : {"bpc", "ojr"}) {
    const train::TrainedForest f = random_trained_forest(7, method, 3, 7, 0.8, 3);
    tools::QuantizationReport rep;
    blob::BlobContents c = tools::convert_forest(f, tools::ConvertOptions{}, "test", &rep);
    c.config.max_votes_per_joint = 77;  // not a converter default: the config must carry over
    const std::string in = dir.path + "/" + method + "3.blob", out = dir.path + "/" + method + "2.blob";
    blob::save_blob_file(in, blob::write_blob(c));
    ASSERT_EQ(run_cli({"convert", "--from-blob", in, "--trees", "2", "--out", out}), 0) << method;
    const std::vector<uint8_t> a_bytes = blob::read_blob_file(in), b_bytes = blob::read_blob_file(out);
    blob::LoadedBlob a, b;
    ASSERT_EQ(blob::load_blob(a_bytes.data(), a_bytes.size(), &a), blob::BlobStatus::kOk);
    ASSERT_EQ(blob::load_blob(b_bytes.data(), b_bytes.size(), &b), blob::BlobStatus::kOk);
    ASSERT_EQ(b.tree_count(), 2) << method;
    EXPECT_EQ(b.config->max_votes_per_joint, 77) << method;
    EXPECT_EQ(std::memcmp(a.config, b.config, sizeof(blob::RuntimeConfig)), 0) << method;
    const blob::BlobContents ac = blob::dense_contents(a), bc = blob::dense_contents(b);
    const size_t stride = std::string(method) == "ojr" ? ac.joint_names.size() * size_t(ac.votes_per_joint) : ac.part_names.size();
    size_t leaf_nodes = 0;
    for (int t = 0; t < 2; ++t) {
      ASSERT_EQ(bc.tree_nodes[t].size(), ac.tree_nodes[t].size()) << method << " tree " << t;
      EXPECT_EQ(std::memcmp(bc.tree_nodes[t].data(), ac.tree_nodes[t].data(), sizeof(blob::TreeNode) * ac.tree_nodes[t].size()), 0);
      EXPECT_EQ(bc.tree_left_child[t], ac.tree_left_child[t]);
      for (size_t m = 0; m < ac.tree_nodes[t].size(); ++m) {
        if (ac.tree_left_child[t][m] != m + 1) continue;
        ++leaf_nodes;
        const uint32_t ra = ac.tree_leaf_index[t][m], rb = bc.tree_leaf_index[t][m];
        if (std::string(method) == "ojr")
          EXPECT_EQ(std::memcmp(&ac.ojr_leaves[ra * stride], &bc.ojr_leaves[rb * stride], sizeof(blob::OjrVote) * stride), 0);
        else
          EXPECT_EQ(std::memcmp(&ac.bpc_leaves[ra * stride], &bc.bpc_leaves[rb * stride], sizeof(uint16_t) * stride), 0);
      }
    }
    EXPECT_EQ(b.meta->leaf_count, leaf_nodes) << method;  // each leaf node its own record here
    EXPECT_LT(b.meta->leaf_count, a.meta->leaf_count) << method;
    ASSERT_EQ(run_cli({"convert", "--from-blob", in, "--trees", "3", "--out", out}), 0) << method;
    EXPECT_EQ(blob::read_blob_file(out), a_bytes) << method;
    for (const char* bad : {"0", "4", "x"})
      EXPECT_THROW(run_cli({"convert", "--from-blob", in, "--trees", bad, "--out", out}), tools::ToolError) << bad;
    EXPECT_THROW(run_cli({"convert", "--from-blob", in, "--out", out}), tools::ToolError);
    EXPECT_THROW(run_cli({"convert", "--from-blob", in, "--trees", "1", "--max-bytes", "100000", "--out", out}), tools::ToolError);
    EXPECT_THROW(run_cli({"convert", "--from-blob", in, "--trees", "1", "--ojr-max-length", "0.2", "--out", out}), tools::ToolError);
  }
}

// Records shared by leaf nodes (allowed by the format) stay shared and are kept once.
TEST(ConvertForest, KeepFirstTreesKeepsASharedRecordOnce) {
  const train::TrainedForest f = random_trained_forest(8, "bpc", 2, 5, 0.8);
  tools::QuantizationReport rep;
  blob::BlobContents c = tools::convert_forest(f, tools::ConvertOptions{}, "test", &rep);
  std::vector<uint32_t*> leaves;
  for (size_t t = 0; t < c.tree_nodes.size(); ++t)
    for (size_t m = 0; m < c.tree_nodes[t].size(); ++m)
      if (c.tree_left_child[t][m] == m + 1) leaves.push_back(&c.tree_leaf_index[t][m]);
  ASSERT_GE(leaves.size(), 4u);
  *leaves[1] = *leaves[0];  // tree 0's second leaf node shares the first one's record
  tools::keep_first_trees(&c, 1);
  ASSERT_EQ(c.tree_nodes.size(), 1u);
  size_t tree0_leaf_nodes = 0;
  for (size_t m = 0; m < c.tree_nodes[0].size(); ++m) tree0_leaf_nodes += c.tree_left_child[0][m] == m + 1;
  EXPECT_EQ(c.bpc_leaves.size() / c.part_names.size(), tree0_leaf_nodes - 1);
  EXPECT_EQ(*leaves[0], 0u);
  EXPECT_EQ(*leaves[1], 0u);
  EXPECT_NO_THROW(blob::write_blob(c));
}
