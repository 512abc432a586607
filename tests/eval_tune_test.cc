// `depthpose tune`: the cached re-aggregation equals the runtime, the blob rebuild is lossless, and
// the grid search repairs deliberately mistuned blobs on synthetic data with known joints.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "eval_dataset_fixture.h"
#include "forest_blob/blob_loader.h"
#include "tools/cli/command.h"
#include "tools/common/error.h"
#include "tools/eval/blob_rebuild.h"
#include "tools/eval/evaluator.h"
#include "tools/eval/tune.h"

using namespace dp;
using namespace dp::evaltest;

namespace {

blob::LoadedBlob load(const std::vector<uint8_t>& bytes) {
  blob::LoadedBlob b;
  EXPECT_EQ(blob::load_blob(bytes.data(), bytes.size(), &b), blob::BlobStatus::kOk);
  return b;
}

// OJR blob whose every leaf votes, for every joint, a short correct offset (0, 0, +50 mm, weight 1)
// and a long wrong one (0, +500 mm, 0, weight 3); mistuned: no vote-length limit.
blob::BlobContents two_vote_ojr() {
  blob::BlobContents c = tools::single_vote_ojr(2, 0, 0, 50);
  c.votes_per_joint = 2;
  c.ojr_leaves.clear();
  for (int j = 0; j < 2; ++j) {
    c.ojr_leaves.push_back(blob::OjrVote{0, 0, 50, 1});
    c.ojr_leaves.push_back(blob::OjrVote{0, 500, 0, 3});
  }
  for (int j = 0; j < 2; ++j) c.config.joints[j].vote_length_mm = 0;
  return c;
}

}  // namespace

TEST(EvalTune, BlobRebuildIsLossless) {
  for (const blob::BlobContents& c : {tools::random_bpc_forest(7, 3, 6, 5, 300, 200), two_vote_ojr()}) {
    const std::vector<uint8_t> bytes = blob::write_blob(c);
    const blob::LoadedBlob b = load(bytes);
    EXPECT_EQ(blob::write_blob(tools::contents_from_blob(b)), bytes);
    // Changing the config changes only the config section (and the CRCs).
    blob::RuntimeConfig cfg = *b.config;
    cfg.joints[0].bandwidth_mm = 77;
    const std::vector<uint8_t> tuned = tools::blob_with_config(b, cfg);
    const blob::LoadedBlob t = load(tuned);
    EXPECT_EQ(t.config->joints[0].bandwidth_mm, 77);
    ASSERT_EQ(t.total_nodes, b.total_nodes);
    EXPECT_EQ(std::memcmp(t.split_nodes, b.split_nodes, (b.total_nodes - b.meta->leaf_count) * sizeof(blob::TreeNode)), 0);
    EXPECT_EQ(std::memcmp(t.split_flags, b.split_flags, b.tree_first_flag[b.tree_count() - 1] +
                                                           blob::split_flag_bytes_of(b.tree_node_count(b.tree_count() - 1))),
              0);
    ASSERT_EQ(t.meta->entry_count, b.meta->entry_count);
    EXPECT_EQ(std::memcmp(t.leaf_offsets, b.leaf_offsets, (size_t(b.meta->leaf_count) + 1) * sizeof(uint32_t)), 0);
    EXPECT_EQ(std::memcmp(t.leaf_entries, b.leaf_entries, size_t(b.meta->entry_count) * blob::leaf_entry_bytes(*b.meta)), 0);
    EXPECT_EQ(std::memcmp(t.entry_tags, b.entry_tags, b.meta->entry_count), 0);
    cfg.joints[0].bandwidth_mm = 0;  // invalid
    EXPECT_THROW(tools::blob_with_config(b, cfg), tools::ToolError);
  }
}

