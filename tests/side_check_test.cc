// `depthpose side-check` (tools/eval/side_check.h): the left/right ruler for real frames with
// marked arms, its truth file's checks, and a run on two of the Skeltrack frames.
#include "tools/eval/side_check.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/app_test_support.h"
#include "tests/cli_test_support.h"
#include "tests/shared_data.h"

namespace dp::tools {
namespace {

using apptest::error_of;
using apptest::TempDir;

SideTruth camera() {
  SideTruth t;
  t.width = 640;
  t.height = 480;
  t.fx = t.fy = 525;
  t.cx = 319.5;
  t.cy = 239.5;
  return t;
}

// Camera metres at depth z that project to pixel (u, v).
std::array<double, 3> at_pixel(const SideTruth& c, double u, double v, double z = 2.0) {
  return {(u - c.cx) * z / c.fx, -(v - c.cy) * z / c.fy, z};
}

// One front-facing person: left arm on the image's right.
SideTruthFrame one_person() {
  SideTruthFrame f;
  f.file = "x.raw";
  PersonSides p;
  p.head = {320, 100};
  p.left = {Pixel{400, 200}, Pixel{460, 260}, Pixel{500, 320}};
  p.right = {Pixel{240, 200}, Pixel{180, 260}, Pixel{140, 320}};
  f.people.push_back(p);
  return f;
}

// A skeleton at the marked positions, each joint moved by (du, dv) pixels.
ReportedSkeleton skeleton_at(const SideTruth& c, const PersonSides& p, double du = 0, double dv = 0) {
  ReportedSkeleton s;
  s.head = at_pixel(c, p.head.u, p.head.v);
  for (size_t k = 0; k < kSideJoints.size(); ++k) {
    s.left[k] = at_pixel(c, p.left[k]->u + du, p.left[k]->v + dv);
    s.right[k] = at_pixel(c, p.right[k]->u + du, p.right[k]->v + dv);
  }
  return s;
}

TEST(SideCheck, ProjectionInvertsTheCameraModel) {
  const SideTruth c = camera();
  const Pixel p = project(c, at_pixel(c, 123.5, 456.25, 3.1));
  EXPECT_NEAR(p.u, 123.5, 1e-9);
  EXPECT_NEAR(p.v, 456.25, 1e-9);
}

TEST(SideCheck, JointsNearTheirOwnSideAreCorrectEvenWhenOffTheMark) {
  const SideTruth c = camera();
  const SideTruthFrame f = one_person();
  // 60 px off every mark, still nearer its own arm than the other one.
  FrameVerdict v = judge_sides(c, f, {skeleton_at(c, f.people[0], 60, 20)});
  ASSERT_EQ(v.people.size(), 1u);
  EXPECT_EQ(v.people[0].skeleton, 0);
  EXPECT_EQ(v.people[0].correct, 6);
  EXPECT_EQ(v.swapped, 0);
  EXPECT_TRUE(v.sides_correct);
}

TEST(SideCheck, AHandOnTheOtherArmIsSwappedAndFailsTheFrame) {
  const SideTruth c = camera();
  const SideTruthFrame f = one_person();
  ReportedSkeleton s = skeleton_at(c, f.people[0]);
  s.left[2] = at_pixel(c, 150, 310);  // hand_l drawn on the right arm
  FrameVerdict v = judge_sides(c, f, {s});
  EXPECT_EQ(v.people[0].left[2], SideOutcome::kSwapped);
  EXPECT_EQ(v.people[0].right[2], SideOutcome::kCorrect);
  EXPECT_EQ(v.swapped, 1);
  EXPECT_FALSE(v.sides_correct);
  // Both hands exchanged: two swaps.
  std::swap(s.left[2], s.right[2]);
  s.right[2] = at_pixel(c, 490, 330);
  s.left[2] = at_pixel(c, 150, 310);
  EXPECT_EQ(judge_sides(c, f, {s}).swapped, 2);
}

TEST(SideCheck, MissingJointsAreCountedApartAndUnmatchedPeopleFailTheFrame) {
  const SideTruth c = camera();
  const SideTruthFrame f = one_person();
  ReportedSkeleton s = skeleton_at(c, f.people[0]);
  s.left[1].reset();
  FrameVerdict v = judge_sides(c, f, {s});
  EXPECT_EQ(v.missing, 1);
  EXPECT_EQ(v.people[0].left[1], SideOutcome::kMissing);
  EXPECT_TRUE(v.sides_correct);
  // The only skeleton's head is 200 px from the marked one: nobody matched.
  ReportedSkeleton far = skeleton_at(c, f.people[0]);
  far.head = at_pixel(c, 520, 100);
  v = judge_sides(c, f, {far});
  EXPECT_EQ(v.people[0].skeleton, -1);
  EXPECT_EQ(v.missing, 6);
  EXPECT_FALSE(v.sides_correct);
  EXPECT_FALSE(judge_sides(c, f, {}).sides_correct);
}

TEST(SideCheck, TwoPeopleAreMatchedByNearestHeadsOneToOne) {
  const SideTruth c = camera();
  SideTruthFrame f = one_person();
  PersonSides second = f.people[0];
  second.head = {330, 110};
  f.people.push_back(second);
  // Skeleton 0 sits on the second person's head, skeleton 1 on the first's: each is matched to
  // the nearer marked head, never both to one person.
  ReportedSkeleton a = skeleton_at(c, f.people[0]), b = skeleton_at(c, f.people[0]);
  a.head = at_pixel(c, 331, 111);
  b.head = at_pixel(c, 319, 99);
  FrameVerdict v = judge_sides(c, f, {a, b});
  EXPECT_EQ(v.people[0].skeleton, 1);
  EXPECT_EQ(v.people[1].skeleton, 0);
}

void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(SideCheck, TruthFileErrorsNameTheField) {
  TempDir tmp;
  const std::string path = tmp / "t.json";
  const std::string cam = R"("camera": {"width": 640, "height": 480, "fx": 525, "fy": 525, "cx": 319.5, "cy": 239.5})";
  auto with_people = [&](const std::string& people) {
    write_text(path, "{" + cam + R"(, "frames": [{"file": "a.raw", "people": [)" + people + "]}]}");
    return error_of([&] { load_side_truth(path); });
  };
  EXPECT_NE(with_people(R"({"head": [1, 2], "left": {"hand": [3, 4]}, "right": {}})").find("marked on one side only"),
            std::string::npos);
  EXPECT_NE(with_people(R"({"head": [1, 2], "left": {"hand": [3, 4]}, "right": {"hand": [700, 4]}})")
                .find("people[0].right.hand = [700"),
            std::string::npos);
  EXPECT_NE(with_people(R"({"head": [1, 2], "left": {"knee": [3, 4]}, "right": {"knee": [5, 4]}})")
                .find("unknown joint \"knee\""),
            std::string::npos);
  EXPECT_NE(with_people(R"({"head": [1, 2], "left": {}, "right": {}})").find("no joint marked"), std::string::npos);
  EXPECT_EQ(with_people(R"({"head": [1, 2], "left": {"hand": [3, 4]}, "right": {"hand": [5, 4]}})"), "(no error)");
  write_text(path, "{" + cam + R"(, "frames": []})");
  EXPECT_NE(error_of([&] { load_side_truth(path); }).find("\"frames\" is missing or empty"), std::string::npos);
  write_text(path, R"({"camera": {"width": 640, "height": 480, "fx": 0, "fy": 525, "cx": 1, "cy": 1}, "frames": [1]})");
  EXPECT_NE(error_of([&] { load_side_truth(path); }).find("\"fx\" = 0"), std::string::npos);
  write_text(path, "{\"camera\": ");
  EXPECT_NE(error_of([&] { load_side_truth(path); }).find("not JSON"), std::string::npos);
}

// The shipped truth file marks the 12 Skeltrack frames, and each names a file that exists.
TEST(SideCheckSharedData, ShippedTruthMarksEveryFrame) {
  const SideTruth t = load_side_truth("docs/data/skeltrack_sides.json");
  ASSERT_EQ(t.frames.size(), 12u);
  size_t people = 0;
  for (const auto& f : t.frames) {
    people += f.people.size();
    EXPECT_TRUE(std::ifstream(dp::test::shared_path("data/skeltrack-frames/" + f.file)).good()) << f.file;
  }
  EXPECT_EQ(people, 13u);
}

// Two frames through the whole command: one person each, every marked joint judged.
TEST(SideCheckSharedData, CommandJudgesFramesWithTheShippedModel) {
  TempDir tmp;
  nlohmann::json truth = nlohmann::json::parse(std::ifstream("docs/data/skeltrack_sides.json"));
  truth["frames"] = {truth["frames"][0], truth["frames"][11]};
  write_text(tmp / "truth.json", truth.dump());
  ASSERT_EQ(testsupport::run_cli({"side-check", "--blob", "models/ojr.blob", "--truth", tmp / "truth.json", "--frames",
                                  dp::test::shared_path("data/skeltrack-frames"), "--json", tmp / "out.json"}),
            0);
  const nlohmann::json out = nlohmann::json::parse(std::ifstream(tmp / "out.json"));
  ASSERT_EQ(out.at("frames").get<int>(), 2);
  const auto& frames = out.at("per_frame");
  EXPECT_EQ(frames[0].at("people_found").get<int>(), 1);
  EXPECT_EQ(frames[1].at("people_found").get<int>(), 2);
  EXPECT_EQ(frames[1].at("people").size(), 2u);
  EXPECT_EQ(frames[0].at("people")[0].at("joints").size(), 6u);
  for (const auto& f : frames)
    for (const auto& p : f.at("people")) EXPECT_TRUE(p.at("matched").get<bool>()) << f.dump();
  // The counts add up: every marked joint is ok, swapped or missing.
  int judged = 0;
  for (const auto& f : frames)
    for (const auto& p : f.at("people"))
      for (const auto& [name, outcome] : p.at("joints").items()) {
        EXPECT_TRUE(outcome == "ok" || outcome == "SWAPPED" || outcome == "missing") << name;
        ++judged;
      }
  EXPECT_EQ(judged, 18);
  EXPECT_NE(error_of([&] {
              testsupport::run_cli({"side-check", "--blob", "models/ojr.blob", "--truth", tmp / "truth.json",
                                    "--frames", tmp.path});
            }).find("depth-data-1028894671.raw"),
            std::string::npos);
}

}  // namespace
}  // namespace dp::tools
