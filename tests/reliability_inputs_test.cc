// Bad inputs found by a hostile probe get a clear error naming the file, the field and the limit:
// frames.jsonl lines without joints, people with the wrong joint count, absurd joint coordinates
// and intrinsics, part labels that name no part, oversized PNG headers, non-regular or huge files,
// unbounded options, trailing data after a PCL tree, corrupt .oni containers.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "platform/oni_container.h"
#include "platform/oni_file_source.h"
#include "platform/openni_source.h"
#include "tests/app_test_support.h"
#include "tests/cli_test_support.h"
#include "tools/app/app_common.h"
#include "tools/common/args.h"
#include "tools/common/dataset.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/common/limits.h"
#include "tools/common/png_io.h"
#include "tools/convert/pcl_import.h"
#include "tools/eval/evaluator.h"
#include "tools/eval/plots.h"

using namespace dp;
using dp::apptest::TempDir;

namespace {

// The ToolError message `f` throws ("" when it does not throw; the test then fails on the match).
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const tools::ToolError& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_HAS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << "message: " << (text)

void write_text(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
}

std::string read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// A one-frame dataset with two named joints and a parts image; `line` replaces frames.jsonl.
void write_joint_dataset(const std::string& dir, const std::string& frames_jsonl, const std::string& meta_extra = "",
                         uint8_t part_label = 3) {
  tools::DatasetMeta meta;
  meta.width = 32;
  meta.height = 24;
  meta.fx = meta.fy = 26.25;
  meta.cx = 15.5;
  meta.cy = 11.5;
  meta.parts = {"a", "b", "c", "d"};
  meta.joints = {"head", "neck"};
  if (!meta_extra.empty()) meta.extra_json = meta_extra;
  tools::create_dataset(dir, meta, true);
  tools::ImageU16 depth{32, 24, std::vector<uint16_t>(32 * 24, 0)};
  tools::ImageU8 parts{32, 24, std::vector<uint8_t>(32 * 24, 255)};
  for (int v = 8; v < 16; ++v)
    for (int u = 10; u < 20; ++u) {
      depth.pixels[size_t(v) * 32 + u] = 2000;
      parts.pixels[size_t(v) * 32 + u] = part_label;
    }
  tools::write_png_u16(dir + "/depth/000000.png", depth);
  tools::write_png_u8(dir + "/parts/000000.png", parts);
  write_text(dir + "/frames.jsonl", frames_jsonl);
}

const char* kTwoJoints = "[[0,0.5,2,1],[0,0.3,2,1]]";

}  // namespace

TEST(ReliabilityInputs, FrameLineWithoutJointsNamesFileAndLine) {
  TempDir t;
  const std::string dir = t / "ds";
  write_joint_dataset(dir, std::string("{\"id\":\"000000\",\"joints\":") + kTwoJoints + "}\n{\"id\":\"000000\"}\n");
  const std::string m = error_of([&] { tools::open_dataset(dir); });
  EXPECT_HAS(m, dir + "/frames.jsonl line 2");
  EXPECT_HAS(m, "no \"joints\"");
  // eval and tune go through the same reader: an error, not a null dereference.
  const std::vector<uint8_t> blob = blob::write_blob(tools::single_part_bpc(4, 1, 2, 40));
  blob::save_blob_file(t / "m.blob", blob);
  const std::string e = error_of([&] { tools::open_eval_session(t / "m.blob", dir, tools::EvalOptions{}); });
  EXPECT_HAS(e, "line 2");
}

TEST(ReliabilityInputs, SegevalPersonWithWrongJointCountIsRefused) {
  for (const char* joints : {"[]", "[[0,0,2,1],[0,0,2,1],[0,0,2,1]]"}) {
    TempDir t;
    const std::string dir = t / "ds";
    write_joint_dataset(dir, std::string("{\"id\":\"000000\",\"joints\":") + kTwoJoints + ",\"people\":[{\"joints\":" +
                                 joints + "}]}\n");
    const std::string m = error_of([&] { testsupport::run_cli({"segeval", "--data", dir}); });
    EXPECT_HAS(m, "person 1");
    EXPECT_HAS(m, "meta.json names 2");
  }
}

