// `depthpose eval` end to end: handcrafted blobs (tools/demo/fixtures.h) on tiny disc datasets
// whose joints are known, through the real runtime, the CLI, the JSON and the plots.
#include <algorithm>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/cli_test_support.h"
#include "eval_dataset_fixture.h"
#include "tools/cli/command.h"
#include "tools/common/error.h"
#include "tools/eval/evaluator.h"
#include "tools/eval/report.h"

using namespace dp;
using namespace dp::evaltest;

using dp::testsupport::run_cli;

namespace {

std::unique_ptr<tools::EvalSession> session(const blob::BlobContents& c, const std::string& data,
                                            const tools::EvalOptions& o = {}) {
  return std::make_unique<tools::EvalSession>(blob::write_blob(c), "test blob", data, o);
}

}  // namespace

TEST(EvalEndToEnd, OjrVotingAtTheJointScoresOneAndAWrongOffsetZero) {
  TempDir tmp;
  DiscDatasetSpec spec;
  spec.discs = three_discs();
  write_disc_dataset(tmp.path, spec);

  const tools::EvalReport good = session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path)->evaluate();
  EXPECT_EQ(good.method, "OJR");
  EXPECT_EQ(good.frames, 3);
  ASSERT_EQ(good.joint_names.size(), 2u);
  ASSERT_TRUE(good.mean_ap.has_value());
  EXPECT_NEAR(*good.mean_ap, 1.0, 1e-9);
  EXPECT_EQ(good.positives[0], 3);
  EXPECT_FALSE(good.class_accuracy.has_value());  // OJR: no segmentation
  EXPECT_GT(good.fps, 0.0);

  // Every vote 0.3 m above the joint: every proposal is a false positive.
  const tools::EvalReport bad = session(tools::single_vote_ojr(2, 0, 300, 0), tmp.path)->evaluate();
  ASSERT_TRUE(bad.mean_ap.has_value());
  EXPECT_NEAR(*bad.mean_ap, 0.0, 1e-9);
  // AP against D_tp (0.02–0.20 m): zero throughout, the votes are 0.3 m off.
  for (const auto& m : bad.map_vs_dtp) EXPECT_NEAR(m.value_or(-1), 0.0, 1e-9);
  // Widening D_tp past the offset recovers them.
  tools::EvalOptions wide;
  wide.d_tp_m = 0.35;
  EXPECT_NEAR(session(tools::single_vote_ojr(2, 0, 300, 0), tmp.path, wide)->evaluate().mean_ap.value_or(-1), 1.0, 1e-9);
}

TEST(EvalEndToEnd, BpcClassAccuracyAndPushBack) {
  TempDir tmp;
  DiscDatasetSpec spec;
  spec.discs = three_discs();
  spec.left_label = 1;  // left half labelled part1, right half part2; the blob always says part2
  spec.right_label = 2;
  spec.joint_dz_m = 0.04f;  // the blob's push-back
  write_disc_dataset(tmp.path, spec);
  const tools::EvalReport r = session(tools::single_part_bpc(4, 2, 2, 40), tmp.path)->evaluate();
  EXPECT_EQ(r.method, "BPC");
  ASSERT_TRUE(r.has_confusion);
  ASSERT_TRUE(r.class_accuracy.has_value());
  EXPECT_NEAR(*r.class_accuracy, 0.5, 1e-12);  // part1 row: 0, part2 row: 1
  EXPECT_GT(r.confusion.count(1, 2), 0);
  EXPECT_EQ(r.confusion.count(1, 1), 0);
  EXPECT_EQ(r.confusion.row_total(0), 0);
  EXPECT_NEAR(r.mean_ap.value_or(-1), 1.0, 1e-9);
}

