// `depthpose run` with segmentation: a recording of a synthetic scene (floor, clutter, two people,
// `synth --sequence`) gives joints for two users whose ids stay with the same person; the loop
// still allocates nothing; --segment off and auto behave as documented.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "platform/oni_recorder.h"
#include "tests/app_run_support.h"
#include "tests/app_test_support.h"
#include "tests/cli_test_support.h"
#include "tests/shared_data.h"
#include "tools/app/reid_eval.h"
#include "tools/app/run.h"
#include "tools/cli/command.h"
#include "tools/common/error.h"
#include "tools/synth/synth.h"

using namespace dp;
using namespace dp::tools;
using dp::apptest::Captured;
using dp::apptest::TempDir;
using dp::apptest::run_captured;
using dp::testsupport::run_cli;
using dp::synth::FrameParams;
using dp::synth::SynthConfig;
using dp::synth::SynthFrame;
using dp::synth::Synthesizer;
using nlohmann::json;

namespace {

const std::string kAssets = dp::test::shared_path("assets");
const char* kBlob = "models/bpc.blob";  // the shipped 31-part forest
constexpr int kFrames = 30;

// Ground truth per frame: people[k] = 16 joints (x, y, z, visible).
std::vector<std::vector<std::vector<std::array<double, 4>>>> read_people(const std::string& dataset) {
  std::vector<std::vector<std::vector<std::array<double, 4>>>> frames;
  std::ifstream f(dataset + "/frames.jsonl");
  for (std::string line; std::getline(f, line);) {
    const json j = json::parse(line);
    auto& people = frames.emplace_back();
    for (const json& p : j.at("people")) {
      auto& joints = people.emplace_back();
      for (const json& q : p.at("joints")) joints.push_back({q[0].get<double>(), q[1].get<double>(), q[2].get<double>(), q[3].get<double>()});
    }
  }
  return frames;
}

// The recording every test here uses: two people, floor, clutter, made once per process. The people
// are bare adults, the bodies the shipped model was trained on: these tests check the app (users,
// ids, joints per user), not how the model generalizes to clothes or children.
struct Scene {
  TempDir dir;
  std::string dataset, oni;
  Scene() {
    dataset = dir / "scene";
    oni = dir / "scene.oni";
    EXPECT_EQ(run_cli({"synth", "--assets", kAssets, "--out", dataset, "--frames", std::to_string(kFrames), "--floor",
                       "--clutter", "4", "--people", "2", "--sequence", "--seed", "25", "--clips", "02_01",
                       "--threads", "2", "--clothed", "0", "--bodies", "adult"}),
              0);
    const std::string spec = "dataset:" + dataset;
    platform::RecordOptions ro;
    ro.zero_border = true;
    platform::record_oni([&] { return platform::open_source(spec); }, true, oni, ro);
  }
};

Scene& scene() {
  static Scene s;
  return s;
}

RunOptions options_for(const std::string& spec) {
  RunOptions o;
  o.blob_path = kBlob;
  o.source_spec = spec;
  o.json = true;
  o.usb_watch = false;
  return o;
}

}  // namespace

