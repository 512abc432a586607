// BVH and ASF/AMC parsers: own fixtures with known answers, malformed files, the shared CMU clips
// and Debian's assimp-testmodels BVH conversion of the same clip.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <functional>
#include <string>

#include "tools/common/error.h"
#include <zlib.h>

#include <map>
#include <set>

#include "tools/synth/clip_index.h"
#include "tools/synth/motion.h"
#include "tests/shared_data.h"

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
  const std::string& path() const { return path_; }
  std::string write(const std::string& name, const std::string& text) const {
    const std::string p = path_ + "/" + name;
    std::ofstream(p) << text;
    return p;
  }

 private:
  std::string path_;
};

// A full CMU skeleton in MotionBuilder names, T-pose rest (cm, y up, facing +z, left at +x);
// Hips and LeftUpLeg carry the rotations the known-answer test checks.
std::string cmu_mb_bvh(const std::string& frames_text, int frames) {
  std::string s = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n"
                  "  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n";
  // name, offset from parent, parent depth (0 = child of Hips)
  struct J { const char* name; const char* offset; int depth; bool leaf; };
  const J joints[] = {
      {"LeftUpLeg", "1 0 0", 1, false},  {"LeftLeg", "0 -2 0", 2, false},  {"LeftFoot", "0 -2 0", 3, true},
      {"RightUpLeg", "-1 0 0", 1, false}, {"RightLeg", "0 -2 0", 2, false}, {"RightFoot", "0 -2 0", 3, true},
      {"Spine", "0 1 0", 1, false},       {"Spine1", "0 1 0", 2, false},   {"Neck", "0 1 0", 3, false},
      {"Head", "0 1 0", 4, true},         {"LeftShoulder", "0 1 0", 3, false}, {"LeftArm", "1 0 0", 4, false},
      {"LeftForeArm", "2 0 0", 5, false}, {"LeftHand", "2 0 0", 6, true},  {"RightShoulder", "0 1 0", 3, false},
      {"RightArm", "-1 0 0", 4, false},   {"RightForeArm", "-2 0 0", 5, false}, {"RightHand", "-2 0 0", 6, true}};
  std::vector<int> open;  // depths of open joints
  int channels = 6;
  for (const J& j : joints) {
    while (!open.empty() && open.back() >= j.depth) {
      s += std::string(size_t(2 * open.back()), ' ') + "}\n";
      open.pop_back();
    }
    const std::string ind(size_t(2 * j.depth), ' ');
    s += ind + "JOINT " + j.name + "\n" + ind + "{\n" + ind + "  OFFSET " + j.offset + "\n" + ind +
         "  CHANNELS 3 Zrotation Yrotation Xrotation\n";
    channels += 3;
    if (j.leaf) s += ind + "  End Site\n" + ind + "  {\n" + ind + "    OFFSET " + j.offset + "\n" + ind + "  }\n";
    open.push_back(j.depth);
  }
  while (!open.empty()) {
    s += std::string(size_t(2 * open.back()), ' ') + "}\n";
    open.pop_back();
  }
  s += "}\nMOTION\nFrames: " + std::to_string(frames) + "\nFrame Time: 0.0333333\n" + frames_text;
  (void)channels;
  return s;
}
constexpr int kMbChannels = 6 + 3 * 18;

// A row of kMbChannels values: hips rotation (z y x), LeftUpLeg (z y x), rest zero.
std::string mb_row(const char* hips_zyx, const char* leg_zyx) {
  std::string r = std::string("0 0 0 ") + hips_zyx + " " + leg_zyx;
  for (int i = 9; i < kMbChannels; ++i) r += " 0";
  return r + "\n";
}

const std::string kBvh = cmu_mb_bvh(mb_row("0 0 0", "0 0 0") + mb_row("90 0 0", "0 0 90") + mb_row("0 0 0", "0 0 0"), 3);