TEST(EvalEndToEnd, ForeignNamesAreRefusedUnlessMapped) {
  TempDir tmp;
  DiscDatasetSpec spec;
  spec.discs = three_discs();
  spec.joint_names = {"head", "neck"};
  write_disc_dataset(tmp.path, spec);
  try {
    session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path);
    FAIL() << "names that do not match must be refused";
  } catch (const tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("joint0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--map-joints"), std::string::npos) << e.what();
  }
  tools::EvalOptions o;
  o.joint_map = tools::parse_name_map("head=joint0,neck=joint1", "--map-joints");
  EXPECT_NEAR(session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path, o)->evaluate().mean_ap.value_or(-1), 1.0, 1e-9);
  // Only one joint mapped: the other is skipped.
  o.joint_map = tools::parse_name_map("neck=joint1", "--map-joints");
  const tools::EvalReport one = session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path, o)->evaluate();
  ASSERT_EQ(one.joint_names.size(), 1u);
  EXPECT_EQ(one.joint_names[0], "joint1");
  // A mapping that names a joint the dataset lacks is an error, not silently ignored.
  o.joint_map = tools::parse_name_map("elbow=joint1", "--map-joints");
  EXPECT_THROW(session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path, o), tools::ToolError);
  EXPECT_THROW(tools::parse_name_map("head", "--map-joints"), tools::ToolError);
  const std::string map_file = tmp.path + "/joints.map";
  std::ofstream(map_file) << "head=joint0\nneck=joint1\n";
  o.joint_map = tools::parse_name_map("@" + map_file, "--map-joints");
  ASSERT_EQ(o.joint_map.size(), 2u);
  EXPECT_EQ(o.joint_map[1].first, "neck");
  EXPECT_EQ(o.joint_map[1].second, "joint1");
  EXPECT_THROW(tools::parse_name_map("@" + tmp.path + "/missing.map", "--map-joints"), tools::ToolError);

  // BPC parts: the blob's "part0..3" against a dataset naming its parts differently.
  DiscDatasetSpec parts = spec;
  parts.joint_names = {"joint0", "joint1"};
  parts.part_names = {"a", "b", "c"};
  TempDir tmp2;
  write_disc_dataset(tmp2.path, parts);
  EXPECT_THROW(session(tools::single_part_bpc(4, 2, 2, 40), tmp2.path), tools::ToolError);
  tools::EvalOptions po;
  po.part_map = tools::parse_name_map("a=part0,b=part1,c=part2", "--map-parts");
  EXPECT_NEAR(session(tools::single_part_bpc(4, 2, 2, 40), tmp2.path, po)->evaluate().class_accuracy.value_or(-1), 1.0, 1e-12);
}

TEST(EvalEndToEnd, SilhouetteModeFlattensDepthAndMeasuresPixels) {
  TempDir tmp;
  DiscDatasetSpec spec;
  spec.discs = {Disc{50, 40, 4, 1000}, Disc{100, 70, 4, 3000}};  // far from the canonical 2 m
  spec.with_parts = false;  // foreground from the depth band
  write_disc_dataset(tmp.path, spec);
  // Votes 0.1 m to the side: at 1 m that is 13 px (f = 131.25), at 3 m about 4.4 px; after flattening
  // to 2 m every proposal is 0.1 m · 131.25 / 2 m = 6.6 px from the joint's pixel.
  tools::EvalOptions sil;
  sil.silhouette = true;
  const tools::EvalReport r = session(tools::single_vote_ojr(2, 100, 0, 0), tmp.path, sil)->evaluate();
  EXPECT_EQ(r.d_tp_unit, "px");
  EXPECT_NEAR(r.d_tp, 10.0, 1e-12);
  EXPECT_NEAR(r.mean_ap.value_or(-1), 1.0, 1e-9);
  sil.d_tp_px = 5.0;
  EXPECT_NEAR(session(tools::single_vote_ojr(2, 100, 0, 0), tmp.path, sil)->evaluate().mean_ap.value_or(-1), 0.0, 1e-9);
  // In depth mode the same votes are exactly 0.1 m away: D_tp 0.09 m misses, 0.11 m hits.
  tools::EvalOptions metres;
  metres.d_tp_m = 0.09;
  EXPECT_NEAR(session(tools::single_vote_ojr(2, 100, 0, 0), tmp.path, metres)->evaluate().mean_ap.value_or(-1), 0.0, 1e-9);
  metres.d_tp_m = 0.11;
  EXPECT_NEAR(session(tools::single_vote_ojr(2, 100, 0, 0), tmp.path, metres)->evaluate().mean_ap.value_or(-1), 1.0, 1e-9);
}

