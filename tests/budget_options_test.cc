// --pixel-budget / --cycle-budget on `depthpose eval` and `depthpose run`: the override reaches the
// pipeline (fewer evaluated pixels, budget flags), is reported, and bad values are refused by name.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "forest_blob/blob_writer.h"
#include "tests/app_run_support.h"
#include "tests/app_test_support.h"
#include "tests/cli_test_support.h"
#include "tools/common/budget_options.h"
#include "tools/common/error.h"
#include "tools/demo/fixtures.h"

using namespace dp;
using namespace dp::tools;
using dp::apptest::Captured;
using dp::apptest::TempDir;
using dp::apptest::run_captured;
using dp::testsupport::run_cli;
using nlohmann::json;

namespace {

// Depth-1 BPC forest, all mass on part 2; the blob's own pixel budget is 20000 (blob_writer default).
std::string write_blob(const TempDir& dir) {
  const std::string path = dir / "b.blob";
  blob::BlobContents c = single_part_bpc(4, 2, 3, 40);
  c.joint_names = {"head", "neck", "hand_l"};
  blob::save_blob_file(path, blob::write_blob(c));
  return path;
}

json eval_json(const std::vector<std::string>& extra, const TempDir& dir, const std::string& blob, const std::string& data) {
  const std::string out = dir / "eval.json";
  std::vector<std::string> args = {"eval", "--blob", blob, "--data", data, "--json", out};
  args.insert(args.end(), extra.begin(), extra.end());
  EXPECT_EQ(run_cli(args), 0);
  std::ifstream f(out);
  return json::parse(f);
}

std::string error_of(const std::vector<std::string>& args) {
  try {
    run_cli(args);
  } catch (const ToolError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(BudgetOptions, EvalPixelBudgetStridesAndIsReported) {
  TempDir dir;
  const std::string blob = write_blob(dir);
  apptest::write_disc_dataset(dir / "ds", 3);
  const json base = eval_json({}, dir, blob, dir / "ds");
  const double all = base.at("speed").at("mean_evaluated_pixels").get<double>();
  ASSERT_GT(all, 60.0) << "the discs must be larger than the budget below";
  EXPECT_TRUE(base.at("budget_override").is_null());
  EXPECT_EQ(base.at("flag_frames").at("pixels_strided").get<int>(), 0);

  const json cut = eval_json({"--pixel-budget", "60"}, dir, blob, dir / "ds");
  EXPECT_LE(cut.at("speed").at("mean_evaluated_pixels").get<double>(), 60.0);
  EXPECT_EQ(cut.at("flag_frames").at("pixels_strided").get<int>(), 3);
  EXPECT_EQ(cut.at("budget_override").get<std::string>(), "pixel budget 60");
}

TEST(BudgetOptions, EvalCycleBudgetDegradesInTheDocumentedOrder) {
  TempDir dir;
  const std::string blob = write_blob(dir);
  apptest::write_disc_dataset(dir / "ds", 2);
  // One cycle cannot be met: every knob goes to its floor and the frame says so.
  const json j = eval_json({"--cycle-budget", "1"}, dir, blob, dir / "ds");
  const json& f = j.at("flag_frames");
  EXPECT_EQ(f.at("budget_infeasible").get<int>(), 2);
  EXPECT_EQ(f.at("over_cycle_budget").get<int>(), 2);
  EXPECT_EQ(f.at("budget_votes").get<int>(), 2);
  EXPECT_EQ(j.at("budget_override").get<std::string>(), "cycle budget 1");
  // 0 = no budget: nothing degrades.
  const json none = eval_json({"--cycle-budget", "0"}, dir, blob, dir / "ds");
  EXPECT_EQ(none.at("flag_frames").at("budget_infeasible").get<int>(), 0);
  EXPECT_EQ(none.at("flag_frames").at("over_cycle_budget").get<int>(), 0);
}

TEST(BudgetOptions, BadValuesAreRefusedByName) {
  TempDir dir;
  const std::string blob = write_blob(dir);
  apptest::write_disc_dataset(dir / "ds", 1);
  const std::string ds = dir / "ds";
  EXPECT_NE(error_of({"eval", "--blob", blob, "--data", ds, "--pixel-budget", "0"}).find("--pixel-budget must be at least 1"),
            std::string::npos);
  EXPECT_NE(error_of({"eval", "--blob", blob, "--data", ds, "--pixel-budget", "20001"}).find("exceeds the blob's pixel budget 20000"),
            std::string::npos);
  EXPECT_NE(error_of({"eval", "--blob", blob, "--data", ds, "--cycle-budget", "-5"}).find("--cycle-budget must be"),
            std::string::npos);
  EXPECT_NE(error_of({"eval", "--blob", blob, "--data", ds, "--cycle-budget", "fast"}).find("--cycle-budget"),
            std::string::npos);
  EXPECT_NE(error_of({"run", "--blob", blob, "--source", "dataset:" + ds, "--pixel-budget", "99999"}).find("exceeds the blob's"),
            std::string::npos);
}

TEST(BudgetOptions, RunAppliesTheOverridePerFrame) {
  TempDir dir;
  const std::string blob = write_blob(dir);
  apptest::write_disc_dataset(dir / "ds", 3);
  RunOptions o;
  o.blob_path = blob;
  o.source_spec = "dataset:" + (dir / "ds");
  o.json = true;
  o.segment = SegmentMode::kOff;
  Captured full = run_captured(o);
  ASSERT_EQ(full.lines.size(), 3u) << full.log;
  o.budget.pixel_budget = 60;
  Captured cut = run_captured(o);
  ASSERT_EQ(cut.lines.size(), 3u) << cut.log;
  EXPECT_NE(cut.log.find("run: pixel budget 60 (blob: pixel budget 20000"), std::string::npos) << cut.log;
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_GT(full.lines[i].at("evaluated_pixels").get<int>(), 60);
    EXPECT_LE(cut.lines[i].at("evaluated_pixels").get<int>(), 60);
    EXPECT_GT(cut.lines[i].at("pixel_stride").get<int>(), 1);
    const json& flags = cut.lines[i].at("flags");
    EXPECT_NE(std::find(flags.begin(), flags.end(), "pixels_strided"), flags.end()) << flags.dump();
  }
  EXPECT_EQ(cut.summary.degraded, 3);
  // Reaching the top-N caps (Nsub, starts, proposals) is normal operation, not a degradation.
  EXPECT_EQ(full.summary.degraded, 0);

  // The cycle budget's flags are named in the JSON (they printed "unknown_flag" before).
  o.budget = BudgetOverrides{};
  o.budget.cycle_budget = 1;
  Captured tight = run_captured(o);
  ASSERT_EQ(tight.lines.size(), 3u) << tight.log;
  const json& flags = tight.lines[0].at("flags");
  for (const char* name : {"budget_votes", "budget_starts", "budget_iterations", "budget_infeasible", "over_cycle_budget"})
    EXPECT_NE(std::find(flags.begin(), flags.end(), name), flags.end()) << name << " in " << flags.dump();
  EXPECT_EQ(std::find(flags.begin(), flags.end(), "unknown_flag"), flags.end()) << flags.dump();
  EXPECT_EQ(tight.summary.overruns, 3);
  EXPECT_EQ(tight.summary.degraded, 3);  // the cycle budget cut votes, starts and iterations
}

TEST(BudgetOptions, EveryFrameFlagHasItsOwnName) {
  for (int32_t a = 0; a < kFrameFlagBits; ++a) {
    EXPECT_STRNE(frame_flag_name(a), "unknown_flag") << a;
    for (int32_t b = a + 1; b < kFrameFlagBits; ++b) EXPECT_STRNE(frame_flag_name(a), frame_flag_name(b));
  }
  EXPECT_STREQ(frame_flag_name(kFrameFlagBits), "unknown_flag");
  EXPECT_STREQ(frame_flag_name(6), "budget_pixels");  // bit 6 = kFlagBudgetPixels
  EXPECT_EQ(1u << 10, uint32_t(kFlagBudgetInfeasible));
}
