// SegmenterConfig from its one table (runtime/segmentation/segmenter_config.h): the struct, the
// runtime validation, the strict text parser of the tools, the docs table, and
// `segeval`/`run --segment-config` reading a file.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tests/app_run_support.h"
#include "tests/app_test_support.h"
#include "tests/cli_test_support.h"
#include "tests/segmentation_test_util.h"
#include "tools/common/body_model.h"
#include "tools/common/dataset.h"
#include "tools/common/error.h"
#include "tools/common/png_io.h"
#include "tools/segeval/scene.h"
#include "tools/segeval/segmenter_config_text.h"

using dp::SegmenterConfig;
using dp::tools::ToolError;

namespace {

// Field `index` of `c` set to `v` without any check (to probe the runtime validation).
void set_raw(SegmenterConfig* c, int index, double v) {
  switch (index) {
#define DP_TEST_SET(type, name, def, lo, hi, range, unit, meaning) \
  case dp::segmenter_config_detail::k_##name:                    \
    c->name = static_cast<type>(v);                              \
    break;
    DP_SEGMENTER_CONFIG_FIELDS(DP_TEST_SET)
#undef DP_TEST_SET
  }
}

bool init_accepts(const SegmenterConfig& c) {
  const size_t bytes = dp::segmenter_required_bytes(32, 24);
  std::unique_ptr<uint8_t, decltype(&std::free)> arena(static_cast<uint8_t*>(std::aligned_alloc(64, (bytes + 63) / 64 * 64)),
                                                       &std::free);
  dp::Segmenter s;
  return s.init(c, 32, 24, arena.get(), bytes) == dp::Status::kOk;
}

// The ToolError message of `f`, or "" when it does not throw.
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ToolError& e) {
    return e.what();
  }
  return "";
}

SegmenterConfig parse(const std::string& text) {
  return dp::tools::parse_segmenter_config(text, dp::default_segmenter_config(true), "cfg.txt");
}

}  // namespace

TEST(SegmentationConfig, OneTableDeclaresEveryFieldWithItsDefaultInRange) {
  EXPECT_EQ(dp::kSegmenterConfigFieldCount, 88);
  const SegmenterConfig c;
  int32_t bad = 0;
  EXPECT_TRUE(dp::segmenter_config_check(c, &bad)) << bad;
  for (int i = 0; i < dp::kSegmenterConfigFieldCount; ++i) {
    const dp::SegmenterConfigField& f = dp::kSegmenterConfigFields[i];
    SCOPED_TRACE(f.name);
    EXPECT_EQ(dp::segmenter_config_value(c, i), f.default_value);  // struct default = table default
    EXPECT_TRUE(dp::segmenter_config_in_range(i, f.default_value));
    EXPECT_GT(std::string(f.meaning).size(), 10u);
    EXPECT_EQ(dp::tools::segmenter_config_field_index(f.name), i);
  }
  EXPECT_EQ(dp::tools::segmenter_config_field_index("no_such_key"), -1);
}

TEST(SegmentationConfig, ValidationRejectsEveryValueOutsideItsRange) {
  for (int i = 0; i < dp::kSegmenterConfigFieldCount; ++i) {
    const dp::SegmenterConfigField& f = dp::kSegmenterConfigFields[i];
    SCOPED_TRACE(f.name);
    const bool open_min = f.range == dp::kRangeOpenMin || f.range == dp::kRangeOpen;
    const bool open_max = f.range == dp::kRangeOpenMax || f.range == dp::kRangeOpen;
    const double step = f.type == dp::kConfigFloat ? std::fmax(1e-3, std::fabs(f.min) * 1e-3) : 1.0;
    // Below the minimum (at it when it is excluded); unsigned fields at 0 only when 0 is excluded.
    const double below = open_min ? f.min : f.min - step;
    if (!(f.type == dp::kConfigUint16 && below < 0) && !(f.type == dp::kConfigBool)) {
      SegmenterConfig c;
      set_raw(&c, i, below);
      EXPECT_FALSE(dp::segmenter_config_check(c)) << below;
      EXPECT_FALSE(init_accepts(c)) << below;
    }
    // Above a bounded maximum.
    const bool bounded = f.type == dp::kConfigFloat ? f.max < dp::kConfigUnbounded : f.max < dp::kConfigIntUnbounded;
    if (bounded && f.type != dp::kConfigBool && !(f.type == dp::kConfigUint16 && f.max >= 65535)) {
      const double above = open_max ? f.max : f.max + (f.type == dp::kConfigFloat ? std::fmax(1e-3, f.max * 1e-3) : 1.0);
      SegmenterConfig c;
      set_raw(&c, i, above);
      EXPECT_FALSE(dp::segmenter_config_check(c)) << above;
    }
    if (f.type == dp::kConfigFloat) {
      SegmenterConfig c;
      set_raw(&c, i, std::nan(""));
      EXPECT_FALSE(dp::segmenter_config_check(c)) << "NaN";
      set_raw(&c, i, INFINITY);
      EXPECT_FALSE(dp::segmenter_config_check(c)) << "inf";
    }
  }
}