TEST(EvalEndToEnd, CommandWritesJsonAndPlots) {
  TempDir tmp;
  const std::string data = tmp.path + "/data";
  DiscDatasetSpec spec;
  spec.discs = three_discs();
  spec.joint_dz_m = 0.04f;
  write_disc_dataset(data, spec);
  const std::string blob_path = tmp.path + "/bpc.dpfb";
  blob::save_blob_file(blob_path, blob::write_blob(tools::single_part_bpc(4, 2, 2, 40)));
  const std::string json_path = tmp.path + "/out.json", plots = tmp.path + "/plots";
  ASSERT_EQ(run_cli({"eval", "--blob", blob_path, "--data", data, "--json", json_path, "--plots", plots}), 0);
  std::ifstream f(json_path);
  ASSERT_TRUE(f.good());
  const nlohmann::json j = nlohmann::json::parse(f);
  EXPECT_NEAR(j.at("mAP").get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(j.at("per_joint_ap").at("joint1").get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(j.at("class_accuracy").get<double>(), 1.0, 1e-12);
  EXPECT_EQ(j.at("frames").get<int>(), 3);
  EXPECT_GT(j.at("fps").get<double>(), 0.0);
  EXPECT_EQ(j.at("ap_vs_dtp").size(), 10u);
  for (const char* name : {"recall_precision.png", "ap_vs_dtp.png", "confusion.png", "overlay_000000.png", "overlay_000002.png"}) {
    const std::string p = plots + "/" + name;
    ASSERT_TRUE(std::filesystem::exists(p)) << p;
    EXPECT_GT(std::filesystem::file_size(p), 100u) << p;
  }
  // --frames limits the run.
  ASSERT_EQ(run_cli({"eval", "--blob", blob_path, "--data", data, "--frames", "1", "--json", json_path}), 0);
  std::ifstream g(json_path);
  EXPECT_EQ(nlohmann::json::parse(g).at("frames").get<int>(), 1);
}

TEST(EvalEndToEnd, OccludedJointsAreNotFalseNegativesByDefault) {
  TempDir tmp;
  DiscDatasetSpec spec;
  spec.discs = three_discs();
  write_disc_dataset(tmp.path, spec);
  // Rewrite frames.jsonl: joint1 invisible and far away from the disc in frame 0.
  tools::Dataset ds = tools::open_dataset(tmp.path);
  ds.frames[0].joints[1] = tools::JointTruth{1.0f, 1.0f, 3.0f, false};
  tools::write_frames_jsonl(tmp.path, ds.frames);
  const tools::EvalReport lenient = session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path)->evaluate();
  EXPECT_EQ(lenient.positives[1], 2);
  // Confidence ≈ pixels · z²: frame 1 (49 px at 2.5 m) > frame 2 (81 px at 1.8 m) > frame 0 (49 px
  // at 2 m). Ranking for joint1: TP, TP, FP (the proposal far from the hidden joint).
  ASSERT_TRUE(lenient.ap[1].has_value());
  EXPECT_NEAR(*lenient.ap[1], 1.0, 1e-9);
  tools::EvalOptions strict;
  strict.penalize_occluded = true;
  const tools::EvalReport s = session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path, strict)->evaluate();
  EXPECT_EQ(s.positives[1], 3);
  ASSERT_TRUE(s.ap[1].has_value());
  EXPECT_NEAR(*s.ap[1], 2.0 / 3.0, 1e-6);  // the hidden joint is a false negative: recall ≤ 2/3
  EXPECT_NEAR(*lenient.ap[0], 1.0, 1e-9);
}