// An ASF with every bone the body needs (the loader refuses less); lfemur and ltibia carry the
// known-answer rotations, the rest have no motion.
std::string make_asf() {
  std::string s =
      "# fixture\n:version 1.10\n:name fixture\n:units\n  mass 1.0\n  length 1.0\n  angle deg\n"
      ":root\n   order TX TY TZ RX RY RZ\n   axis XYZ\n   position 0 0 0\n   orientation 0 0 0\n:bonedata\n"
      "  begin\n     id 1\n     name lfemur\n     direction 0 -1 0\n     length 2\n     axis 0 0 90 XYZ\n"
      "    dof rx ry rz\n    limits (-160.0 20.0)\n           (-70.0 70.0)\n           (-60.0 70.0)\n  end\n"
      "  begin\n     id 2\n     name ltibia\n     direction 0 -1 0\n     length 2\n     axis 0 0 0 XYZ\n"
      "    dof rx\n  end\n";
  struct B { const char* name; const char* dir; const char* dof; };
  const B more[] = {{"lhipjoint", "1 -1 0", ""},  {"lfoot", "0 0 1", "rx rz"}, {"rhipjoint", "-1 -1 0", ""},
                    {"rfemur", "0 -1 0", "rx ry rz"}, {"rtibia", "0 -1 0", "rx"}, {"rfoot", "0 0 1", "rx rz"},
                    {"lowerback", "0 1 0", "rx ry rz"}, {"upperback", "0 1 0", "rx ry rz"},
                    {"thorax", "0 1 0", "rx ry rz"},  {"lowerneck", "0 1 0", "rx ry rz"},
                    {"upperneck", "0 1 0", "rx ry rz"}, {"head", "0 1 0", "rx ry rz"},
                    {"lclavicle", "1 0 0", "ry rz"},  {"lhumerus", "1 0 0", "rx ry rz"}, {"lradius", "1 0 0", "rx"},
                    {"lwrist", "1 0 0", "ry"},        {"rclavicle", "-1 0 0", "ry rz"},
                    {"rhumerus", "-1 0 0", "rx ry rz"}, {"rradius", "-1 0 0", "rx"}, {"rwrist", "-1 0 0", "ry"}};
  int id = 3;
  for (const B& b : more) {
    s += "  begin\n     id " + std::to_string(id++) + "\n     name " + b.name + "\n     direction " + b.dir +
         "\n     length 1\n     axis 0 0 0 XYZ\n";
    if (b.dof[0]) s += std::string("    dof ") + b.dof + "\n";
    s += "  end\n";
  }
  s += ":hierarchy\n  begin\n    root lfemur lhipjoint rhipjoint lowerback\n    lhipjoint\n"
       "    lfemur ltibia\n    ltibia lfoot\n    rhipjoint rfemur\n    rfemur rtibia\n    rtibia rfoot\n"
       "    lowerback upperback\n    upperback thorax\n    thorax lowerneck lclavicle rclavicle\n"
       "    lowerneck upperneck\n    upperneck head\n    lclavicle lhumerus\n    lhumerus lradius\n"
       "    lradius lwrist\n    rclavicle rhumerus\n    rhumerus rradius\n    rradius rwrist\n  end\n";
  return s;
}
const std::string kAsf = make_asf();

// One AMC frame: the known-answer bones first, then every other bone with dofs at zero.
std::string amc_frame(int number, const char* root, const char* lfemur, const char* ltibia) {
  return std::to_string(number) + "\nroot " + root + "\nlfemur " + lfemur + "\nltibia " + ltibia +
         "\nlfoot 0 0\nrfemur 0 0 0\nrtibia 0\nrfoot 0 0\nlowerback 0 0 0\nupperback 0 0 0\n"
         "thorax 0 0 0\nlowerneck 0 0 0\nupperneck 0 0 0\nhead 0 0 0\nlclavicle 0 0\nlhumerus 0 0 0\n"
         "lradius 0\nlwrist 0\nrclavicle 0 0\nrhumerus 0 0 0\nrradius 0\nrwrist 0\n";
}
const std::string kAmc = ":FULLY-SPECIFIED\n:DEGREES\n" + amc_frame(1, "0 0 0 0 0 0", "0 0 0", "0") +
                         amc_frame(2, "5 6 7 0 0 0", "90 0 0", "90");