TEST(EvalTune, AggregateFromLeavesMatchesProcess) {
  blob::BlobContents c = tools::random_bpc_forest(11, 2, 8, 6, 200, 150);
  c.joint_names = {"a", "b"};
  c.config = blob::default_runtime_config(2);
  c.config.joints[0].part_mask = 0b000111;
  c.config.joints[1].part_mask = 0b111000;
  const std::vector<uint8_t> bytes = blob::write_blob(c);
  const blob::LoadedBlob b = load(bytes);
  const size_t need = required_arena_bytes(b, 160, 120);
  std::unique_ptr<uint8_t, decltype(&std::free)> arena(static_cast<uint8_t*>(std::aligned_alloc(64, (need + 63) / 64 * 64)), &std::free);
  Pipeline p;
  ASSERT_EQ(p.init(b, 160, 120, arena.get(), need), Status::kOk);
  tools::SyntheticFrame f = tools::make_plane_frame(160, 120, 2000, 3, -2);
  for (size_t i = 0; i < f.depth_mm.size(); i += 7) f.depth_mm[i] = uint16_t(1500 + (i * 37) % 900);  // texture
  FrameResult direct, again;
  ASSERT_EQ(p.process(f.view(), &direct), Status::kOk);
  ASSERT_GT(direct.proposal_count[0] + direct.proposal_count[1], 0);
  const int n = p.evaluated_pixel_count();
  std::vector<EvaluatedPixel> pixels(p.evaluated_pixels(), p.evaluated_pixels() + n);
  std::vector<uint32_t> leaves(size_t(n) * 2);
  for (int t = 0; t < 2; ++t)
    for (int i = 0; i < n; ++i) leaves[size_t(t) * n + i] = p.leaf_of(i, t);
  // Another frame in between, so nothing of the first survives in the arena by accident.
  FrameResult other;
  ASSERT_EQ(p.process(tools::make_disc_frame(160, 120, 40, 40, 9, 1200).view(), &other), Status::kOk);
  ASSERT_EQ(p.aggregate_from_leaves(f.intrinsics, pixels.data(), leaves.data(), n, &again), Status::kOk);
  for (int j = 0; j < 2; ++j) {
    ASSERT_EQ(again.proposal_count[j], direct.proposal_count[j]);
    EXPECT_EQ(std::memcmp(again.proposals[j], direct.proposals[j], sizeof(JointProposal) * size_t(direct.proposal_count[j])), 0);
  }
  EXPECT_EQ(again.flags & kFlagVotesTruncated, direct.flags & kFlagVotesTruncated);
  // Refusals: bad leaf index, empty list, too many pixels.
  leaves[0] = b.meta->leaf_count;
  EXPECT_EQ(p.aggregate_from_leaves(f.intrinsics, pixels.data(), leaves.data(), n, &again), Status::kBadArgument);
  EXPECT_EQ(p.aggregate_from_leaves(f.intrinsics, pixels.data(), leaves.data(), 0, &again), Status::kBadArgument);
  EXPECT_EQ(p.aggregate_from_leaves(f.intrinsics, pixels.data(), leaves.data(), 160 * 120 + 1, &again), Status::kBadArgument);
}

TEST(EvalTune, VoteLengthSearchDropsTheMisleadingLongVotes) {
  TempDir tmp;
  DiscDatasetSpec spec;
  spec.discs = three_discs();
  spec.joint_dz_m = 0.05f;  // the correct vote's offset
  write_disc_dataset(tmp.path, spec);
  tools::EvalSession s(blob::write_blob(two_vote_ojr()), "mistuned", tmp.path, tools::EvalOptions{});
  tools::TuneOptions o;
  o.threads = 2;
  o.passes = 1;
  const tools::TuneResult r = tools::tune_runtime_config(s, o);
  ASSERT_TRUE(r.map_before && r.map_after);
  EXPECT_LT(*r.map_before, 0.9);
  EXPECT_NEAR(*r.map_after, 1.0, 1e-9);
  for (int j = 0; j < 2; ++j) {
    EXPECT_GE(r.config.joints[j].vote_length_mm, 50);   // keeps the 50 mm vote
    EXPECT_LT(r.config.joints[j].vote_length_mm, 500);  // drops the 500 mm one
  }
  EXPECT_GT(r.grid_points, 12);
  // The tuned config, run end to end through process(), gives the searched mAP.
  const tools::EvalReport full = s.evaluate(&r.config);
  EXPECT_NEAR(full.mean_ap.value_or(-1), 1.0, 1e-9);
  EXPECT_NEAR(s.evaluate().mean_ap.value_or(-1), *r.map_before, 1e-9);  // the blob's own config
}