TEST(SynthSequenceSharedData, OneSceneWithBodiesSteppingThroughTheirClips) {
  SynthConfig c;
  c.clips = {"02_01"};
  c.floor = true;
  c.people = 2;
  c.clutter = 3;
  c.sequence = true;
  Synthesizer synth(kAssets, c);
  const FrameParams a = synth.sample_frame_params(25, 0), b = synth.sample_frame_params(25, 7);
  // One scene: camera, placements, shapes and clutter of frame 0 in every frame.
  EXPECT_EQ(a.camera_height_m, b.camera_height_m);
  EXPECT_EQ(a.camera_pitch_deg, b.camera_pitch_deg);
  EXPECT_EQ(a.distance_m, b.distance_m);
  EXPECT_EQ(a.image_x, b.image_x);
  ASSERT_EQ(a.others.size(), 1u);
  EXPECT_EQ(a.others[0].distance_m, b.others[0].distance_m);
  ASSERT_EQ(a.clutter.size(), b.clutter.size());
  for (size_t i = 0; i < a.clutter.size(); ++i) EXPECT_EQ(a.clutter[i].x, b.clutter[i].x);
  // Bodies step through the unpruned clip, one mocap sample per frame; noise differs.
  const size_t n = synth.pose_library().poses.size();
  EXPECT_EQ(n, synth.pose_library().candidate_count) << "a sequence keeps every sampled frame";
  EXPECT_EQ(b.pose_index, (a.pose_index + 7) % n);
  EXPECT_EQ(b.others[0].pose_index, (a.others[0].pose_index + 7) % n);
  EXPECT_NE(a.noise_seed, b.noise_seed);
  // Consecutive frames are consecutive in time: no joint jumps more than a hand moves in 33 ms.
  const SynthFrame f0 = synth.render(synth.sample_frame_params(25, 3));
  const SynthFrame f1 = synth.render(synth.sample_frame_params(25, 4));
  for (size_t p = 0; p < 2; ++p)
    for (int j = 0; j < 16; ++j) {
      const auto& x = f0.people_joints[p][size_t(j)];
      const auto& y = f1.people_joints[p][size_t(j)];
      EXPECT_LT(std::hypot(x.x - y.x, x.y - y.y, x.z - y.z), 0.12) << "person " << p << " joint " << j;
    }
}

TEST(AppRunUsersSharedData, TwoPeopleOnARecordingGetJointsUnderStableIds) {
  Scene& s = scene();
  const auto truth = read_people(s.dataset);
  ASSERT_EQ(truth.size(), size_t(kFrames));
  Captured c = run_captured(options_for("oni:" + s.oni));  // auto: .oni → segmentation on
  ASSERT_EQ(c.lines.size(), size_t(kFrames)) << c.log;
  EXPECT_NE(c.log.find("segmentation on"), std::string::npos) << c.log;
  EXPECT_TRUE(c.summary.segmented);
  EXPECT_EQ(c.summary.distinct_user_ids, 2) << c.log;
  std::map<int, int> person_of_id;  // id → ground-truth person, fixed by the first frame
  for (const json& line : c.lines) {
    const int frame = line["frame"].get<int>();
    SCOPED_TRACE(frame);
    ASSERT_TRUE(line.contains("users"));
    ASSERT_EQ(line["users"].size(), 2u) << line["users"].dump();
    EXPECT_TRUE(line.contains("segmentation") && line["segmentation"]["stage_cycles"].contains("components"));
    EXPECT_GE(line["frame_cycles"].get<uint64_t>(), line["total_cycles"].get<uint64_t>());
    // The top level is the primary user's (most pixels); cycles and pixels are summed over users.
    const json& users = line["users"];
    const json& primary = users[0]["pixels"].get<int>() >= users[1]["pixels"].get<int>() ? users[0] : users[1];
    EXPECT_EQ(line["primary_user"].get<int>(), primary["id"].get<int>());
    EXPECT_EQ(line["joints"], primary["joints"]);
    EXPECT_EQ(line["evaluated_pixels"].get<int>(),
              users[0]["evaluated_pixels"].get<int>() + users[1]["evaluated_pixels"].get<int>());
    EXPECT_EQ(line["total_cycles"].get<uint64_t>(), users[0]["cycles"].get<uint64_t>() + users[1]["cycles"].get<uint64_t>());
    for (const json& u : line["users"]) {
      const int id = u["id"].get<int>();
      EXPECT_EQ(u["frames_tracked"].get<int>(), frame + 1) << "id " << id << " was lost or renumbered";
      EXPECT_EQ(u["arrival"].get<std::string>(), frame == 0 ? "new" : "continued") << "id " << id;
      // Which person is this user? The one the median distance of its joints to the person's
      // visible joints is smallest for, by a clear margin over the other person.
      std::vector<double> medians;
      for (size_t p = 0; p < truth[size_t(frame)].size(); ++p) {
        std::vector<double> d;
        for (int j = 0; j < 16; ++j) {
          const json& q = u["joints"][j];
          const auto& t = truth[size_t(frame)][p][size_t(j)];
          if (q["x"].is_null() || t[3] == 0) continue;
          d.push_back(std::hypot(q["x"].get<double>() - t[0], q["y"].get<double>() - t[1], q["z"].get<double>() - t[2]));
        }
        ASSERT_GE(d.size(), 8u) << "user " << id << " has too few joints on person " << p;
        std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
        medians.push_back(d[d.size() / 2]);
      }
      ASSERT_EQ(medians.size(), 2u);
      const int best_person = medians[0] < medians[1] ? 0 : 1;
      const double best = medians[size_t(best_person)], other = medians[size_t(1 - best_person)];
      EXPECT_LT(best, 0.15) << "user " << id << " joints are not on a person";
      EXPECT_LT(2 * best, other) << "user " << id << " is not clearly one person";
      if (!person_of_id.count(id)) person_of_id[id] = best_person;
      EXPECT_EQ(person_of_id[id], best_person) << "id " << id << " moved to another person";
    }
  }
  EXPECT_EQ(person_of_id.size(), 2u);
  if (person_of_id.size() == 2u) {
    EXPECT_NE(person_of_id.begin()->second, person_of_id.rbegin()->second);
  }
}