// 1-based line number of the first line containing `needle`.
int line_of(const std::string& text, const std::string& needle) {
  const size_t at = text.find(needle);
  EXPECT_NE(at, std::string::npos) << needle;
  return 1 + int(std::count(text.begin(), text.begin() + long(at), '\n'));
}

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
  EXPECT_EQ(c.skeleton, "motionbuilder");
  ASSERT_EQ(c.frames.size(), 3u);
  EXPECT_NEAR(c.source_frame_rate, 30.0, 1e-3);
  EXPECT_EQ(c.segments.size(), 19u);  // the 19 joints of the fixture (not the End Sites), each a rig bone
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
  const std::string second = mb_row("90 0 0", "0 0 90");
  bad_row.replace(bad_row.find(second), second.size(), second.substr(2));  // one value short
  std::string e = error_of([&] { load_bvh(dir.write("short_row.bvh", bad_row)); });
  EXPECT_NE(e.find("short_row.bvh:" + std::to_string(line_of(kBvh, second)) + ":"), std::string::npos) << e;

  std::string bad_word = kBvh;
  bad_word.replace(bad_word.find("OFFSET 1 0 0"), 6, "OFFSTE");
  e = error_of([&] { load_bvh(dir.write("keyword.bvh", bad_word)); });
  EXPECT_NE(e.find("keyword.bvh:" + std::to_string(line_of(kBvh, "OFFSET 1 0 0")) + ":"), std::string::npos) << e;

  std::string bad_number = kBvh;
  bad_number.replace(bad_number.find("OFFSET 0 -2 0"), 13, "OFFSET 0 -2 x");
  e = error_of([&] { load_bvh(dir.write("number.bvh", bad_number)); });
  EXPECT_NE(e.find("number.bvh:" + std::to_string(line_of(kBvh, "OFFSET 0 -2 0")) + ":"), std::string::npos) << e;

  std::string braces = kBvh;
  braces.erase(braces.find("}\nMOTION"), 2);
  e = error_of([&] { load_bvh(dir.write("braces.bvh", braces)); });
  EXPECT_NE(e.find("braces.bvh:"), std::string::npos) << e;

  // A channel count out of 0..6 or not whole is refused by name (a huge one used to be converted
  // to int unchecked: undefined behaviour, found by `make fuzz-smoke`).
  for (const std::string count : {"1e110", "7", "-1", "2.5"}) {
    std::string channels = kBvh;
    const size_t at = channels.find("CHANNELS ") + 9;
    channels.replace(at, channels.find(' ', at) - at, count);
    e = error_of([&] { load_bvh(dir.write("channels.bvh", channels)); });
    EXPECT_NE(e.find("bad channel count"), std::string::npos) << count << ": " << e;
  }

  std::string frames = kBvh;
  frames.replace(frames.find("Frames: 3"), 9, "Frames: 4");
  e = error_of([&] { load_bvh(dir.write("count.bvh", frames)); });
  EXPECT_NE(e.find("count.bvh"), std::string::npos) << e;

  const std::string asf = dir.write("good.asf", kAsf);
  std::string amc = kAmc;
  amc.replace(amc.find("ltibia 90"), 9, "lknee 90");
  e = error_of([&] { load_asf_amc(asf, dir.write("bone.amc", amc)); });
  EXPECT_NE(e.find("bone.amc:" + std::to_string(line_of(kAmc, "ltibia 90")) + ":"), std::string::npos) << e;
  EXPECT_NE(e.find("lknee"), std::string::npos) << e;

  amc = kAmc;
  amc.replace(amc.find("lfemur 90 0 0"), 13, "lfemur 90 0");  // too few values
  e = error_of([&] { load_asf_amc(asf, dir.write("values.amc", amc)); });
  EXPECT_NE(e.find("values.amc:" + std::to_string(line_of(kAmc, "lfemur 90 0 0")) + ":"), std::string::npos) << e;

  std::string asf_text = kAsf;
  asf_text.replace(asf_text.find("direction 0 -1 0"), 16, "direction 0 -1 q");
  e = error_of([&] { load_asf_amc(dir.write("bad.asf", asf_text), dir.write("ok.amc", kAmc)); });
  EXPECT_NE(e.find("bad.asf:" + std::to_string(line_of(kAsf, "direction 0 -1 0")) + ":"), std::string::npos) << e;

  asf_text = kAsf;
  asf_text.replace(asf_text.find("lfemur ltibia"), 13, "lfemur ltibiaX");
  e = error_of([&] { load_asf_amc(dir.write("hier.asf", asf_text), dir.write("ok.amc", kAmc)); });
  EXPECT_NE(e.find("hier.asf:" + std::to_string(line_of(kAsf, "lfemur ltibia")) + ":"), std::string::npos) << e;

  e = error_of([&] { load_bvh("/nonexistent/x.bvh"); });
  EXPECT_NE(e.find("cannot open /nonexistent/x.bvh"), std::string::npos) << e;
}

TEST(SynthMotionSharedData, SharedCmuClipLoads) {
  const std::string dir = dp::test::shared_path("assets/mocap/cmu/02");
  ASSERT_TRUE(fs::exists(dir + "/02.asf")) << "shared CMU mocap missing under " << dir;
  MotionClip c = load_asf_amc(dir + "/02.asf", dir + "/02_01.amc", 4);
  EXPECT_EQ(c.segments.size(), 31u);  // all CMU bones map onto the rig
  EXPECT_GT(c.source_frame_count, 100);
  EXPECT_EQ(c.frames.size(), size_t((c.source_frame_count + 3) / 4));
  // Walking: the thigh points mostly down in every frame.
  for (size_t k = 0; k < c.frames.size(); ++k) EXPECT_LT(posed_direction(c, k, "LeftUpLeg").y, -0.5) << k;
}