TEST(SegmentationConfig, BoundariesAndConstraintsAsTheSegmenterNeedsThem) {
  auto valid_with = [](const std::function<void(SegmenterConfig&)>& edit) {
    SegmenterConfig c;
    edit(c);
    return init_accepts(c);
  };
  // fragment_min_share is [0, 0.5): the smaller of two pieces holds at most half of the union.
  EXPECT_TRUE(valid_with([](SegmenterConfig& c) { c.fragment_min_share = 0.0f; }));
  EXPECT_TRUE(valid_with([](SegmenterConfig& c) { c.fragment_min_share = 0.49f; }));
  EXPECT_FALSE(valid_with([](SegmenterConfig& c) { c.fragment_min_share = 0.5f; }));
  EXPECT_FALSE(valid_with([](SegmenterConfig& c) { c.floor_max_tilt_deg = 90.0f; }));
  EXPECT_FALSE(valid_with([](SegmenterConfig& c) { c.cut_fill_border_columns = 2; }));
  EXPECT_FALSE(valid_with([](SegmenterConfig& c) { c.max_users = dp::kMaxUsers + 1; }));
  EXPECT_FALSE(valid_with([](SegmenterConfig& c) { c.far_mm = c.near_mm; }));
  EXPECT_TRUE(valid_with([](SegmenterConfig& c) { c.floor_far_mm = c.near_mm; }));
  EXPECT_FALSE(valid_with([](SegmenterConfig& c) { c.floor_far_mm = uint16_t(c.near_mm - 1); }));
  EXPECT_FALSE(valid_with([](SegmenterConfig& c) { c.floor_wide_inlier_fraction = c.floor_min_inlier_fraction + 0.01f; }));
  EXPECT_FALSE(valid_with([](SegmenterConfig& c) { c.floor_wide_extent_m = c.floor_min_extent_m - 0.1f; }));
  EXPECT_FALSE(valid_with([](SegmenterConfig& c) { c.camera_height_max_m = c.camera_height_min_m; }));
  int32_t bad = 0;
  SegmenterConfig c;
  c.far_mm = 100;
  EXPECT_FALSE(dp::segmenter_config_check(c, &bad));
  EXPECT_EQ(bad, -1);  // constraint 0: far_mm > near_mm
}

TEST(SegmentationConfig, ParsesKeyValueLinesWithComments) {
  const SegmenterConfig c = parse(
      "# deployment: ceiling camera\n"
      "\n"
      "min_person_height_m = 1.2   # taller than the benches\n"
      "  max_users=3\n"
      "background_enabled = false\n"
      "floor_far_mm = 7000\n"
      "fragment_min_share = 0.25\n");
  EXPECT_FLOAT_EQ(c.min_person_height_m, 1.2f);
  EXPECT_EQ(c.max_users, 3);
  EXPECT_FALSE(c.background_enabled);
  EXPECT_EQ(c.floor_far_mm, 7000);
  EXPECT_FLOAT_EQ(c.fragment_min_share, 0.25f);
  EXPECT_FLOAT_EQ(c.join_mm, SegmenterConfig{}.join_mm);  // the rest keeps the base
}

