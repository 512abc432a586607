// The synthesizer on the shared MakeHuman body and CMU clip 02_01: labels, retargeting, mirroring,
// shape, determinism across thread counts and the written dataset.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <tuple>
#include <sstream>

#include <nlohmann/json.hpp>

#include "tools/cli/command.h"
#include "tools/common/body_model.h"
#include "tools/common/dataset.h"
#include "tools/synth/synth.h"
#include "tests/shared_data.h"

namespace dp::synth {
namespace {
namespace fs = std::filesystem;
using dp::tools::kJointMirror;
using dp::tools::kPartMirror;

const std::string kAssets = dp::test::shared_path("assets");

class SynthRenderSharedData : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ASSERT_TRUE(fs::exists(kAssets + "/makehuman/3dobjs/base.obj"))
        << "shared assets missing: expected " << kAssets << " (set DEPTHPOSE_SHARED or make test SHARED=DIR)";
    SynthConfig c;
    c.clips = {"02_01"};
    synth_ = std::make_unique<Synthesizer>(kAssets, c);
  }
  static void TearDownTestSuite() { synth_.reset(); }
  static std::unique_ptr<Synthesizer> synth_;
};
std::unique_ptr<Synthesizer> SynthRenderSharedData::synth_;

TEST_F(SynthRenderSharedData, EveryPartAppearsInAFrontalRender) {
  const DepthLabelImage img = synth_->render_body_view(rest_pose(synth_->assets()), 0, 480, 640);
  std::vector<int> count(256, 0);
  for (uint8_t l : img.label) count[l]++;
  for (int p = 0; p < dp::tools::kPartCount; ++p)
    EXPECT_GE(count[p], 20) << "part " << dp::tools::kPartNames[p] << " (" << p << ") barely visible";
  for (int l = dp::tools::kPartCount; l < 255; ++l) EXPECT_EQ(count[l], 0) << l;
}

TEST_F(SynthRenderSharedData, LabelTableIsMirrorSymmetric) {
  // Every vertex at (x, y, z) with label p has a partner at (-x, y, z) with label mirror(p).
  const HumanAssets& a = synth_->assets();
  const std::vector<uint8_t>& labels = synth_->vertex_labels();
  ASSERT_EQ(labels.size(), size_t(kBodyVertexCount));
  std::map<std::tuple<long, long, long>, std::vector<uint8_t>> by_position;
  auto key = [](float x, float y, float z) {
    return std::make_tuple(std::lround(x * 1e4), std::lround(y * 1e4), std::lround(z * 1e4));
  };
  for (int v = 0; v < kBodyVertexCount; ++v) {
    const Vec3f& p = a.base_vertices[v];
    by_position[key(p.x, p.y, p.z)].push_back(labels[v]);
  }
  int checked = 0, matched = 0;
  for (int v = 0; v < kBodyVertexCount; ++v) {
    const Vec3f& p = a.base_vertices[v];
    if (std::fabs(p.x) < 1e-4f) continue;  // on the mid plane: its own partner
    auto it = by_position.find(key(-p.x, p.y, p.z));
    if (it == by_position.end()) continue;
    ++checked;
    for (uint8_t l : it->second) matched += l == kPartMirror[labels[v]];
  }
  EXPECT_GT(checked, kBodyVertexCount * 8 / 10);
  EXPECT_GE(matched, checked * 99 / 100);
}

TEST_F(SynthRenderSharedData, TPoseCorrectionPutsArmsOutSideways) {
  const HumanAssets& a = synth_->assets();
  const Skeleton rest = measure_skeleton(a, a.base_vertices);
  for (const char* arm : {"LeftArm", "RightArm"}) {
    const int b = a.bone_index(arm);
    const Vec3 d = (a.tpose_world[b] * (rest.tails[b] - rest.heads[b])).normalized();
    EXPECT_GT(std::fabs(d.x), 0.97) << arm << " not horizontal in the T-pose";
    EXPECT_LT((rest.tails[b] - rest.heads[b]).normalized().y, -0.5) << arm << " rest is not an A-pose";
  }
}