TEST(SynthMotionSharedData, AssimpBvhMatchesCmuAsfAmcOfTheSameClip) {
  const std::string bvh = "/usr/share/assimp/models/BVH/01_01.bvh";
  ASSERT_TRUE(fs::exists(bvh)) << bvh << " missing: install assimp-testmodels (make deps)";
  const std::string dir = dp::test::shared_path("assets/mocap/cmu/01");
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

// ---- Skeleton namings: small synthetic BVH skeletons of each naming, same body, same motion ----

struct JointSpec {
  std::string name, parent;  // parent "" = ROOT
  Vec3 at;                   // rest position, cm
  bool has_end = false;
  Vec3 end;                  // End Site position
};

// Semantic points of one T-posed body (cm, y up, facing +z, left at +x); the right side mirrors.
Vec3 pt(const std::string& what, int side = 1) {
  const double s = side;
  if (what == "hips") return {0, 100, 0};
  if (what == "hip") return {9 * s, 95, 0};
  if (what == "knee") return {9 * s, 52, 0};
  if (what == "ankle") return {9 * s, 10, 0};
  if (what == "toe") return {9 * s, 2, 12};
  if (what == "toe_end") return {9 * s, 0, 18};
  if (what == "clav") return {3 * s, 147, 0};
  if (what == "shoulder") return {17 * s, 147, 0};
  if (what == "elbow") return {45 * s, 147, 0};
  if (what == "wrist") return {70 * s, 147, 0};
  if (what == "mid1") return {76 * s, 147, 0};
  if (what == "hand_end") return {80 * s, 147, 0};
  if (what == "thumb") return {72 * s, 146, 3};
  if (what == "thumb_end") return {74 * s, 145, 6};
  ADD_FAILURE() << what;
  return {};
}

// Joints of one naming; left-side names contain "{S}" style placeholders resolved per side.
struct SidedSpec {
  std::string left, right, parent_left, parent_right, point;
  bool has_end = false;
  std::string end_point;
};

std::vector<JointSpec> skeleton(const std::vector<JointSpec>& centre, const std::vector<SidedSpec>& sided) {
  std::vector<JointSpec> out = centre;
  for (int side : {1, -1})
    for (const SidedSpec& j : sided) {
      JointSpec s{side > 0 ? j.left : j.right, side > 0 ? j.parent_left : j.parent_right, pt(j.point, side),
                  j.has_end, j.has_end ? pt(j.end_point, side) : Vec3{}};
      out.push_back(s);
    }
  return out;
}

std::vector<JointSpec> mb_skeleton() {
  return skeleton({{"Hips", "", {0, 100, 0}},
                   {"LowerBack", "Hips", {0, 100, 0}},
                   {"Spine", "LowerBack", {0, 112, 0}},
                   {"Spine1", "Spine", {0, 125, 0}},
                   {"Neck", "Spine1", {0, 150, 0}},
                   {"Head", "Neck", {0, 160, 0}, true, {0, 178, 0}}},
                  {{"LHipJoint", "RHipJoint", "Hips", "Hips", "hips"},
                   {"LeftUpLeg", "RightUpLeg", "LHipJoint", "RHipJoint", "hip"},
                   {"LeftLeg", "RightLeg", "LeftUpLeg", "RightUpLeg", "knee"},
                   {"LeftFoot", "RightFoot", "LeftLeg", "RightLeg", "ankle", true, "toe"},
                   {"LeftShoulder", "RightShoulder", "Spine1", "Spine1", "clav"},
                   {"LeftArm", "RightArm", "LeftShoulder", "RightShoulder", "shoulder"},
                   {"LeftForeArm", "RightForeArm", "LeftArm", "RightArm", "elbow"},
                   {"LeftHand", "RightHand", "LeftForeArm", "RightForeArm", "wrist", true, "hand_end"}});
}

std::vector<JointSpec> daz_skeleton() {
  return skeleton({{"hip", "", {0, 100, 0}},
                   {"abdomen", "hip", {0, 110, 0}},
                   {"chest", "abdomen", {0, 125, 0}},
                   {"neck", "chest", {0, 150, 0}},
                   {"head", "neck", {0, 160, 0}},
                   {"leftEye", "head", {3, 165, 8}, true, {3, 165, 9}},
                   {"rightEye", "head", {-3, 165, 8}, true, {-3, 165, 9}}},
                  {{"lCollar", "rCollar", "chest", "chest", "clav"},
                   {"lShldr", "rShldr", "lCollar", "rCollar", "shoulder"},
                   {"lForeArm", "rForeArm", "lShldr", "rShldr", "elbow"},
                   {"lHand", "rHand", "lForeArm", "rForeArm", "wrist"},
                   {"lThumb1", "rThumb1", "lHand", "rHand", "thumb", true, "thumb_end"},
                   {"lMid1", "rMid1", "lHand", "rHand", "mid1", true, "hand_end"},
                   {"lButtock", "rButtock", "hip", "hip", "hip"},
                   {"lThigh", "rThigh", "lButtock", "rButtock", "hip"},
                   {"lShin", "rShin", "lThigh", "rThigh", "knee"},
                   {"lFoot", "rFoot", "lShin", "rShin", "ankle", true, "toe_end"}});
}

std::vector<JointSpec> max_skeleton() {
  return skeleton({{"Hips", "", {0, 100, 0}},
                   {"lowerback", "Hips", {0, 110, 0}},
                   {"Chest", "lowerback", {0, 125, 0}},
                   {"Chest2", "Chest", {0, 135, 0}},
                   {"Neck", "Chest2", {0, 150, 0}},
                   {"Head", "Neck", {0, 160, 0}, true, {0, 178, 0}}},
                  {{"LeftHip", "RightHip", "Hips", "Hips", "hip"},
                   {"LeftKnee", "RightKnee", "LeftHip", "RightHip", "knee"},
                   {"LeftAnkle", "RightAnkle", "LeftKnee", "RightKnee", "ankle"},
                   {"LeftToe", "RightToe", "LeftAnkle", "RightAnkle", "toe", true, "toe_end"},
                   {"LeftCollar", "RightCollar", "Chest2", "Chest2", "clav"},
                   {"LeftShoulder", "RightShoulder", "LeftCollar", "RightCollar", "shoulder"},
                   {"LeftElbow", "RightElbow", "LeftShoulder", "RightShoulder", "elbow"},
                   {"LeftWrist", "RightWrist", "LeftElbow", "RightElbow", "wrist", true, "hand_end"}});
}

std::vector<JointSpec> makehuman_skeleton() {
  std::vector<JointSpec> j = skeleton(
      {{"root", "", {0, 100, 0}},
       {"spine05", "root", {0, 104, 0}},
       {"spine04", "spine05", {0, 110, 0}},
       {"spine03", "spine04", {0, 118, 0}},
       {"spine02", "spine03", {0, 125, 0}},
       {"spine01", "spine02", {0, 135, 0}},
       {"neck01", "spine01", {0, 150, 0}},
       {"neck02", "neck01", {0, 153, 0}},
       {"neck03", "neck02", {0, 156, 0}},
       {"head", "neck03", {0, 160, 0}},
       {"jaw", "head", {0, 158, 5}, true, {0, 155, 9}}},
      {{"clavicle.L", "clavicle.R", "spine01", "spine01", "clav"},
       {"upperarm01.L", "upperarm01.R", "clavicle.L", "clavicle.R", "shoulder"},
       {"lowerarm01.L", "lowerarm01.R", "upperarm01.L", "upperarm01.R", "elbow"},
       {"wrist.L", "wrist.R", "lowerarm01.L", "lowerarm01.R", "wrist"},
       {"finger3-1.L", "finger3-1.R", "wrist.L", "wrist.R", "mid1", true, "hand_end"},
       {"pelvis.L", "pelvis.R", "root", "root", "hips"},
       {"upperleg01.L", "upperleg01.R", "pelvis.L", "pelvis.R", "hip"},
       {"lowerleg01.L", "lowerleg01.R", "upperleg01.L", "upperleg01.R", "knee"},
       {"foot.L", "foot.R", "lowerleg01.L", "lowerleg01.R", "ankle"},
       {"toe1-1.L", "toe1-1.R", "foot.L", "foot.R", "toe", true, "toe_end"}});
  return j;
}

// BVH text: ROOT with 6 channels, every joint 3 (Z X Y); rows give per joint (z, x, y) degrees.
std::string bvh_of(const std::vector<JointSpec>& joints, const std::vector<std::map<std::string, Vec3>>& frames,
                   const std::string& eol = "\n") {
  std::string s = "HIERARCHY" + eol;
  std::vector<std::string> order;
  std::function<void(const JointSpec&, int)> emit = [&](const JointSpec& j, int depth) {
    const std::string ind(size_t(2 * depth), ' ');
    Vec3 parent_at;
    for (const JointSpec& p : joints)
      if (p.name == j.parent) parent_at = p.at;
    const Vec3 o = j.parent.empty() ? Vec3{} : j.at - parent_at;
    char buf[160];
    std::snprintf(buf, sizeof buf, "OFFSET %g %g %g", o.x, o.y, o.z);
    s += ind + (j.parent.empty() ? "ROOT " : "JOINT ") + j.name + eol + ind + "{" + eol + ind + "  " + buf + eol;
    s += ind + (j.parent.empty() ? "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"
                                 : "  CHANNELS 3 Zrotation Xrotation Yrotation") + eol;
    order.push_back(j.name);
    for (const JointSpec& c : joints)
      if (c.parent == j.name) emit(c, depth + 1);
    if (j.has_end) {
      const Vec3 e = j.end - j.at;
      std::snprintf(buf, sizeof buf, "OFFSET %g %g %g", e.x, e.y, e.z);
      s += ind + "  End Site" + eol + ind + "  {" + eol + ind + "    " + buf + eol + ind + "  }" + eol;
    }
    s += ind + "}" + eol;
  };
  emit(joints[0], 0);
  s += "MOTION" + eol + "Frames: " + std::to_string(frames.size()) + eol + "Frame Time: 0.0083333" + eol;
  for (const auto& f : frames) {
    std::string row = "0 100 0";
    for (const std::string& name : order) {
      auto it = f.find(name);
      const Vec3 a = it == f.end() ? Vec3{} : it->second;
      char buf[96];
      std::snprintf(buf, sizeof buf, " %g %g %g", a.x, a.y, a.z);
      row += buf;
    }
    s += row + eol;
  }
  return s;
}

struct NamingCase {
  const char* naming;
  std::vector<JointSpec> (*make)();
  const char* upper_arm;  // source joint of the rig's LeftArm
  const char* knee;       // source joint of the rig's LeftLeg
};
const NamingCase kNamings[] = {{"motionbuilder", mb_skeleton, "LeftArm", "LeftLeg"},
                               {"daz", daz_skeleton, "lShldr", "lShin"},
                               {"3dsmax", max_skeleton, "LeftShoulder", "LeftKnee"},
                               {"makehuman", makehuman_skeleton, "upperarm01.L", "lowerleg01.L"}};

TEST(SynthSkeletonNaming, EachNamingRecognisedAndLimbsOnTheRightBones) {
  TempDir dir;
  for (const NamingCase& n : kNamings) {
    SCOPED_TRACE(n.naming);
    // Frame 0 rest; frame 1: upper arm down (z -90), knee bent (x 90).
    const std::vector<std::map<std::string, Vec3>> frames = {{}, {{n.upper_arm, {-90, 0, 0}}, {n.knee, {0, 90, 0}}}};
    const MotionClip c = load_bvh(dir.write(std::string(n.naming) + ".bvh", bvh_of(n.make(), frames)));
    EXPECT_EQ(c.skeleton, n.naming);
    for (const char* rig : {"Hips", "Spine", "Spine1", "Neck", "Head", "LeftShoulder", "LeftArm", "LeftForeArm",
                            "LeftHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightArm", "RightLeg"})
      ASSERT_GE(c.segment_index(rig), 0) << rig;
    // Rest directions: the rest-pose geometry of the source.
    expect_vec_near(c.rest_directions[c.segment_index("LeftArm")], {1, 0, 0}, 1e-9);
    expect_vec_near(c.rest_directions[c.segment_index("LeftHand")], {1, 0, 0}, 1e-9);  // not the thumb
    expect_vec_near(c.rest_directions[c.segment_index("LeftUpLeg")], {0, -1, 0}, 1e-9);
    expect_vec_near(c.rest_directions[c.segment_index("RightForeArm")], {-1, 0, 0}, 1e-9);
    for (const char* rig : {"LeftShoulder", "LeftArm", "LeftLeg", "RightArm"})
      expect_vec_near(posed_direction(c, 0, rig), c.rest_directions[c.segment_index(rig)], 1e-9);
    // Frame 1: the upper arm and forearm hang down, the clavicle has not moved, the shin points back.
    expect_vec_near(posed_direction(c, 1, "LeftArm"), {0, -1, 0}, 1e-9);
    expect_vec_near(posed_direction(c, 1, "LeftForeArm"), {0, -1, 0}, 1e-9);
    expect_vec_near(posed_direction(c, 1, "LeftShoulder"), c.rest_directions[c.segment_index("LeftShoulder")], 1e-9);
    expect_vec_near(posed_direction(c, 1, "LeftUpLeg"), {0, -1, 0}, 1e-9);
    expect_vec_near(posed_direction(c, 1, "LeftLeg"), {0, 0, -1}, 1e-9);
    expect_vec_near(posed_direction(c, 1, "RightArm"), {-1, 0, 0}, 1e-9);
    expect_vec_near(posed_direction(c, 1, "RightLeg"), {0, -1, 0}, 1e-9);
  }
}

TEST(SynthSkeletonNaming, UnknownOrIncompleteSkeletonsRefusedNamingTheMissingJoints) {
  TempDir dir;
  const std::vector<std::map<std::string, Vec3>> one = {{}};
  // Rigify-style names: nothing we know.
  std::vector<JointSpec> rigify = mb_skeleton();
  for (JointSpec& j : rigify) {
    j.name = "DEF-" + j.name;
    if (!j.parent.empty()) j.parent = "DEF-" + j.parent;
  }
  std::string e = error_of([&] { load_bvh(dir.write("rigify.bvh", bvh_of(rigify, one))); });
  EXPECT_NE(e.find("rigify.bvh: BVH skeleton not recognised"), std::string::npos) << e;
  EXPECT_NE(e.find("lacks joints"), std::string::npos) << e;
  EXPECT_NE(e.find("LeftForeArm"), std::string::npos) << e;

  // 3ds Max names without elbows: recognised as 3ds Max, refused naming the elbows.
  std::vector<JointSpec> no_elbows = max_skeleton();
  for (JointSpec& j : no_elbows) {
    if (j.name == "LeftElbow") j.name = "LeftLowArm";
    if (j.name == "RightElbow") j.name = "RightLowArm";
    if (j.parent == "LeftElbow") j.parent = "LeftLowArm";
    if (j.parent == "RightElbow") j.parent = "RightLowArm";
  }
  e = error_of([&] { load_bvh(dir.write("noelbow.bvh", bvh_of(no_elbows, one))); });
  EXPECT_NE(e.find("closest naming '3dsmax' lacks joints LeftElbow, RightElbow"), std::string::npos) << e;

  // DAZ without the middle finger the hand direction needs.
  std::vector<JointSpec> daz;
  for (const JointSpec& j : daz_skeleton())
    if (j.name != "lMid1" && j.name != "rMid1") daz.push_back(j);
  e = error_of([&] { load_bvh(dir.write("nomid.bvh", bvh_of(daz, one))); });
  EXPECT_NE(e.find("'daz' lacks joints lMid1, rMid1"), std::string::npos) << e;

  // Left and right swapped in the rest pose: refused, not rendered mirrored.
  std::vector<JointSpec> mirrored = mb_skeleton();
  for (JointSpec& j : mirrored) {
    j.at.x = -j.at.x;
    j.end.x = -j.end.x;
  }
  e = error_of([&] { load_bvh(dir.write("mirror.bvh", bvh_of(mirrored, one))); });
  EXPECT_NE(e.find("left joints at -x"), std::string::npos) << e;
}

// ---- Files: gzip, CRLF, truncation ----

void write_gz(const std::string& path, const std::string& text) {
  gzFile f = gzopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr) << path;
  ASSERT_EQ(gzwrite(f, text.data(), unsigned(text.size())), int(text.size()));
  ASSERT_EQ(gzclose(f), Z_OK);
}

