// BVH and ASF/AMC parsers: own fixtures with known answers, malformed files, the shared CMU clips
// and Debian's assimp-testmodels BVH conversion of the same clip.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "tools/common/error.h"
#include "tools/synth/motion.h"

namespace dp::synth {
namespace {
namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    char pattern[] = "/tmp/synth_motion_test_XXXXXX";
    path_ = mkdtemp(pattern);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string write(const std::string& name, const std::string& text) const {
    const std::string p = path_ + "/" + name;
    std::ofstream(p) << text;
    return p;
  }

 private:
  std::string path_;
};

const char* kBvh =
    "HIERARCHY\n"
    "ROOT Hips\n"
    "{\n"
    "  OFFSET 0 0 0\n"
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
    "  JOINT LeftUpLeg\n"
    "  {\n"
    "    OFFSET 1 0 0\n"
    "    CHANNELS 3 Zrotation Yrotation Xrotation\n"
    "    End Site\n"
    "    {\n"
    "      OFFSET 0 -2 0\n"
    "    }\n"
    "  }\n"
    "}\n"
    "MOTION\n"
    "Frames: 3\n"
    "Frame Time: 0.0333333\n"
    "0 0 0 0 0 0 0 0 0\n"
    "1 2 3 90 0 0 0 0 90\n"
    "0 0 0 0 0 0 0 0 0\n";

const char* kAsf =
    "# fixture\n"
    ":version 1.10\n"
    ":name fixture\n"
    ":units\n"
    "  mass 1.0\n"
    "  length 1.0\n"
    "  angle deg\n"
    ":root\n"
    "   order TX TY TZ RX RY RZ\n"
    "   axis XYZ\n"
    "   position 0 0 0\n"
    "   orientation 0 0 0\n"
    ":bonedata\n"
    "  begin\n"
    "     id 1\n"
    "     name lfemur\n"
    "     direction 0 -1 0\n"
    "     length 2\n"
    "     axis 0 0 90 XYZ\n"
    "    dof rx ry rz\n"
    "    limits (-160.0 20.0)\n"
    "           (-70.0 70.0)\n"
    "           (-60.0 70.0)\n"
    "  end\n"
    "  begin\n"
    "     id 2\n"
    "     name ltibia\n"
    "     direction 0 -1 0\n"
    "     length 2\n"
    "     axis 0 0 0 XYZ\n"
    "    dof rx\n"
    "  end\n"
    ":hierarchy\n"
    "  begin\n"
    "    root lfemur\n"
    "    lfemur ltibia\n"
    "  end\n";

const char* kAmc =
    ":FULLY-SPECIFIED\n"
    ":DEGREES\n"
    "1\n"
    "root 0 0 0 0 0 0\n"
    "lfemur 0 0 0\n"
    "ltibia 0\n"
    "2\n"
    "root 5 6 7 0 0 0\n"
    "lfemur 90 0 0\n"
    "ltibia 90\n";

void expect_vec_near(const Vec3& a, const Vec3& b, double tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

Vec3 posed_direction(const MotionClip& c, size_t frame, const std::string& segment) {
  const int s = c.segment_index(segment);
  EXPECT_GE(s, 0) << segment;
  return c.frames[frame][s] * c.rest_directions[s];
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const dp::tools::ToolError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(SynthMotion, BvhFixtureKnownRotations) {
  TempDir dir;
  const std::string p = dir.write("fixture.bvh", kBvh);
  MotionClip c = load_bvh(p);
  EXPECT_EQ(c.name, "fixture");
  EXPECT_EQ(c.source_frame_count, 3);
  ASSERT_EQ(c.frames.size(), 3u);
  EXPECT_NEAR(c.source_frame_rate, 30.0, 1e-3);
  ASSERT_EQ(c.segments.size(), 2u);
  expect_vec_near(c.rest_directions[c.segment_index("LeftUpLeg")], {0, -1, 0}, 1e-12);
  expect_vec_near(posed_direction(c, 0, "LeftUpLeg"), {0, -1, 0}, 1e-12);
  // Frame 2: hips Rz(90), leg Rx(90) below it: (0,-1,0) -> (0,0,-1) -> (0,0,-1).
  expect_vec_near(posed_direction(c, 1, "LeftUpLeg"), {0, 0, -1}, 1e-12);
  expect_vec_near(c.frames[1][c.segment_index("Hips")] * Vec3{1, 0, 0}, {0, 1, 0}, 1e-12);
  MotionClip strided = load_bvh(p, 2);
  EXPECT_EQ(strided.frames.size(), 2u);  // frames 0 and 2
  EXPECT_EQ(strided.source_frame_count, 3);
}

TEST(SynthMotion, AsfAmcFixtureKnownRotations) {
  TempDir dir;
  const std::string asf = dir.write("fixture.asf", kAsf), amc = dir.write("fixture_01.amc", kAmc);
  MotionClip c = load_asf_amc(asf, amc);
  EXPECT_EQ(c.name, "fixture_01");
  ASSERT_EQ(c.frames.size(), 2u);
  ASSERT_GE(c.segment_index("Hips"), 0);
  ASSERT_GE(c.segment_index("LeftUpLeg"), 0);
  ASSERT_GE(c.segment_index("LeftLeg"), 0);
  expect_vec_near(posed_direction(c, 0, "LeftLeg"), {0, -1, 0}, 1e-12);
  // lfemur rx 90 in a local frame turned 90 deg about z = a turn about world y: thigh unchanged.
  expect_vec_near(posed_direction(c, 1, "LeftUpLeg"), {0, -1, 0}, 1e-12);
  expect_vec_near(c.frames[1][c.segment_index("LeftUpLeg")] * Vec3{1, 0, 0}, {0, 0, -1}, 1e-12);
  // ltibia rx 90 then the femur's turn: (0,-1,0) -> (0,0,-1) -> (-1,0,0).
  expect_vec_near(posed_direction(c, 1, "LeftLeg"), {-1, 0, 0}, 1e-12);
  EXPECT_EQ(rig_name_for_asf_bone("rhumerus"), "RightArm");
  EXPECT_EQ(rig_name_for_asf_bone("nonsense"), "");
}

TEST(SynthMotion, MalformedFilesNameFileAndLine) {
  TempDir dir;
  std::string bad_row = kBvh;
  bad_row.replace(bad_row.find("1 2 3 90"), 8, "1 2 90");  // 8 values on line 20
  std::string e = error_of([&] { load_bvh(dir.write("short_row.bvh", bad_row)); });
  EXPECT_NE(e.find("short_row.bvh:20:"), std::string::npos) << e;

  std::string bad_word = kBvh;
  bad_word.replace(bad_word.find("OFFSET 1 0 0"), 6, "OFFSTE");  // line 8
  e = error_of([&] { load_bvh(dir.write("keyword.bvh", bad_word)); });
  EXPECT_NE(e.find("keyword.bvh:8:"), std::string::npos) << e;

  std::string bad_number = kBvh;
  bad_number.replace(bad_number.find("OFFSET 0 -2 0"), 13, "OFFSET 0 -2 x");  // line 12
  e = error_of([&] { load_bvh(dir.write("number.bvh", bad_number)); });
  EXPECT_NE(e.find("number.bvh:12:"), std::string::npos) << e;

  std::string braces = kBvh;
  braces.erase(braces.find("  }\n}\n"), 4);
  e = error_of([&] { load_bvh(dir.write("braces.bvh", braces)); });
  EXPECT_NE(e.find("braces.bvh:"), std::string::npos) << e;

  std::string frames = kBvh;
  frames.replace(frames.find("Frames: 3"), 9, "Frames: 4");
  e = error_of([&] { load_bvh(dir.write("count.bvh", frames)); });
  EXPECT_NE(e.find("count.bvh"), std::string::npos) << e;

  const std::string asf = dir.write("good.asf", kAsf);
  std::string amc = kAmc;
  amc.replace(amc.find("ltibia 90"), 9, "lknee 90");  // line 10
  e = error_of([&] { load_asf_amc(asf, dir.write("bone.amc", amc)); });
  EXPECT_NE(e.find("bone.amc:10:"), std::string::npos) << e;
  EXPECT_NE(e.find("lknee"), std::string::npos) << e;

  amc = kAmc;
  amc.replace(amc.find("lfemur 90 0 0"), 13, "lfemur 90 0");  // line 9, too few values
  e = error_of([&] { load_asf_amc(asf, dir.write("values.amc", amc)); });
  EXPECT_NE(e.find("values.amc:9:"), std::string::npos) << e;

  std::string asf_text = kAsf;
  asf_text.replace(asf_text.find("direction 0 -1 0"), 16, "direction 0 -1 q");  // line 17
  e = error_of([&] { load_asf_amc(dir.write("bad.asf", asf_text), dir.write("ok.amc", kAmc)); });
  EXPECT_NE(e.find("bad.asf:17:"), std::string::npos) << e;

  asf_text = kAsf;
  asf_text.replace(asf_text.find("lfemur ltibia"), 13, "lfemur ltibiaX");  // line 36
  e = error_of([&] { load_asf_amc(dir.write("hier.asf", asf_text), dir.write("ok.amc", kAmc)); });
  EXPECT_NE(e.find("hier.asf:36:"), std::string::npos) << e;

  e = error_of([&] { load_bvh("/nonexistent/x.bvh"); });
  EXPECT_NE(e.find("cannot open /nonexistent/x.bvh"), std::string::npos) << e;
}

TEST(SynthMotion, SharedCmuClipLoads) {
  const std::string dir = "../shared/assets/mocap/cmu/02";
  ASSERT_TRUE(fs::exists(dir + "/02.asf")) << "shared CMU mocap missing under " << dir;
  MotionClip c = load_asf_amc(dir + "/02.asf", dir + "/02_01.amc", 4);
  EXPECT_EQ(c.segments.size(), 31u);  // all CMU bones map onto the rig
  EXPECT_GT(c.source_frame_count, 100);
  EXPECT_EQ(c.frames.size(), size_t((c.source_frame_count + 3) / 4));
  // Walking: the thigh points mostly down in every frame.
  for (size_t k = 0; k < c.frames.size(); ++k) EXPECT_LT(posed_direction(c, k, "LeftUpLeg").y, -0.5) << k;
}

TEST(SynthMotion, AssimpBvhMatchesCmuAsfAmcOfTheSameClip) {
  const std::string bvh = "/usr/share/assimp/models/BVH/01_01.bvh";
  ASSERT_TRUE(fs::exists(bvh)) << bvh << " missing: install assimp-testmodels (make deps)";
  const std::string dir = "../shared/assets/mocap/cmu/01";
  ASSERT_TRUE(fs::exists(dir + "/01_01.amc")) << "shared CMU mocap missing under " << dir;
  MotionClip b = load_bvh(bvh);
  MotionClip a = load_asf_amc(dir + "/01.asf", dir + "/01_01.amc");
  // The BVH conversion prepends one T-pose frame: BVH frame k+1 is AMC frame k.
  ASSERT_EQ(b.source_frame_count, a.source_frame_count + 1);
  EXPECT_GT(posed_direction(b, 0, "LeftArm").x, std::cos(10 * kDegToRad));  // arms out sideways
  EXPECT_LT(posed_direction(b, 0, "RightArm").x, -std::cos(10 * kDegToRad));
  // Same capture, two formats: each segment points the same way in every sampled frame.
  for (const char* s : {"LeftUpLeg", "RightLeg", "LeftArm", "RightForeArm", "Spine", "Neck1", "LeftShoulder"}) {
    for (size_t k = 0; k < a.frames.size(); k += 50) {
      const Vec3 da = posed_direction(a, k, s), db = posed_direction(b, k + 1, s);
      EXPECT_GT(da.dot(db), std::cos(5 * kDegToRad)) << s << " frame " << k;
    }
  }
}

}  // namespace
}  // namespace dp::synth