TEST_F(SynthRenderSharedData, RetargetedWalkIsUprightWithLeftOnTheLeft) {
  const HumanAssets& a = synth_->assets();
  const Skeleton rest = measure_skeleton(a, a.base_vertices);
  const PoseLibrary& lib = synth_->pose_library();
  ASSERT_GT(lib.poses.size(), 20u);
  EXPECT_LE(lib.poses.size(), lib.candidate_count);
  for (size_t i = 0; i < lib.poses.size(); ++i) {
    const Skeleton s = pose_skeleton(a, rest, lib.poses[i]);
    const JointSet j = joints_of(a, s);
    EXPECT_GT(j[0].y, j[1].y) << lib.origin[i];                       // head above neck
    EXPECT_GT(j[1].y, std::max(j[10].y, j[11].y) + 0.5) << lib.origin[i];  // neck well above knees
    EXPECT_GT(std::min(j[10].y, j[11].y), std::max(j[12].y, j[13].y)) << lib.origin[i];  // knees above ankles
    EXPECT_GT(j[2].x, j[3].x + 0.2) << lib.origin[i];                 // left shoulder on +x (facing +z)
    // Bones keep their lengths.
    for (size_t b = 0; b < a.bones.size(); ++b)
      EXPECT_NEAR((s.tails[b] - s.heads[b]).norm(), (rest.tails[b] - rest.heads[b]).norm(), 1e-9);
  }
}

TEST_F(SynthRenderSharedData, SkeletonFollowsShape) {
  const HumanAssets& a = synth_->assets();
  ShapeControls tall, short_;
  tall.height = 0.6;
  tall.extra_height = 1.1;
  short_.height = 0.4;
  short_.extra_height = 0.9;
  const JointSet jt = joints_of(a, measure_skeleton(a, shaped_vertices(a, tall)));
  const JointSet js = joints_of(a, measure_skeleton(a, shaped_vertices(a, short_)));
  const double ht = jt[0].y - jt[12].y, hs = js[0].y - js[12].y;  // head to ankle
  EXPECT_GT(ht, hs * 1.2);
  EXPECT_GT(hs, 1.0);
  EXPECT_LT(ht, 2.0);
}

TEST_F(SynthRenderSharedData, MirroredRenderIsTheFlippedImageWithSwappedLabelsAndJoints) {
  FrameParams p = synth_->sample_frame_params(7, 3);
  p.mirror = false;
  p.camera_roll_deg = 0;
  p.yaw_deg = 25;
  p.image_x = synth_->intrinsics().cx / synth_->intrinsics().width;  // hips on the optical axis
  FrameParams m = p;
  m.mirror = true;
  m.yaw_deg = -25;
  const SynthFrame a = synth_->render(p), b = synth_->render(m);
  const int W = a.clean.width, H = a.clean.height;
  int body = 0, same = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x, j = size_t(y) * W + (W - 1 - x);
      const uint8_t la = a.clean.label[i], lb = b.clean.label[j];
      if (la == kNoLabel && lb == kNoLabel) continue;
      ++body;
      const bool depth_same = std::fabs(a.clean.depth[i] - b.clean.depth[j]) < 2e-3;  // float rounding
      same += depth_same && la != kNoLabel && lb == kPartMirror[la];
    }
  ASSERT_GT(body, 1000);
  EXPECT_GE(same, body * 995 / 1000) << same << " of " << body << " body pixels agree";
  for (int jn = 0; jn < dp::tools::kJointCount; ++jn) {
    const auto& ja = a.joints[jn];
    const auto& jb = b.joints[kJointMirror[jn]];
    EXPECT_NEAR(ja.x, -jb.x, 1e-4) << jn;
    EXPECT_NEAR(ja.y, jb.y, 1e-4) << jn;
    EXPECT_NEAR(ja.z, jb.z, 1e-4) << jn;
  }
}

