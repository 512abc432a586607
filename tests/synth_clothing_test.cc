// Clothing and hair on the synthetic bodies (tools/synth/wardrobe.h) with the shared MakeHuman CC0
// wardrobe: every item loads, garments follow the posed body, garment pixels carry body-part
// labels, hidden body vertices are gone, and clothed frames are deterministic across threads.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <thread>

#include "tools/cli/command.h"
#include "tools/common/body_model.h"
#include "tools/common/error.h"
#include "tools/synth/synth.h"
#include "tests/shared_data.h"

namespace dp::synth {
namespace {

const std::string kAssets = dp::test::shared_path("assets");

class SynthClothingSharedData : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ASSERT_TRUE(std::filesystem::exists(kAssets + "/makehuman/clothes"))
        << "shared wardrobe missing: expected " << kAssets << "/makehuman/clothes (set DEPTHPOSE_SHARED or make test SHARED=DIR)";
    SynthConfig c;
    c.clips = {"02_01"};
    c.clothed_share = 1.0;
    c.hat_probability = 0.5;
    synth_ = std::make_unique<Synthesizer>(kAssets, c);
  }
  static void TearDownTestSuite() { synth_.reset(); }
  static std::unique_ptr<Synthesizer> synth_;
};
std::unique_ptr<Synthesizer> SynthClothingSharedData::synth_;

const WornGarment* find_garment(const Wardrobe& w, GarmentKind kind, const std::string& name, int* index = nullptr) {
  const auto& list = w.of(kind);
  for (size_t i = 0; i < list.size(); ++i)
    if (list[i].garment.name == name) {
      if (index) *index = int(i);
      return &list[i];
    }
  return nullptr;
}

TEST_F(SynthClothingSharedData, WardrobeHoldsEveryItemWithBodyPartLabels) {
  const Wardrobe& w = synth_->wardrobe();
  EXPECT_EQ(w.of(GarmentKind::kOutfit).size(), 12u);
  EXPECT_EQ(w.of(GarmentKind::kShoes).size(), 6u);
  EXPECT_EQ(w.of(GarmentKind::kHat).size(), 2u);
  EXPECT_EQ(w.of(GarmentKind::kHair).size(), 10u);
  for (const auto& list : w.items)
    for (const WornGarment& g : list) {
      ASSERT_EQ(g.labels.size(), g.garment.bindings.size()) << g.path;
      for (uint8_t l : g.labels) ASSERT_LT(l, dp::tools::kPartCount) << g.path;
    }
  // The label comes from the body beneath: shoes are feet, hair is head or neck or torso.
  for (const WornGarment& g : w.of(GarmentKind::kShoes))
    for (uint8_t l : g.labels) {
      const std::string part = dp::tools::kPartNames[l];
      ASSERT_TRUE(part.find("foot") != std::string::npos || part.find("ankle") != std::string::npos ||
                  part.find("knee") != std::string::npos || part.find("leg") != std::string::npos)
          << g.path << " labelled " << part;
    }
}

TEST_F(SynthClothingSharedData, GarmentFollowsItsBoundVerticesThroughShapeAndPose) {
  const HumanAssets& a = synth_->assets();
  ShapeControls shape;
  shape.gender = 0.2;
  shape.age = 0.3;
  shape.weight = 0.8;
  shape.extra_height = 1.05;
  const std::vector<Vec3f> shaped = shaped_vertices(a, shape);
  const Skeleton rest = measure_skeleton(a, shaped);
  const WornGarment* hair = find_garment(synth_->wardrobe(), GarmentKind::kHair, "afro01");
  ASSERT_NE(hair, nullptr);
  std::vector<Vec3f> out;

  // Rest pose: exactly the mhclo formula on the shaped body.
  {
    const BodyPose pose = rest_pose(a);
    pose_garment(*hair, a, shaped, bone_skin_transforms(a, rest, pose_skeleton(a, rest, pose), pose), out);
    std::vector<Vec3f> fitted;
    fit_garment(hair->garment, shaped, fitted);
    ASSERT_EQ(out.size(), fitted.size());
    for (size_t i = 0; i < out.size(); ++i) {
      ASSERT_NEAR(out[i].x, fitted[i].x, 1e-5) << i;
      ASSERT_NEAR(out[i].y, fitted[i].y, 1e-5) << i;
      ASSERT_NEAR(out[i].z, fitted[i].z, 1e-5) << i;
    }
  }
  // A mocap pose: the barycentric part is the posed body's own vertices (skin_body, an independent
  // path), the rest is the offset turned with the body, so its length is kept.
  const BodyPose& pose = synth_->pose_library().poses[synth_->pose_library().poses.size() / 2];
  const Skeleton posed = pose_skeleton(a, rest, pose);
  std::vector<Vec3f> body;
  skin_body(a, shaped, rest, posed, pose, body);
  pose_garment(*hair, a, shaped, bone_skin_transforms(a, rest, posed, pose), out);
  const Vec3 s = garment_offset_scale(hair->garment, shaped);
  double worst = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    const GarmentBinding& b = hair->garment.bindings[i];
    Vec3 bary;
    for (int k = 0; k < 3; ++k) {
      const Vec3f& p = body[b.vertices[size_t(k)]];
      bary += Vec3{p.x, p.y, p.z} * b.weights[size_t(k)];
    }
    const double offset = Vec3{b.offset[0] * s.x, b.offset[1] * s.y, b.offset[2] * s.z}.norm();
    const double moved = (Vec3{out[i].x, out[i].y, out[i].z} - bary).norm();
    worst = std::max(worst, std::fabs(moved - offset));
    ASSERT_NEAR(moved, offset, 0.05 * offset + 2e-4) << "garment vertex " << i;
  }
  EXPECT_GT(worst, 0.0);  // the pose is not the rest pose
}