TEST(ReliabilityInputs, FarOffTruthJointIsRefusedWithTheLimit) {
  TempDir t;
  const std::string dir = t / "ds";
  write_joint_dataset(dir, "{\"id\":\"000000\",\"joints\":[[1e300,0.5,2,1],[0,0.3,2,1]]}\n");
  const std::string m = error_of([&] { tools::open_dataset(dir); });
  EXPECT_HAS(m, "line 1");
  EXPECT_HAS(m, "joint coordinate x");
  EXPECT_HAS(m, "1000 m");
}

TEST(ReliabilityInputs, TinyFocalLengthInMetaIsRefused) {
  TempDir t;
  const std::string dir = t / "ds";
  write_joint_dataset(dir, std::string("{\"id\":\"000000\",\"joints\":") + kTwoJoints + "}\n");
  std::string meta = read_text(dir + "/meta.json");
  const size_t at = meta.find("\"fx\"");
  ASSERT_NE(at, std::string::npos);
  const size_t end = meta.find_first_of(",\n}", at);
  meta.replace(at, end - at, "\"fx\": 1e-300");
  write_text(dir + "/meta.json", meta);
  const std::string m = error_of([&] { tools::open_dataset(dir); });
  EXPECT_HAS(m, "meta.json");
  EXPECT_HAS(m, "fx = 1e-300 px is outside 1..100000 px");
}

TEST(ReliabilityInputs, NonFiniteIntrinsicsOptionIsRefused) {
  for (const char* value : {"inf,inf,0,0", "nan,500,0,0", "500,500,1e30,0", "0.5,500,0,0"}) {
    std::vector<std::string> words = {"run", "--intrinsics", value};
    std::vector<char*> argv;
    for (std::string& w : words) argv.push_back(w.data());
    const tools::Args args(int(argv.size()), argv.data(), "usage", tools::kSourceOptionNames);
    const std::string m = error_of([&] { tools::source_options_from(args); });
    EXPECT_HAS(m, "--intrinsics");
  }
  std::vector<std::string> words = {"run", "--intrinsics", "525,525,319.5,239.5"};
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  const tools::Args ok(int(argv.size()), argv.data(), "usage", tools::kSourceOptionNames);
  EXPECT_TRUE(tools::source_options_from(ok).has_intrinsics);
}

TEST(ReliabilityInputs, PartLabelsNamingNoPartAreRefused) {
  for (int label : {4, 31, 254}) {
    TempDir t;
    const std::string dir = t / "ds";
    write_joint_dataset(dir, std::string("{\"id\":\"000000\",\"joints\":") + kTwoJoints + "}\n", "", uint8_t(label));
    const tools::Dataset ds = tools::open_dataset(dir);
    const std::string m = error_of([&] { ds.load_parts(0); });
    EXPECT_HAS(m, "part label " + std::to_string(label));
    EXPECT_HAS(m, "labels are 0..3");
  }
  TempDir t;
  write_joint_dataset(t / "ds", std::string("{\"id\":\"000000\",\"joints\":") + kTwoJoints + "}\n", "", 3);
  EXPECT_EQ(tools::open_dataset(t / "ds").load_parts(0).pixels[8 * 32 + 10], 3);
}