TEST(AppRunUsersSharedData, TextModePrintsOneLinePerUser) {
  RunOptions o = options_for("oni:" + scene().oni);
  o.json = false;
  o.max_frames = 3;
  Captured c = run_captured(o);
  ASSERT_EQ(c.text.size(), 9u) << c.log;  // frame line + two user lines, three frames
  EXPECT_NE(c.text[0].find("2 user(s)"), std::string::npos) << c.text[0];
  EXPECT_EQ(c.text[1].rfind("frame 0 user 1 (", 0), 0u) << c.text[1];
  EXPECT_EQ(c.text[2].rfind("frame 0 user 2 (", 0), 0u) << c.text[2];
  EXPECT_NE(c.text[4].find("tracked 2 frames"), std::string::npos) << c.text[4];
}

// Text mode prints each joint as the tracker reports it (the same position, state and calibrated
// confidence as --json), not a raw vote weight.
TEST(AppRunUsersSharedData, TextModeJointsCarryStateAndConfidenceAsJson) {
  RunOptions o = options_for("oni:" + scene().oni);
  o.max_frames = 3;
  const Captured js = run_captured(o);
  o.json = false;
  const Captured text = run_captured(o);
  ASSERT_EQ(js.lines.size(), 3u) << js.log;
  ASSERT_EQ(text.text.size(), 9u) << text.log;
  int tracked = 0;
  for (size_t f = 0; f < 3; ++f) {
    const json& line = js.lines[f];
    ASSERT_TRUE(line.at("skeleton").get<bool>());
    ASSERT_EQ(line.at("users").size(), 2u);
    for (size_t i = 0; i < 2; ++i) {
      const std::string& t = text.text[f * 3 + 1 + i];
      EXPECT_EQ(t.find("votes"), std::string::npos) << t;
      EXPECT_EQ(t.find("e+"), std::string::npos) << t;
      // " name x y z state confidence" per joint, " name -" when missing, joined by " | ".
      std::istringstream in(t.substr(t.find("):") + 2));
      for (const json& j : line.at("users")[i].at("joints")) {
        std::string name, x;
        ASSERT_TRUE(in >> name >> x) << t;
        EXPECT_EQ(name, j.at("name").get<std::string>()) << t;
        if (j.at("state") == "missing") {
          EXPECT_EQ(x, "-") << t;
        } else {
          std::string y, z, state, confidence;
          ASSERT_TRUE(in >> y >> z >> state >> confidence) << t;
          EXPECT_NEAR(std::stod(x), j.at("x").get<double>(), 6e-4) << t;
          EXPECT_NEAR(std::stod(z), j.at("z").get<double>(), 6e-4) << t;
          EXPECT_EQ(state, j.at("state").get<std::string>()) << t;
          const double c = std::stod(confidence);
          EXPECT_NEAR(c, j.at("confidence").get<double>(), 1e-9) << t;
          EXPECT_GE(c, 0.0);
          EXPECT_LE(c, 1.0);
          tracked += state == "tracked";
        }
        std::string bar;
        if (in >> bar) {
          EXPECT_EQ(bar, "|") << t;
        }
      }
    }
  }
  EXPECT_GT(tracked, 3 * 2 * 8) << "most joints of two people in view are tracked";
}