TEST_F(SynthClothingSharedData, HiddenBodyVerticesAreGone) {
  const HumanAssets& a = synth_->assets();
  int index = -1;
  const WornGarment* suit = find_garment(synth_->wardrobe(), GarmentKind::kOutfit, "male_casualsuit01", &index);
  ASSERT_NE(suit, nullptr);
  std::vector<uint8_t> hidden(kBodyVertexCount, 0);
  size_t hidden_body = 0;
  for (uint32_t v : suit->garment.delete_vertices)
    if (v < uint32_t(kBodyVertexCount)) hidden[v] = 1, ++hidden_body;
  ASSERT_GT(hidden_body, 1000u);
  Outfit outfit;
  outfit.outfit = index;
  const BodyPose pose = rest_pose(a);
  const Skeleton rest = measure_skeleton(a, a.base_vertices);
  std::vector<Vec3f> verts;
  skin_body(a, a.base_vertices, rest, rest, pose, verts);
  std::vector<uint8_t> labels;
  std::vector<std::array<uint32_t, 3>> triangles;
  dress_body(synth_->wardrobe(), outfit, a, synth_->vertex_labels(), a.base_vertices,
             bone_skin_transforms(a, rest, rest, pose), verts, labels, triangles);
  ASSERT_EQ(verts.size(), size_t(kBodyVertexCount) + suit->garment.bindings.size());
  ASSERT_EQ(labels.size(), verts.size());
  size_t body_triangles = 0;
  for (const auto& t : triangles) {
    for (uint32_t v : t) {
      ASSERT_LT(v, verts.size());
      if (v < uint32_t(kBodyVertexCount)) {
        ASSERT_FALSE(hidden[v]) << "hidden body vertex " << v << " still drawn";
      }
    }
    if (t[0] < uint32_t(kBodyVertexCount)) ++body_triangles;
  }
  EXPECT_LT(body_triangles + 1000, a.body_triangles.size());
  EXPECT_EQ(triangles.size() - body_triangles, suit->garment.triangles.size());
}

TEST_F(SynthClothingSharedData, GarmentPixelsCarryBodyPartLabels) {
  size_t garment_pixels = 0, frames = 0;
  for (uint64_t i = 0; i < 8; ++i) {
    FrameParams p = synth_->sample_frame_params(5, i);
    ASSERT_TRUE(p.outfit.clothed()) << "clothed share 1";
    const SynthFrame dressed = synth_->render(p);
    FrameParams bare_params = p;
    bare_params.outfit = Outfit{};
    const SynthFrame bare = synth_->render(bare_params);
    const DepthLabelImage& d = dressed.clean;
    for (size_t k = 0; k < d.depth.size(); ++k) {
      if (d.depth[k] == 0) continue;
      ASSERT_LT(d.label[k], dp::tools::kPartCount) << "frame " << i << " pixel " << k << " drawn without a body label";
      const bool garment = bare.clean.depth[k] == 0 || d.depth[k] < bare.clean.depth[k] - 0.004f;
      garment_pixels += garment;
    }
    for (size_t k = 0; k < dressed.parts.pixels.size(); ++k)
      if (dressed.depth.pixels[k] != 0) {
        ASSERT_LT(dressed.parts.pixels[k], dp::tools::kPartCount);
      }
    ++frames;
  }
  EXPECT_GT(garment_pixels, 100 * frames) << "clothes barely visible";
}