TEST(ReliabilityInputs, PngHeaderDimensionsCheckedBeforeAllocating) {
  TempDir t;
  // A valid 2x2 PNG whose IHDR is then edited to 30000x30000 (CRC left stale: the size check
  // comes first) and 100000x100000.
  tools::ImageU16 small{2, 2, {1, 2, 3, 4}};
  std::vector<uint8_t> png = tools::encode_png_u16(small);
  for (uint32_t side : {30000u, 100000u}) {
    std::vector<uint8_t> edited = png;
    for (int k = 0; k < 4; ++k) {
      edited[16 + k] = uint8_t(side >> (24 - 8 * k));
      edited[20 + k] = uint8_t(side >> (24 - 8 * k));
    }
    const std::string path = t / ("big" + std::to_string(side) + ".png");
    tools::write_file_atomic(path, edited.data(), edited.size());
    const std::string m = error_of([&] { tools::read_png_u16(path); });
    EXPECT_HAS(m, path);
    EXPECT_HAS(m, std::to_string(side) + "x" + std::to_string(side));
    EXPECT_HAS(m, "8192");
  }
}

TEST(ReliabilityInputs, NonRegularAndHugeFilesAreRefusedBeforeReading) {
  const std::string m = error_of([] { testsupport::run_cli({"info", "/dev/zero"}); });
  EXPECT_HAS(m, "/dev/zero: not a regular file");
  EXPECT_HAS(error_of([] { tools::read_file_bytes("/proc/self", "blob"); }), "not a regular file");
  TempDir t;
  // A sparse file one byte over the limit: refused by its size, nothing read.
  const std::string big = t / "big.blob";
  {
    std::FILE* f = std::fopen(big.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    ASSERT_EQ(::ftruncate(::fileno(f), off_t(tools::limits::kMaxInputFileBytes) + 1), 0);
    std::fclose(f);
  }
  const std::string h = error_of([&] { testsupport::run_cli({"info", big}); });
  EXPECT_HAS(h, "exceeds the limit of 1024 MiB");
  // An empty blob says so.
  const std::string empty = t / "empty.blob";
  write_text(empty, "");
  testing::internal::CaptureStderr();
  EXPECT_EQ(testsupport::run_cli({"info", empty}), 1);
  EXPECT_HAS(testing::internal::GetCapturedStderr(), "blob is empty (0 bytes)");
}

TEST(ReliabilityInputs, ConvertCheckFramesIsBounded) {
  const std::string m = error_of([] { testsupport::run_cli({"convert", "x.forest", "--out", "/tmp/x.blob", "--check-frames", "100000"}); });
  EXPECT_HAS(m, "--check-frames 100000 is outside 0..256");
  EXPECT_HAS(error_of([] { testsupport::run_cli({"convert", "x.forest", "--out", "/tmp/x.blob", "--check-frames", "-1"}); }),
             "outside 0..256");
}

TEST(ReliabilityInputs, TrailingDataAfterPclTreeIsRefused) {
  TempDir t;
  // Depth 1: one node (5 integers) and two leaf labels.
  write_text(t / "tree.txt", "1\n0 0 0 0 100\n3 4\n");
  ASSERT_EQ(std::system(("bzip2 -k '" + (t / "tree.txt") + "'").c_str()), 0);
  const tools::PclTree good = tools::read_pcl_tree(t / "tree.txt.bz2");
  EXPECT_EQ(good.depth, 1);
  // Garbage after the stream, and a second stream appended.
  const std::string bz = read_text(t / "tree.txt.bz2");
  write_text(t / "garbage.bz2", bz + "trailing junk");
  EXPECT_HAS(error_of([&] { tools::read_pcl_tree(t / "garbage.bz2"); }), "trailing data after the bzip2 stream");
  write_text(t / "two.bz2", bz + bz);
  EXPECT_HAS(error_of([&] { tools::read_pcl_tree(t / "two.bz2"); }), "trailing data");
  // Trailing numbers inside the stream were already refused.
  write_text(t / "extra.txt", "1\n0 0 0 0 100\n3 4 5\n");
  ASSERT_EQ(std::system(("bzip2 -k '" + (t / "extra.txt") + "'").c_str()), 0);
  EXPECT_HAS(error_of([&] { tools::read_pcl_tree(t / "extra.txt.bz2"); }), "trailing data");
}

TEST(ReliabilityInputs, OniContainerCheckedBeforeOpenNiSeesIt) {
  const std::string demo = "models/demo.oni";
  ASSERT_TRUE(std::filesystem::exists(demo)) << demo << " is missing (make model builds it)";
  const std::vector<uint8_t> bytes = tools::read_file_bytes(demo);
  const platform::OniContainerSummary s = platform::check_oni_bytes(bytes.data(), bytes.size(), demo);
  EXPECT_GT(s.depth_frames, 0);
  EXPECT_GT(s.width, 0);
  // ff ff ff 7f written over each 4-byte window of the first 1 KiB (the header, the node and
  // property records): every variant is refused with a message, or still well formed (a value
  // such as a timestamp may take any bits) and then opens without crashing.
  int refused = 0;
  for (size_t at = 0; at + 4 <= 1024; ++at) {
    std::vector<uint8_t> b = bytes;
    b[at] = 0xff;
    b[at + 1] = 0xff;
    b[at + 2] = 0xff;
    b[at + 3] = 0x7f;
    const std::string m = error_of([&] { platform::check_oni_bytes(b.data(), b.size(), "demo"); });
    if (!m.empty()) {
      ++refused;
      EXPECT_HAS(m, "truncated or corrupt");
    }
  }
  // 900 of the 1021 windows are refused; the rest fall on timestamps and property values, which
  // may hold any bits.
  EXPECT_GE(refused, 900);
  // The reproducer: bytes 205..208 (either counting) through the whole source path.
  TempDir t;
  for (size_t at : {204u, 205u}) {
    std::vector<uint8_t> b = bytes;
    b[at] = 0xff;
    b[at + 1] = 0xff;
    b[at + 2] = 0xff;
    b[at + 3] = 0x7f;
    const std::string path = t / ("bad" + std::to_string(at) + ".oni");
    tools::write_file_atomic(path, b.data(), b.size());
    const std::string m = error_of([&] { platform::open_oni_source(path); });
    EXPECT_HAS(m, "oni:" + path);
  }
  // Truncation inside the records is refused too.
  EXPECT_HAS(error_of([&] { platform::check_oni_bytes(bytes.data(), 100, "demo"); }), "truncated or corrupt");
}

TEST(ReliabilityInputs, SegevalSetToleranceIsRangeChecked) {
  TempDir t;
  const std::string dir = t / "ds";
  write_joint_dataset(dir, std::string("{\"id\":\"000000\",\"joints\":") + kTwoJoints + "}\n");
  const std::string m = error_of([&] { testsupport::run_cli({"segeval", "--data", dir, "--set", "join_mm=1e30"}); });
  EXPECT_HAS(m, "join_mm");
  EXPECT_HAS(m, "out of range (float in (0, 65535])");
}

TEST(ReliabilityInputs, PlotsOfFarOffPointsStayOnTheCanvas) {
  // A truth joint at x = 1e300 (infinite as a float) and proposals at ±1e30 px: the overlay is
  // written without converting them to int (clang's UBSan flagged "inf is outside the range of
  // representable values of type 'int'" in plot_overlay).
  TempDir t;
  tools::EvalReport r;
  r.method = "BPC";
  r.frames = 1;
  r.joint_names = {"head"};
  r.ap = {0.5};
  r.curves.resize(1);
  r.positives = {1};
  tools::OverlayFrame o;
  o.id = "000000";
  o.width = 32;
  o.height = 24;
  o.depth_mm.assign(32 * 24, 1000);
  o.part.assign(32 * 24, -1);
  o.proposals = {{tools::ScoredPoint{tools::Point3{1e30f, -1e30f, 1.0f}, 1.0f}}};
  tools::JointSamples::Truth truth;
  truth.position = tools::Point3{float(1e300), 1e38f, 0.0f};
  truth.visible = true;
  o.truth = {truth};
  r.overlays.push_back(o);
  const std::vector<std::string> written = tools::write_eval_plots(r, t / "plots");
  ASSERT_EQ(written.size(), 3u);
  EXPECT_TRUE(std::filesystem::file_size(t / "plots/overlay_000000.png") > 0);
}