TEST(EvalTune, PushBackSearchOnBpc) {
  TempDir tmp;
  DiscDatasetSpec spec;
  spec.discs = three_discs();
  spec.joint_dz_m = 0.06f;  // joints 60 mm behind the surface
  write_disc_dataset(tmp.path, spec);
  tools::EvalOptions eo;
  eo.d_tp_m = 0.03;  // tight enough that a push-back of 0 misses
  tools::EvalSession s(blob::write_blob(tools::single_part_bpc(4, 2, 2, 0)), "mistuned", tmp.path, eo);
  tools::TuneOptions o;
  o.threads = 1;
  o.passes = 1;
  const tools::TuneResult r = tools::tune_runtime_config(s, o);
  EXPECT_NEAR(r.map_before.value_or(-1), 0.0, 1e-9);
  EXPECT_NEAR(r.map_after.value_or(-1), 1.0, 1e-9);
  for (int j = 0; j < 2; ++j) {
    EXPECT_GT(r.config.joints[j].push_back_mm, 30);
    EXPECT_LT(r.config.joints[j].push_back_mm, 90);
  }
}

TEST(EvalTune, CommandWritesATunedBlob) {
  TempDir tmp;
  const std::string data = tmp.path + "/val";
  DiscDatasetSpec spec;
  spec.discs = three_discs();
  spec.joint_dz_m = 0.05f;
  write_disc_dataset(data, spec);
  const std::string in = tmp.path + "/in.dpfb", out = tmp.path + "/out.dpfb", json = tmp.path + "/tune.json";
  blob::save_blob_file(in, blob::write_blob(two_vote_ojr()));
  std::vector<std::string> args{"tune", "--blob", in, "--data", data, "--out", out, "--passes", "1", "--json", json};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  ASSERT_EQ(cli::find_command("tune")->run(int(argv.size()), argv.data()), 0);
  const std::vector<uint8_t> bytes = blob::read_blob_file(out);
  const blob::LoadedBlob b = load(bytes);
  EXPECT_GT(b.config->joints[0].vote_length_mm, 0);
  EXPECT_LT(b.config->joints[0].vote_length_mm, 500);
  std::ifstream f(json);
  const nlohmann::json j = nlohmann::json::parse(f);
  EXPECT_GT(j.at("gain").get<double>(), 0.1);
  EXPECT_NEAR(j.at("mAP_end_to_end").get<double>(), 1.0, 1e-9);
}

TEST(EvalTune, OneJointsConfigNeverChangesAnotherJointsProposals) {
  // Two joints, each leaf voting a short and a long offset of equal weight; Nsub small so the
  // top-N tie-breaking decides which votes survive. Dropping joint 1's long votes must leave joint
  // 0 bit-identical (tune's per-joint search relies on this).
  blob::BlobContents c = two_vote_ojr();
  for (blob::OjrVote& v : c.ojr_leaves) v.weight = 1;
  c.config.max_votes_per_joint = 40;
  const std::vector<uint8_t> bytes = blob::write_blob(c);
  const blob::LoadedBlob b = load(bytes);
  const size_t need = required_arena_bytes(b, 160, 120);
  std::unique_ptr<uint8_t, decltype(&std::free)> arena(static_cast<uint8_t*>(std::aligned_alloc(64, (need + 63) / 64 * 64)), &std::free);
  Pipeline p;
  ASSERT_EQ(p.init(b, 160, 120, arena.get(), need), Status::kOk);
  const tools::SyntheticFrame f = tools::make_disc_frame(160, 120, 80, 60, 20, 2000);
  FrameResult a, bres;
  ASSERT_EQ(p.process(f.view(), &a), Status::kOk);
  ASSERT_NE(a.flags & kFlagVotesTruncated, 0u);
  blob::RuntimeConfig cfg = *b.config;
  cfg.joints[1].vote_length_mm = 100;
  ASSERT_EQ(p.set_config(cfg), Status::kOk);
  ASSERT_EQ(p.process(f.view(), &bres), Status::kOk);
  ASSERT_GT(a.proposal_count[0], 0);
  ASSERT_EQ(a.proposal_count[0], bres.proposal_count[0]);
  EXPECT_EQ(std::memcmp(a.proposals[0], bres.proposals[0], sizeof(JointProposal) * size_t(a.proposal_count[0])), 0);
  // ...while joint 1 did change.
  EXPECT_NE(std::memcmp(a.proposals[1], bres.proposals[1], sizeof(JointProposal) * kMaxProposals), 0);
}