// Frames that carry their motion category and clip (as synth writes them) are also scored per
// category and per subject, each group matched on its own frames only.
TEST(EvalEndToEnd, AccuracyPerCategoryAndSubject) {
  TempDir tmp;
  DiscDatasetSpec spec;
  spec.discs = {Disc{50, 40, 4, 2000}, Disc{100, 70, 4, 2500}, Disc{80, 60, 5, 1800}, Disc{60, 50, 5, 2200}};
  write_disc_dataset(tmp.path, spec);
  // Frames 0-1: Indian dance (subject 94), truth at the disc, where the blob votes; frames 2-3:
  // karate (subject 135), truth moved 0.3 m up, so every vote there misses.
  tools::Dataset ds = tools::open_dataset(tmp.path);
  const char* extra[] = {R"({"category":"indian dance","clip":"94_01"})", R"({"category":"indian dance","clip":"94_03"})",
                         R"({"category":"martial arts","clip":"135_02"})", R"({"category":"martial arts","clip":"135_02"})"};
  for (size_t i = 0; i < ds.frames.size(); ++i) {
    ds.frames[i].extra_json = extra[i];
    if (i >= 2)
      for (tools::JointTruth& t : ds.frames[i].joints) t.y += 0.3f;
  }
  tools::write_frames_jsonl(tmp.path, ds.frames);

  const tools::EvalReport r = session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path)->evaluate();
  ASSERT_EQ(r.by_category.size(), 2u);
  EXPECT_EQ(r.by_category[0].name, "indian dance");
  EXPECT_EQ(r.by_category[0].frames, 2);
  EXPECT_NEAR(r.by_category[0].mean_ap.value_or(-1), 1.0, 1e-9);
  EXPECT_EQ(r.by_category[1].name, "martial arts");
  EXPECT_NEAR(r.by_category[1].mean_ap.value_or(-1), 0.0, 1e-9);
  ASSERT_EQ(r.by_category[1].ap.size(), 2u);
  // The whole set lies between its categories.
  ASSERT_TRUE(r.mean_ap.has_value());
  EXPECT_GT(*r.mean_ap, 0.2);
  EXPECT_LT(*r.mean_ap, 0.8);
  // Subjects from the clip ids, sorted by name: "135" before "94".
  ASSERT_EQ(r.by_subject.size(), 2u);
  EXPECT_EQ(r.by_subject[0].name, "135");
  EXPECT_NEAR(r.by_subject[0].mean_ap.value_or(-1), 0.0, 1e-9);
  EXPECT_EQ(r.by_subject[1].name, "94");
  EXPECT_EQ(r.by_subject[1].frames, 2);
  EXPECT_NEAR(r.by_subject[1].mean_ap.value_or(-1), 1.0, 1e-9);

  // The CLI: JSON per category and subject, and a table in the text report.
  const std::string blob_path = tmp.path + "/ojr.dpfb", json_path = tmp.path + "/out.json";
  blob::save_blob_file(blob_path, blob::write_blob(tools::single_vote_ojr(2, 0, 0, 0)));
  ASSERT_EQ(run_cli({"eval", "--blob", blob_path, "--data", tmp.path, "--json", json_path}), 0);
  std::ifstream f(json_path);
  const nlohmann::json j = nlohmann::json::parse(f);
  EXPECT_NEAR(j.at("by_category").at("indian dance").at("mAP").get<double>(), 1.0, 1e-9);
  EXPECT_EQ(j.at("by_category").at("martial arts").at("frames").get<int>(), 2);
  EXPECT_NEAR(j.at("by_category").at("martial arts").at("per_joint_ap").at("joint1").get<double>(), 0.0, 1e-9);
  EXPECT_NEAR(j.at("by_subject").at("94").at("mAP").get<double>(), 1.0, 1e-9);
  EXPECT_EQ(j.at("joints"), nlohmann::json(r.joint_names));
  // "joints" keeps the blob's order where the per-joint objects (keyed by name) are alphabetical.
  tools::EvalReport renamed = r;
  std::reverse(renamed.joint_names.begin(), renamed.joint_names.end());
  renamed.joint_names[0] = "zeta";
  const nlohmann::json rj = tools::report_to_json(renamed);
  EXPECT_EQ(rj.at("joints").front().get<std::string>(), "zeta");
  EXPECT_NE(rj.at("per_joint_ap").begin().key(), "zeta");
  char* text = nullptr;
  size_t size = 0;
  FILE* out = open_memstream(&text, &size);
  tools::print_report(r, out);
  std::fclose(out);
  const std::string printed(text, size);
  std::free(text);
  EXPECT_NE(printed.find("mAP per motion category"), std::string::npos) << printed;
  EXPECT_NE(printed.find("  martial arts      2 frames  mAP 0.000  | 0.000 0.000\n"), std::string::npos) << printed;
}

TEST(EvalEndToEnd, FramesWithoutCategoriesHaveNoGroupsAndABadCategoryIsRefused) {
  TempDir tmp;
  DiscDatasetSpec spec;
  spec.discs = three_discs();
  write_disc_dataset(tmp.path, spec);
  const tools::EvalReport r = session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path)->evaluate();
  EXPECT_TRUE(r.by_category.empty());
  EXPECT_TRUE(r.by_subject.empty());
  EXPECT_TRUE(tools::report_to_json(r).at("by_category").is_null());

  // A frame without the key joins "(none)"; a category that is not a string names the frame.
  tools::Dataset ds = tools::open_dataset(tmp.path);
  ds.frames[0].extra_json = R"({"category":"salsa"})";
  tools::write_frames_jsonl(tmp.path, ds.frames);
  const tools::EvalReport some = session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path)->evaluate();
  ASSERT_EQ(some.by_category.size(), 2u);
  EXPECT_EQ(some.by_category[0].name, "(none)");
  EXPECT_EQ(some.by_category[0].frames, 2);
  EXPECT_EQ(some.by_category[1].name, "salsa");
  ds.frames[1].extra_json = R"({"category":7})";
  tools::write_frames_jsonl(tmp.path, ds.frames);
  try {
    session(tools::single_vote_ojr(2, 0, 0, 0), tmp.path)->evaluate();
    FAIL() << "a numeric category was accepted";
  } catch (const tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("frame 000001: \"category\""), std::string::npos) << e.what();
  }
}