TEST_F(SynthRenderSharedData, FramesArePureFunctionsOfSeedAndIndex) {
  const SynthFrame a = synth_->render_frame(5, 11), b = synth_->render_frame(5, 11), c = synth_->render_frame(6, 11);
  EXPECT_EQ(a.depth.pixels, b.depth.pixels);
  EXPECT_EQ(a.parts.pixels, b.parts.pixels);
  EXPECT_EQ(a.extra_json, b.extra_json);
  EXPECT_NE(a.depth.pixels, c.depth.pixels);
  // The record names the pose's clip and its clips.tsv category (eval groups frames by them).
  const nlohmann::json extra = nlohmann::json::parse(a.extra_json);
  EXPECT_EQ(extra.value("clip", ""), "02_01") << a.extra_json;
  EXPECT_EQ(extra.value("category", ""), "various expressions and human behaviors") << a.extra_json;
  // Parts only where depth has a reading; every reading on the body has a part.
  int body = 0;
  for (size_t i = 0; i < a.parts.pixels.size(); ++i) {
    const uint8_t l = a.parts.pixels[i];
    EXPECT_TRUE(l < dp::tools::kPartCount || l == dp::tools::kNotBodyLabel);
    if (l != dp::tools::kNotBodyLabel) {
      ++body;
      EXPECT_NE(a.depth.pixels[i], 0);
    }
  }
  EXPECT_GT(body, 100);
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

int run_synth(std::vector<std::string> args) {
  const dp::cli::Command* cmd = dp::cli::find_command("synth");
  EXPECT_NE(cmd, nullptr);
  if (!cmd) return -1;
  std::vector<char*> argv;
  args.insert(args.begin(), "synth");
  for (auto& a : args) argv.push_back(a.data());
  return cmd->run(int(argv.size()), argv.data());
}

TEST(SynthCommandSharedData, DatasetIsValidAndIdenticalForAnyThreadCount) {
  char pattern[] = "/tmp/synth_render_test_XXXXXX";
  const std::string dir = mkdtemp(pattern);
  const std::string one = dir + "/t1", two = dir + "/t2";
  ASSERT_EQ(run_synth({"--assets", kAssets, "--out", one, "--frames", "6", "--seed", "3", "--clips", "02_01",
                       "--threads", "1", "--floor"}),
            0);
  ASSERT_EQ(run_synth({"--assets", kAssets, "--out", two, "--frames", "6", "--seed", "3", "--clips", "02_01",
                       "--threads", "2", "--floor", "--preview", dir + "/preview.png"}),
            0);
  int files = 0;
  for (auto& e : fs::recursive_directory_iterator(one)) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), one);
    ASSERT_TRUE(fs::exists(fs::path(two) / rel)) << rel;
    EXPECT_EQ(slurp(e.path()), slurp(fs::path(two) / rel)) << rel << " differs between 1 and 2 threads";
    ++files;
  }
  EXPECT_EQ(files, 2 + 6 * 2);
  EXPECT_TRUE(fs::exists(dir + "/preview.png"));

  dp::tools::Dataset ds = dp::tools::open_dataset(one);
  EXPECT_EQ(ds.meta.width, 320);
  EXPECT_EQ(ds.meta.height, 240);
  EXPECT_NEAR(ds.meta.fx, 525.0 / 2, 1e-9);
  ASSERT_EQ(ds.meta.parts.size(), size_t(dp::tools::kPartCount));
  ASSERT_EQ(ds.meta.joints.size(), size_t(dp::tools::kJointCount));
  for (int p = 0; p < dp::tools::kPartCount; ++p) EXPECT_EQ(ds.meta.parts[p], dp::tools::kPartNames[p]);
  ASSERT_EQ(ds.frames.size(), 6u);
  EXPECT_TRUE(ds.has_parts);
  for (size_t i = 0; i < ds.frames.size(); ++i) {
    EXPECT_EQ(ds.frames[i].id, dp::tools::frame_id(i));
    ASSERT_EQ(ds.frames[i].joints.size(), size_t(dp::tools::kJointCount));
    const auto depth = ds.load_depth(i);
    const auto parts = ds.load_parts(i);
    int floor_pixels = 0;
    for (size_t k = 0; k < depth.pixels.size(); ++k) floor_pixels += depth.pixels[k] != 0 && parts.pixels[k] == 255;
    EXPECT_GT(floor_pixels, 1000) << "--floor should fill the background";
    // Visible joints project inside the image onto something not much nearer than themselves.
    for (const auto& j : ds.frames[i].joints) {
      EXPECT_GT(j.z, 0.3f);
      if (!j.visible) continue;
      const double u = ds.meta.cx + ds.meta.fx * j.x / j.z, v = ds.meta.cy - ds.meta.fy * j.y / j.z;
      EXPECT_TRUE(u > -0.5 && v > -0.5 && u < ds.meta.width - 0.5 && v < ds.meta.height - 0.5);
    }
  }
  fs::remove_all(dir);
}

TEST(SynthCommand, MissingAssetsNameTheFile) {
  try {
    run_synth({"--assets", "/nonexistent/assets", "--out", "/tmp/never", "--frames", "1"});
    FAIL() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/assets"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dp::synth
