// The mhclo garment reader (tools/synth/garment.h): what it accepts, the binding formula, and the
// clear refusal of malformed files (file, line and field named).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "tools/common/error.h"
#include "tools/synth/garment.h"

namespace dp::synth {
namespace {

constexpr size_t kBase = 100;  // a small base mesh for the parser tests

const std::string kGood =
    "# comment\n"
    "basemesh hm08\n"
    "name tri\n"
    "obj_file tri.obj\n"
    "x_scale 0 1 2.0\n"
    "z_scale 4 5 0.5\n"
    "verts 0\n"
    "material tri.mhmat\n"
    "0 1 2 0.2 0.3 0.5 0.1 -0.2 0.3\r\n"
    "7\n"
    "10 11 12 1 0 0 0 0 0\n"
    "delete_verts\n"
    "20 - 23 30\n"
    "22 - 24\n";
const std::string kGoodObj = "v 0 0 0\nvt 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\nf 3 2 -3\n";

// Expects a ToolError whose message contains every fragment.
void expect_refused(const std::string& mhclo, const std::string& obj, std::initializer_list<const char*> fragments) {
  try {
    Garment g = parse_mhclo(mhclo, "g.mhclo", kBase);
    parse_garment_obj(obj, "g.obj", g);
    ADD_FAILURE() << "accepted:\n" << mhclo;
  } catch (const dp::tools::ToolError& e) {
    for (const char* f : fragments) EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what() << " lacks " << f;
  }
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return s.replace(at, from.size(), to);
}

TEST(SynthGarment, ParsesBindingsScalesDeleteListAndFaces) {
  Garment g = parse_mhclo(kGood, "g.mhclo", kBase);
  parse_garment_obj(kGoodObj, "g.obj", g);
  EXPECT_EQ(g.name, "tri");
  EXPECT_EQ(g.obj_file, "tri.obj");
  ASSERT_EQ(g.bindings.size(), 3u);
  EXPECT_EQ(g.bindings[0].vertices, (std::array<uint32_t, 3>{0, 1, 2}));
  EXPECT_FLOAT_EQ(g.bindings[0].weights[2], 0.5f);
  EXPECT_FLOAT_EQ(g.bindings[0].offset[1], -0.2f);
  EXPECT_EQ(g.bindings[1].vertices, (std::array<uint32_t, 3>{7, 7, 7}));
  EXPECT_FLOAT_EQ(g.bindings[1].weights[0], 1.0f);
  EXPECT_TRUE(g.scales[0].present);
  EXPECT_FALSE(g.scales[1].present);
  EXPECT_DOUBLE_EQ(g.scales[2].denominator, 0.5);
  EXPECT_EQ(g.delete_vertices, (std::vector<uint32_t>{20, 21, 22, 23, 24, 30}));
  ASSERT_EQ(g.triangles.size(), 2u);
  EXPECT_EQ(g.triangles[1], (std::array<uint32_t, 3>{2, 1, 0}));
}

TEST(SynthGarment, FitIsTheBindingFormulaWithScaledOffsets) {
  Garment g = parse_mhclo(kGood, "g.mhclo", kBase);
  std::vector<Vec3f> body(kBase);
  for (size_t i = 0; i < kBase; ++i) body[i] = {0.01f * float(i), 0.02f * float(i % 7), -0.03f * float(i % 5)};
  std::vector<Vec3f> out;
  fit_garment(g, body, out);
  ASSERT_EQ(out.size(), 3u);
  // x: |x0 - x1| / 2.0 per unit; y: no scale line, 0.1 m per unit; z: |z4 - z5| / 0.5.
  const double sx = std::fabs(body[0].x - body[1].x) / 2.0, sy = 0.1, sz = std::fabs(body[4].z - body[5].z) / 0.5;
  const double ex = 0.2 * body[0].x + 0.3 * body[1].x + 0.5 * body[2].x + 0.1 * sx;
  const double ey = 0.2 * body[0].y + 0.3 * body[1].y + 0.5 * body[2].y - 0.2 * sy;
  const double ez = 0.2 * body[0].z + 0.3 * body[1].z + 0.5 * body[2].z + 0.3 * sz;
  EXPECT_NEAR(out[0].x, ex, 1e-6);
  EXPECT_NEAR(out[0].y, ey, 1e-6);
  EXPECT_NEAR(out[0].z, ez, 1e-6);
  EXPECT_NEAR(out[1].x, body[7].x, 1e-7);
  EXPECT_NEAR(out[1].z, body[7].z, 1e-7);
}

TEST(SynthGarment, RefusesMalformedMhclo) {
  expect_refused(replace(kGood, "10 11 12", "10 11 100"), kGoodObj, {"g.mhclo:11", "binding vertex 3", "outside the base mesh"});
  expect_refused(replace(kGood, "0.2 0.3 0.5", "0.2 x 0.5"), kGoodObj, {"g.mhclo:9", "binding weight 2", "'x'"});
  expect_refused(replace(kGood, "0.1 -0.2 0.3", "0.1 -0.2 nan"), kGoodObj, {"g.mhclo:9", "binding offset z"});
  expect_refused(replace(kGood, " 0.1 -0.2 0.3", " 0.1 -0.2"), kGoodObj, {"g.mhclo:9", "expected 9 fields", "got 8"});
  expect_refused(replace(kGood, "x_scale 0 1 2.0", "x_scale 0 1 0"), kGoodObj, {"g.mhclo:5", "x_scale denominator", "> 0"});
  expect_refused(replace(kGood, "x_scale 0 1 2.0", "x_scale 0 1"), kGoodObj, {"g.mhclo:5", "x_scale"});
  expect_refused(replace(kGood, "20 - 23 30", "20 - 230"), kGoodObj, {"g.mhclo:13", "delete_verts range end", "230"});
  expect_refused(replace(kGood, "20 - 23 30", "23 - 20"), kGoodObj, {"g.mhclo:13", "runs backwards"});
  expect_refused(replace(kGood, "22 - 24", "22 -"), kGoodObj, {"g.mhclo:14", "no end"});
  expect_refused(replace(kGood, "basemesh hm08", "basemesh hm07"), kGoodObj, {"g.mhclo:2", "basemesh", "hm07"});
  expect_refused(replace(kGood, "basemesh hm08\n", ""), kGoodObj, {"g.mhclo", "basemesh hm08"});
  expect_refused(replace(kGood, "obj_file tri.obj\n", ""), kGoodObj, {"g.mhclo", "obj_file"});
  expect_refused(replace(kGood, "material tri.mhmat", "wobble 3"), kGoodObj, {"g.mhclo:8", "unknown keyword 'wobble'"});
  expect_refused(replace(kGood, "verts 0", "verts 1"), kGoodObj, {"g.mhclo:7", "verts 0"});
  // Truncated: cut in the middle of a binding line.
  expect_refused(kGood.substr(0, kGood.find("0.3\r\n")), kGoodObj, {"g.mhclo:9", "expected 9 fields"});
  expect_refused(kGood.substr(0, kGood.find("verts 0")), kGoodObj, {"g.mhclo", "no vertex bindings"});
}

TEST(SynthGarment, RefusesMalformedObj) {
  expect_refused(kGood, "v 0 0 0\nv 1 0 0\nf 1 2 3\n", {"g.obj:3", "f corner 3", "vertex 3 outside", "2 vertices"});
  expect_refused(kGood, kGoodObj + "v 0 0 1\n", {"g.obj", "4 vertices", "binds 3"});
  expect_refused(kGood, "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", {"g.obj:2", "v: expected x y z"});
  expect_refused(kGood, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", {"g.obj:4", "at least 3 corners"});
  expect_refused(kGood, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 b 3\n", {"g.obj:4", "f corner 2", "'b'"});
  expect_refused(kGood, "v 0 0 0\nv 1 0 0\nv 0 1 0\n", {"g.obj", "no faces"});
  expect_refused(kGood, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nq 1\n", {"g.obj:5", "unknown record 'q'"});
}

TEST(SynthGarment, LoadNamesTheMissingFile) {
  const std::string dir = ::testing::TempDir() + "/garment_missing";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  EXPECT_THROW(
      {
        try {
          load_garment(dir + "/none.mhclo", kBase);
        } catch (const dp::tools::ToolError& e) {
          EXPECT_NE(std::string(e.what()).find("none.mhclo"), std::string::npos) << e.what();
          throw;
        }
      },
      dp::tools::ToolError);
  std::ofstream(dir + "/g.mhclo") << kGood;  // names tri.obj, which is absent
  try {
    load_garment(dir + "/g.mhclo", kBase);
    ADD_FAILURE() << "accepted a garment without its obj";
  } catch (const dp::tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("tri.obj"), std::string::npos) << e.what();
  }
  std::ofstream(dir + "/tri.obj") << kGoodObj;
  EXPECT_EQ(load_garment(dir + "/g.mhclo", kBase).triangles.size(), 2u);
}

}  // namespace
}  // namespace dp::synth