TEST(AppRunUsersSharedData, SegmentOffAndAutoOnDatasets) {
  // --segment off: the whole band is foreground (floor and clutter included); no users reported.
  RunOptions off = options_for("oni:" + scene().oni);
  off.segment = SegmentMode::kOff;
  off.max_frames = 2;
  Captured a = run_captured(off);
  ASSERT_EQ(a.lines.size(), 2u);
  EXPECT_FALSE(a.lines[0].contains("users"));
  // auto on a dataset: off (datasets are usually cut out already); kOn there: users, no model.
  RunOptions ds = options_for("dataset:" + scene().dataset);
  ds.max_frames = 2;
  Captured b = run_captured(ds);
  ASSERT_EQ(b.lines.size(), 2u);
  EXPECT_FALSE(b.lines[0].contains("users"));
  ds.segment = SegmentMode::kOn;
  Captured on = run_captured(ds);
  ASSERT_EQ(on.lines.size(), 2u);
  ASSERT_TRUE(on.lines[1].contains("users"));
  EXPECT_EQ(on.lines[1]["users"].size(), 2u);
  EXPECT_NE(on.log.find("no background model"), std::string::npos) << on.log;
  // The segmenter removes the floor and the clutter: far fewer foreground pixels than without.
  EXPECT_LT(on.lines[1]["foreground_pixels"].get<int>() * 2, a.lines[1]["foreground_pixels"].get<int>());
}

TEST(AppRunUsersSharedData, BadSegmentModeIsRefused) {
  EXPECT_THROW(run_cli({"run", "--blob", kBlob, "--source", "oni:" + scene().oni, "--segment", "maybe"}), ToolError);
}

TEST(AppRunUsersSharedData, EvalSegmentReportsSegmentationQuality) {
  // `depthpose eval --segment` measures the segmenter on a labelled dataset (segeval's protocol).
  Scene& s = scene();
  const std::string out = s.dir / "seg.json";
  ASSERT_EQ(run_cli({"eval", "--segment", "--data", s.dataset, "--live", "--json", out}), 0);
  std::ifstream f(out);
  const json j = json::parse(f);
  EXPECT_EQ(j["frames"].get<int>(), kFrames);
  EXPECT_EQ(j["people"].get<int>(), 2 * kFrames);
  EXPECT_GE(j["detection_rate"].get<double>(), 0.95);
  EXPECT_GT(j["foreground_iou_pooled"].get<double>(), 0.8);
  EXPECT_LE(j["false_users_per_frame"].get<double>(), 0.1);
}

// reid-eval's plumbing on the two-person scene: a gap shorter than track_keep_frames is an
// occlusion (the same id back), and a newcomer meanwhile gets a fresh id; a sequence too short for
// --leave + --gap is refused naming it.
TEST(ReidEvalSharedData, ShortGapKeepsTheIdAndTooShortSequencesAreRefused) {
  ReidEvalOptions o;
  o.datasets = {scene().dataset};
  o.leave_frame = 12;
  o.gap_frames = 10;
  const std::vector<ReidSequenceResult> r = evaluate_reid(o);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(reid_outcome_name(r[0].return_outcome), std::string("same"));
  EXPECT_EQ(reid_outcome_name(r[0].newcomer_outcome), std::string("new"));
  EXPECT_GT(r[0].person1_height_m, 1.0);
  EXPECT_GT(r[0].person2_height_m, 1.0);
  o.leave_frame = 20;
  o.gap_frames = 20;
  try {
    evaluate_reid(o);
    ADD_FAILURE() << "a 30-frame sequence was accepted for leave + gap = 40";
  } catch (const ToolError& e) {
    EXPECT_NE(std::string(e.what()).find(scene().dataset), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("needs more than --leave + --gap = 40"), std::string::npos) << e.what();
  }
}