std::string crlf(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '\n') out += '\r';
    out += c;
  }
  return out;
}

void expect_same_motion(const MotionClip& a, const MotionClip& b) {
  ASSERT_EQ(a.segments, b.segments);
  ASSERT_EQ(a.frames.size(), b.frames.size());
  EXPECT_EQ(a.source_frame_count, b.source_frame_count);
  for (size_t s = 0; s < a.segments.size(); ++s)
    EXPECT_EQ(a.rest_directions[s].x, b.rest_directions[s].x) << a.segments[s];
  for (size_t k = 0; k < a.frames.size(); ++k)
    for (size_t s = 0; s < a.segments.size(); ++s)
      for (int i = 0; i < 9; ++i) ASSERT_EQ(a.frames[k][s].m[i], b.frames[k][s].m[i]) << k << " " << a.segments[s];
}

TEST(SynthMocapFiles, GzipAndCrlfParseToTheSameMotionAsPlainLf) {
  TempDir dir;
  const std::string daz_text = bvh_of(daz_skeleton(), {{}, {{"lShldr", {-40, 10, 5}}, {"rShin", {0, 70, 0}}}});
  const MotionClip plain = load_bvh(dir.write("p.bvh", daz_text));
  expect_same_motion(plain, load_bvh(dir.write("c.bvh", crlf(daz_text))));
  write_gz(dir.path() + "/g.bvh.gz", daz_text);
  expect_same_motion(plain, load_bvh(dir.path() + "/g.bvh.gz"));
  write_gz(dir.path() + "/gc.bvh.gz", crlf(daz_text));
  expect_same_motion(plain, load_bvh(dir.path() + "/gc.bvh.gz"));

  const std::string asf = dir.write("s.asf", kAsf);
  const MotionClip amc = load_asf_amc(asf, dir.write("a.amc", kAmc));
  expect_same_motion(amc, load_asf_amc(dir.write("sc.asf", crlf(kAsf)), dir.write("ac.amc", crlf(kAmc))));
  write_gz(dir.path() + "/s.asf.gz", crlf(kAsf));
  write_gz(dir.path() + "/a.amc.gz", kAmc);
  expect_same_motion(amc, load_asf_amc(dir.path() + "/s.asf.gz", dir.path() + "/a.amc.gz"));

  // A gzip stream cut short is refused, naming the file.
  std::string gz;
  {
    std::ifstream in(dir.path() + "/g.bvh.gz", std::ios::binary);
    gz.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::string cut = dir.path() + "/cut.bvh.gz";
  std::ofstream(cut, std::ios::binary) << gz.substr(0, gz.size() / 2);
  const std::string e = error_of([&] { load_bvh(cut); });
  EXPECT_NE(e.find("cut.bvh.gz: corrupt or truncated gzip data"), std::string::npos) << e;
}

TEST(SynthMocapFiles, AmcTruncatedAnywhereInItsLastFrameIsRefusedNamingFileAndFrame) {
  TempDir dir;
  const std::string asf = dir.write("s.asf", kAsf);
  const size_t last = kAmc.find("\n2\n") + 1;  // first byte of the last frame
  ASSERT_EQ(load_asf_amc(asf, dir.write("whole.amc", kAmc)).source_frame_count, 2);
  ASSERT_EQ(load_asf_amc(asf, dir.write("one.amc", kAmc.substr(0, last))).source_frame_count, 1);
  int refused = 0;
  for (size_t cut = last + 1; cut < kAmc.size(); ++cut) {
    const std::string e = error_of([&] { load_asf_amc(asf, dir.write("cut.amc", kAmc.substr(0, cut))); });
    EXPECT_NE(e.find("cut.amc"), std::string::npos) << "cut at " << cut << ": " << e;
    EXPECT_NE(e.find("frame 2"), std::string::npos) << "cut at " << cut << ": " << e;
    refused += e != "(no error)";
  }
  EXPECT_EQ(refused, int(kAmc.size() - last - 1));
  // CRLF: a cut between CR and LF is a cut too.
  const std::string c = crlf(kAmc);
  EXPECT_NE(error_of([&] { load_asf_amc(asf, dir.write("cr.amc", c.substr(0, c.size() - 1))); }).find("frame 2"),
            std::string::npos);
  // A frame that lists a bone twice is refused too.
  std::string twice = kAmc;
  twice.replace(twice.rfind("rwrist 0"), 8, "lwrist 0");
  EXPECT_NE(error_of([&] { load_asf_amc(asf, dir.write("twice.amc", twice)); }).find("listed twice"),
            std::string::npos);
}

TEST(SynthMocapFiles, BvhTruncatedAnywhereInItsLastRowIsRefused) {
  TempDir dir;
  const size_t last = kBvh.rfind('\n', kBvh.size() - 2) + 1;
  for (size_t cut = last + 1; cut < kBvh.size(); ++cut) {
    const std::string e = error_of([&] { load_bvh(dir.write("cut.bvh", kBvh.substr(0, cut))); });
    EXPECT_NE(e.find("cut.bvh"), std::string::npos) << "cut at " << cut << ": " << e;
  }
}

// ---- The shared corpus ----

const std::string kMocap = dp::test::shared_path("assets/mocap");

TEST(SynthMocapFilesSharedData, SharedDazMotionBuilderAndGzAmcClipsLoad) {
  ASSERT_TRUE(fs::exists(kMocap + "/clips.tsv")) << "shared mocap index missing: " << kMocap << "/clips.tsv";
  // DAZ, gzip and CRLF: frame 0 is the T-pose, arms sideways, legs down.
  const MotionClip daz = load_bvh(kMocap + "/cmu-bvh-daz/60/60_01.bvh.gz", 100);
  EXPECT_EQ(daz.skeleton, "daz");
  const MotionClip mb = load_bvh(kMocap + "/cmu-bvh/06/06_01.bvh.gz", 100);
  EXPECT_EQ(mb.skeleton, "motionbuilder");
  for (const MotionClip* c : {&daz, &mb}) {
    SCOPED_TRACE(c->name);
    EXPECT_GT(posed_direction(*c, 0, "LeftArm").x, 0.9);
    EXPECT_LT(posed_direction(*c, 0, "RightArm").x, -0.9);
    EXPECT_GT(posed_direction(*c, 0, "LeftForeArm").x, 0.9);
    EXPECT_LT(posed_direction(*c, 0, "LeftUpLeg").y, -0.9);
    EXPECT_LT(posed_direction(*c, 0, "RightLeg").y, -0.9);
    EXPECT_GT(posed_direction(*c, 0, "Spine").y, 0.9);
  }
  const MotionClip amc = load_asf_amc(kMocap + "/cmu-amc/06/06.asf.gz", kMocap + "/cmu-amc/06/06_12.amc.gz", 10);
  EXPECT_EQ(amc.skeleton, "cmu-asf");
  EXPECT_EQ(amc.segments.size(), 31u);
  // 09_12 ends without a line break: refused alone, accepted with the index's frame count.
  const std::string asf09 = kMocap + "/cmu-amc/09/09.asf.gz", amc09 = kMocap + "/cmu-amc/09/09_12.amc.gz";
  EXPECT_NE(error_of([&] { load_asf_amc(asf09, amc09, 50); }).find("no line break"), std::string::npos);
  EXPECT_EQ(load_asf_amc(asf09, amc09, 50, 1918).source_frame_count, 1918);
  EXPECT_NE(error_of([&] { load_asf_amc(asf09, amc09, 50, 1917); }).find("the clip index declares 1917"),
            std::string::npos);
}

TEST(SynthMocapFilesSharedData, EveryClipOfTheSharedIndexLoads) {
  ASSERT_TRUE(fs::exists(kMocap + "/clips.tsv")) << "shared mocap index missing: " << kMocap << "/clips.tsv";
  const std::vector<ClipEntry> all = select_clips(kMocap, {"all"}, kDefaultSplitsPath);
  EXPECT_EQ(all.size(), 289u);
  std::map<std::string, int> by_skeleton;
  long frames = 0;
  for (const ClipEntry& e : all) {
    SCOPED_TRACE(e.id);
    const MotionClip c = load_clip(e, 60);
    EXPECT_EQ(c.source_frame_count, e.frames);
    by_skeleton[c.skeleton]++;
    frames += c.source_frame_count;
  }
  EXPECT_EQ(by_skeleton["cmu-asf"], 196);
  EXPECT_EQ(by_skeleton["motionbuilder"], 42);
  EXPECT_EQ(by_skeleton["daz"], 50);
  EXPECT_EQ(by_skeleton["cmu-asf-names"], 1);  // cmu-bvh-daz/16/16_01 keeps CMU's ASF names
  EXPECT_GT(frames, 360000);
}

TEST(SynthMocapFilesSharedData, SplitsHoldOutWholeSubjects) {
  const std::vector<ClipEntry> test = select_clips(kMocap, {"split:test"}, kDefaultSplitsPath);
  const std::vector<ClipEntry> train = select_clips(kMocap, {"split:train"}, kDefaultSplitsPath);
  const std::vector<ClipEntry> val = select_clips(kMocap, {"split:validation"}, kDefaultSplitsPath);
  EXPECT_EQ(test.size() + train.size() + val.size(), 289u);
  std::set<std::string> train_subjects;
  for (const ClipEntry& e : train) train_subjects.insert(e.subject);
  for (const char* held : {"94", "135", "55", "49", "61", "12"}) EXPECT_EQ(train_subjects.count(held), 0u) << held;
  for (const ClipEntry& e : val) EXPECT_EQ(train_subjects.count(e.subject), 0u) << e.id;
  for (const ClipEntry& e : test) {  // the stylized walks of 105 are a held-out category, not subject
    if (e.subject != "105") {
      EXPECT_EQ(train_subjects.count(e.subject), 0u) << e.id;
    }
  }
  EXPECT_NE(error_of([&] { select_clips(kMocap, {"split:holdout"}, kDefaultSplitsPath); }).find("split must be"),
            std::string::npos);
  EXPECT_NE(error_of([&] { select_clips(kMocap, {"77_01"}, kDefaultSplitsPath); }).find("unknown clip '77_01'"),
            std::string::npos);
}

}  // namespace
}  // namespace dp::synth