TEST_F(SynthClothingSharedData, ClothedFramesAreDeterministicAcrossThreads) {
  const int n = 6;
  std::vector<SynthFrame> serial(n), parallel(n);
  for (int i = 0; i < n; ++i) serial[size_t(i)] = synth_->render_frame(9, uint64_t(i));
  std::vector<std::thread> threads;
  for (int t = 0; t < 2; ++t)
    threads.emplace_back([&, t] {
      for (int i = t; i < n; i += 2) parallel[size_t(i)] = synth_->render_frame(9, uint64_t(i));
    });
  for (auto& t : threads) t.join();
  int hats = 0;
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(serial[size_t(i)].depth.pixels, parallel[size_t(i)].depth.pixels) << i;
    EXPECT_EQ(serial[size_t(i)].parts.pixels, parallel[size_t(i)].parts.pixels) << i;
    EXPECT_EQ(serial[size_t(i)].extra_json, parallel[size_t(i)].extra_json) << i;
  }
  for (uint64_t i = 0; i < 400; ++i) hats += synth_->sample_frame_params(9, i).outfit.hat >= 0;
  EXPECT_NEAR(hats / 400.0, 0.5, 0.1) << "hat probability 0.5";
}

TEST(SynthStature, BodiesOutsideTheLimitsAreScaledAboutTheirFeet) {
  std::vector<Vec3f> v(kBodyVertexCount + 10);
  for (size_t i = 0; i < v.size(); ++i) v[i] = {0.001f * float(i % 100), 0.3f + 2.2f * float(i) / float(v.size() - 1), 0.0f};
  v.back().y = 9.0f;  // a helper vertex: not part of the standing height
  const float body_top = v[kBodyVertexCount - 1].y;
  std::vector<Vec3f> tall = v;
  EXPECT_NEAR(limit_stature(tall, 1.1, 2.0), 2.0, 1e-6);
  EXPECT_NEAR(tall[0].y, 0.3f, 1e-6);  // feet stay
  EXPECT_NEAR(tall[kBodyVertexCount - 1].y - tall[0].y, 2.0f, 1e-5);
  EXPECT_NEAR(tall[5].x, v[5].x, 0);  // only vertical
  std::vector<Vec3f> open = v;
  EXPECT_NEAR(limit_stature(open, 0, 0), body_top - 0.3f, 1e-5);
  EXPECT_EQ(open[kBodyVertexCount - 1].y, body_top);
  std::vector<Vec3f> short_body = v;
  for (Vec3f& p : short_body) p.y *= 0.3f;
  EXPECT_NEAR(limit_stature(short_body, 1.1, 2.0), 1.1, 1e-6);
  EXPECT_NEAR(short_body[kBodyVertexCount - 1].y - short_body[0].y, 1.1f, 1e-5);
}

// The synth command refuses bad clothing, body and camera options before loading any asset.
TEST(SynthOptions, RefusesBadClothingBodyAndCameraOptions) {
  const dp::cli::Command* cmd = dp::cli::find_command("synth");
  ASSERT_NE(cmd, nullptr);
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--clothed", "1.5"}, "--clothed"},           {{"--hat", "-0.1"}, "--hat"},
      {{"--bodies", "giant"}, "--bodies"},           {{"--camera-pitch", "25-5"}, "--camera-pitch"},
      {{"--camera-height", "0.5"}, "--camera-height"}, {{"--camera-roll", "90"}, "--camera-roll"},
      {{"--ages", "3-95"}, "--ages"}};
  for (const auto& [extra, named] : cases) {
    std::vector<std::string> args = {"synth", "--assets", "/nonexistent", "--out", "/nonexistent/out", "--frames", "1"};
    args.insert(args.end(), extra.begin(), extra.end());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    try {
      cmd->run(int(argv.size()), argv.data());
      ADD_FAILURE() << "accepted " << extra[0] << " " << extra[1];
    } catch (const dp::tools::ToolError& e) {
      EXPECT_NE(std::string(e.what()).find(named), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace dp::synth