TEST(SegmentationConfig, ParsesAJsonObject) {
  const SegmenterConfig c = parse(R"({"min_person_height_m": 1.1, "max_users": 2, "floor_enabled": false})");
  EXPECT_FLOAT_EQ(c.min_person_height_m, 1.1f);
  EXPECT_EQ(c.max_users, 2);
  EXPECT_FALSE(c.floor_enabled);
  EXPECT_NE(error_of([] { parse(R"({"max_users": 2.5})"); }).find("max_users"), std::string::npos);
  EXPECT_NE(error_of([] { parse(R"({"max_users": "2"})"); }).find("max_users"), std::string::npos);
  EXPECT_NE(error_of([] { parse(R"({"max_users": 2)"); }).find("not valid JSON"), std::string::npos);
  EXPECT_NE(error_of([] { parse(R"({"maxusers": 2})"); }).find("unknown key 'maxusers'"), std::string::npos);
}

TEST(SegmentationConfig, UnknownKeyIsAnErrorNamingIt) {
  const std::string e = error_of([] { parse("min_person_height_m = 1.0\nmin_persn_area_m2 = 0.05\n"); });
  EXPECT_NE(e.find("cfg.txt:2"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown key 'min_persn_area_m2'"), std::string::npos) << e;
}

TEST(SegmentationConfig, BadNumberIsAnErrorNamingKeyAndValue) {
  // A typo no longer becomes 0 (which turns a rule off).
  for (const char* value : {"0,05", "abc", "", "0.05x", "1e", "0x"}) {
    const std::string e = error_of([&] { parse(std::string("fragment_min_share = ") + value + "\n"); });
    SCOPED_TRACE(value);
    EXPECT_NE(e.find("fragment_min_share"), std::string::npos) << e;
    EXPECT_NE(e.find(std::string("'") + value + "'"), std::string::npos) << e;
    EXPECT_NE(e.find("[0, 0.5)"), std::string::npos) << e;
  }
  EXPECT_NE(error_of([] { parse("max_users = 2.5\n"); }).find("not an integer"), std::string::npos);
  EXPECT_NE(error_of([] { parse("floor_enabled = yes\n"); }).find("not a bool"), std::string::npos);
  EXPECT_NE(error_of([] { parse("join_mm = inf\n"); }).find("not a finite number"), std::string::npos);
  EXPECT_NE(error_of([] { parse("join_mm = nan\n"); }).find("join_mm"), std::string::npos);
  EXPECT_NE(error_of([] { parse("join_mm = 1e60\n"); }).find("join_mm"), std::string::npos);
  EXPECT_NE(error_of([] { parse("max_users = 99999999999999999999\n"); }).find("max_users"), std::string::npos);
  EXPECT_NE(error_of([] { parse("join_mm 30\n"); }).find("expected 'key = value'"), std::string::npos);
  EXPECT_NE(error_of([] { parse("join_mm = 30\njoin_mm = 31\n"); }).find("set twice"), std::string::npos);
}

TEST(SegmentationConfig, OutOfRangeValueIsAnErrorNamingKeyValueAndRange) {
  std::string e = error_of([] { parse("fragment_min_share = 0.5\n"); });
  EXPECT_NE(e.find("fragment_min_share = '0.5': out of range (float in [0, 0.5))"), std::string::npos) << e;
  e = error_of([] { parse("max_users = 16\n"); });
  EXPECT_NE(e.find("max_users = '16': out of range (int32 in [1, 15])"), std::string::npos) << e;
  e = error_of([] { parse("join_mm = -1\n"); });
  EXPECT_NE(e.find("join_mm = '-1': out of range (float in (0, 65535])"), std::string::npos) << e;
  e = error_of([] { parse("near_mm = 70000\n"); });
  EXPECT_NE(e.find("near_mm"), std::string::npos) << e;
  // Constraints between keys name both.
  e = error_of([] { parse("camera_height_min_m = 2\ncamera_height_max_m = 1.5\n"); });
  EXPECT_NE(e.find("camera_height_max_m = 1.5 must be > camera_height_min_m = 2"), std::string::npos) << e;
}

TEST(SegmentationConfig, DocsTableIsTheGeneratedOne) {
  const std::string path = "docs/segmentation.md";
  std::ifstream f(path);
  ASSERT_TRUE(f) << path << " not found (run the tests from the repository root)";
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string doc = ss.str();
  const std::string begin = "<!-- config-table:begin (generated: depthpose segeval --print-config-table) -->\n";
  const std::string end = "<!-- config-table:end -->";
  const size_t a = doc.find(begin), b = doc.find(end);
  ASSERT_NE(a, std::string::npos) << path << " lacks the config-table begin marker";
  ASSERT_NE(b, std::string::npos) << path << " lacks the config-table end marker";
  EXPECT_EQ(doc.substr(a + begin.size(), b - a - begin.size()), dp::tools::segmenter_config_table_markdown())
      << "regenerate the table: build/bin/depthpose segeval --print-config-table";
}

namespace {

// A labelled dataset (layout v1 with parts/ and people/) of seeded scenes: 6 frames of seed 3.
struct SceneDataset {
  dp::apptest::TempDir dir;
  std::string path;
  SceneDataset() {
    path = dir / "scenes";
    dp::tools::DatasetMeta meta;
    meta.width = 320;
    meta.height = 240;
    const dp::tools::RenderedScene first = dp::tools::render_scene(dp::tools::random_scene(3, 0));
    meta.fx = first.intrinsics.fx;
    meta.fy = first.intrinsics.fy;
    meta.cx = first.intrinsics.cx;
    meta.cy = first.intrinsics.cy;
    meta.parts = {"body"};
    meta.joints = {"joint0"};
    dp::tools::create_dataset(path, meta, true);
    std::filesystem::create_directories(path + "/people");
    std::vector<dp::tools::FrameRecord> records;
    for (int i = 0; i < 6; ++i) {
      const dp::tools::RenderedScene s = dp::tools::render_scene(dp::tools::random_scene(3, i));
      dp::tools::FrameRecord r;
      r.id = dp::tools::frame_id(size_t(i));
      dp::tools::write_png_u16(path + "/depth/" + r.id + ".png", dp::tools::ImageU16{s.width, s.height, s.depth_mm});
      dp::tools::ImageU8 parts{s.width, s.height, std::vector<uint8_t>(s.truth.size(), dp::tools::kNotBodyLabel)};
      dp::tools::ImageU8 people{s.width, s.height, s.truth};
      int n_people = 0;
      for (size_t p = 0; p < s.truth.size(); ++p) {
        if (s.truth[p]) parts.pixels[p] = 0;
        n_people = std::max<int>(n_people, s.truth[p]);
      }
      dp::tools::write_png_u8(path + "/parts/" + r.id + ".png", parts);
      dp::tools::write_png_u8(path + "/people/" + r.id + ".png", people);
      nlohmann::json extra;
      extra["people"] = nlohmann::json::array();
      for (int k = 0; k < n_people; ++k) extra["people"].push_back({{"joints", {{0.0, 0.0, 2.0, true}}}});
      r.extra_json = extra.dump();
      r.joints.assign(1, dp::tools::JointTruth{0, 0, 2, true});
      records.push_back(r);
    }
    dp::tools::write_frames_jsonl(path, records);
  }
};

SceneDataset& scene_dataset() {
  static SceneDataset d;
  return d;
}

nlohmann::json segeval_json(const std::vector<std::string>& extra) {
  SceneDataset& d = scene_dataset();
  const std::string out = d.dir / ("segeval_" + std::to_string(extra.size()) + ".json");
  std::vector<std::string> args{"segeval", "--data", d.path, "--json", out};
  args.insert(args.end(), extra.begin(), extra.end());
  EXPECT_EQ(dp::testsupport::run_cli(args), 0);
  std::ifstream f(out);
  return nlohmann::json::parse(f);
}

std::string write_file(const std::string& name, const std::string& text) {
  const std::string p = scene_dataset().dir / name;
  std::ofstream(p) << text;
  return p;
}

}  // namespace

TEST(SegmentationConfig, SegevalReadsASegmentConfigFileThatChangesTheResult) {
  const nlohmann::json base = segeval_json({});
  ASSERT_GT(base["people_found"].get<int>(), 0);
  // Nobody is 2.5 m tall: no one passes the person test.
  const std::string cfg = write_file("tall.cfg", "# stricter\nmin_person_height_m = 2.5\nmin_person_area_m2 = 5\n");
  const nlohmann::json tall = segeval_json({"--segment-config", cfg});
  EXPECT_LT(tall["people_found"].get<int>(), base["people_found"].get<int>());
  // --set goes through the same strict parser.
  const nlohmann::json set = segeval_json({"--set", "min_person_height_m=2.5,min_person_area_m2=5"});
  EXPECT_EQ(set["people_found"], tall["people_found"]);
  EXPECT_THROW(dp::testsupport::run_cli({"segeval", "--data", scene_dataset().path, "--set", "min_person_height_m=2,5"}),
               ToolError);
  EXPECT_THROW(dp::testsupport::run_cli({"segeval", "--data", scene_dataset().path, "--set", "fragment_min_share=0.6"}),
               ToolError);
  const std::string typo = write_file("typo.cfg", "min_person_hieght_m = 1\n");
  const std::string e = error_of([&] { dp::testsupport::run_cli({"segeval", "--data", scene_dataset().path, "--segment-config", typo}); });
  EXPECT_NE(e.find("unknown key 'min_person_hieght_m'"), std::string::npos) << e;
}

TEST(SegmentationConfig, RunReadsASegmentConfigFile) {
  dp::tools::RunOptions o;
  o.blob_path = "models/bpc.blob";
  o.source_spec = "dataset:" + scene_dataset().path;
  o.json = true;
  o.usb_watch = false;
  o.segment = dp::tools::SegmentMode::kOn;
  const dp::apptest::Captured base = dp::apptest::run_captured(o);
  ASSERT_EQ(base.lines.size(), 6u) << base.log;
  size_t users = 0;
  for (const nlohmann::json& line : base.lines) users += line.contains("users") ? line["users"].size() : 0;
  ASSERT_GT(users, 0u) << "the seeded scenes should hold users";
  o.segment_config_path = write_file("run_tall.cfg", "min_person_height_m = 2.5\nmin_person_area_m2 = 5\n");
  const dp::apptest::Captured tall = dp::apptest::run_captured(o);
  ASSERT_EQ(tall.lines.size(), 6u) << tall.log;
  size_t tall_users = 0;
  for (const nlohmann::json& line : tall.lines) tall_users += line.contains("users") ? line["users"].size() : 0;
  EXPECT_LT(tall_users, users);
  EXPECT_NE(tall.log.find("run_tall.cfg"), std::string::npos) << tall.log;
  // Errors reach the command line naming the key: out of range, unknown key, bad number.
  auto run_error = [&](const std::string& name, const std::string& text) {
    const std::string file = write_file(name, text);
    return error_of([&] {
      dp::testsupport::run_cli({"run", "--blob", "models/bpc.blob", "--source", "dataset:" + scene_dataset().path,
                                "--segment", "on", "--segment-config", file});
    });
  };
  std::string e = run_error("run_range.cfg", "max_users = 0\n");
  EXPECT_NE(e.find("max_users = '0': out of range (int32 in [1, 15])"), std::string::npos) << e;
  e = run_error("run_key.cfg", "# typo\nmax_user = 2\n");
  EXPECT_NE(e.find("run_key.cfg:2: unknown key 'max_user'"), std::string::npos) << e;
  e = run_error("run_number.cfg", "min_person_height_m = 1,2\n");
  EXPECT_NE(e.find("min_person_height_m = '1,2': not a number"), std::string::npos) << e;
  // With segmentation off the file would be ignored: an error instead.
  const std::string good = write_file("run_good.cfg", "max_users = 2\n");
  e = error_of([&] {
    dp::testsupport::run_cli({"run", "--blob", "models/bpc.blob", "--source", "dataset:" + scene_dataset().path,
                              "--segment", "off", "--segment-config", good});
  });
  EXPECT_NE(e.find("segmentation is off"), std::string::npos) << e;
}
