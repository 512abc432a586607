// File sources (raw, dataset) and source specs.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include "platform/frame_source.h"
#include "tests/app_test_support.h"
#include "tests/shared_data.h"
#include "tools/common/error.h"

using namespace dp;
using namespace dp::platform;
using dp::apptest::TempDir;

namespace {

std::string error_of(const std::string& spec, const SourceOptions& o = {}) {
  try {
    open_source(spec, o);
  } catch (const tools::ToolError& e) {
    return e.what();
  }
  return "(no error)";
}

void write_raw(const std::string& path, const std::vector<uint16_t>& pixels, size_t bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(pixels.data()), std::streamsize(bytes));
}

}  // namespace

TEST(PlatformSourcesSharedData, RawSkeltrackFramesAreReadAsLittleEndianMillimetres) {
  const std::string glob = dp::test::shared_path("data/skeltrack-frames/*.raw");
  auto source = open_source("raw:" + glob + ":640x480");
  ASSERT_EQ(source->frame_count(), 12) << "needs the 12 Skeltrack frames in " << dp::test::shared_path("data/skeltrack-frames");
  EXPECT_EQ(source->width(), 640);
  EXPECT_EQ(source->height(), 480);
  const CameraIntrinsics k = source->intrinsics();
  EXPECT_FLOAT_EQ(k.fx, 525.0f);
  EXPECT_FLOAT_EQ(k.fy, 525.0f);
  EXPECT_FLOAT_EQ(k.cx, 319.5f);
  EXPECT_FLOAT_EQ(k.cy, 239.5f);
  EXPECT_FALSE(source->live());
  // Frame 0 is the first file by name, byte for byte.
  std::ifstream f(dp::test::shared_path("data/skeltrack-frames/depth-data-1028894671.raw"), std::ios::binary);
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  ASSERT_EQ(bytes.size(), 640u * 480u * 2u);
  std::vector<uint16_t> depth(640 * 480);
  FrameInfo info;
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(info.index, 0);
  EXPECT_EQ(depth[1000], uint16_t(bytes[2000] | (bytes[2001] << 8)));
  EXPECT_EQ(std::memcmp(depth.data(), bytes.data(), bytes.size()), 0);
  int frames = 1;
  while (source->next(depth.data(), &info) == NextStatus::kFrame) ++frames;
  EXPECT_EQ(frames, 12);
  EXPECT_EQ(info.timestamp_us, 11u * 33333u);
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kEnd);
  EXPECT_EQ(source->stats().frames, 12);
  EXPECT_EQ(source->stats().corrupt_frames, 0);
}

TEST(PlatformSources, RawShortFileIsSkippedAndCounted) {
  TempDir dir;
  std::vector<uint16_t> a(4 * 3, 1000), b(4 * 3, 2000);
  write_raw(dir / "f0.raw", a, 24);
  write_raw(dir / "f1.raw", b, 23);  // truncated
  write_raw(dir / "f2.raw", b, 24);
  auto source = open_source("raw:" + (dir / "f*.raw") + ":4x3");
  std::vector<uint16_t> depth(12);
  FrameInfo info;
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(depth, a);
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(depth, b);
  EXPECT_EQ(info.index, 2);
  EXPECT_EQ(source->stats().corrupt_frames, 1);
  EXPECT_NE(source->last_warning().find("f1.raw"), std::string::npos) << source->last_warning();
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kEnd);
}

TEST(PlatformSources, DatasetUsesItsIntrinsicsAndSkipsMissingFrames) {
  TempDir dir;
  auto frames = apptest::write_disc_dataset(dir / "ds", 3);
  std::remove((dir / "ds/depth/000001.png").c_str());
  auto source = open_source("dataset:" + (dir / "ds"));
  EXPECT_EQ(source->frame_count(), 3);
  EXPECT_FLOAT_EQ(source->intrinsics().fx, frames[0].intrinsics.fx);
  std::vector<uint16_t> depth(160 * 120);
  FrameInfo info;
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_TRUE(depth == frames[0].depth_mm);
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(info.index, 2);
  EXPECT_TRUE(depth == frames[2].depth_mm);
  EXPECT_EQ(source->stats().corrupt_frames, 1);
  EXPECT_NE(source->last_warning().find("000001.png"), std::string::npos) << source->last_warning();
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kEnd);
}

TEST(PlatformSourcesSharedData, IntrinsicsOverride) {
  SourceOptions o;
  o.has_intrinsics = true;
  o.intrinsics = CameraIntrinsics{580.0f, 581.0f, 320.0f, 240.0f};
  auto source = open_source("raw:" + dp::test::shared_path("data/skeltrack-frames") + "/*.raw:640x480", o);
  EXPECT_FLOAT_EQ(source->intrinsics().fx, 580.0f);
  EXPECT_FLOAT_EQ(source->intrinsics().cy, 240.0f);
}

TEST(PlatformSourcesSharedData, BadSpecsAreOneLineErrors) {
  TempDir dir;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "unknown source"},
      {"webcam:0", "unknown source"},
      {"raw:" + dp::test::shared_path("data/skeltrack-frames") + "/*.raw", "want raw:GLOB:WxH"},
      {"raw:" + dp::test::shared_path("data/skeltrack-frames") + "/*.raw:640", "bad frame size"},
      {"raw:" + dp::test::shared_path("data/skeltrack-frames") + "/*.raw:0x480", "bad frame size"},
      {"raw:" + dp::test::shared_path("data/skeltrack-frames") + "/*.raw:320x240", "wrong resolution"},
      {"raw:" + (dir / "none*.raw") + ":640x480", "no file matches"},
      {"dataset:", "want dataset:DIR"},
      {"dataset:" + (dir / "missing"), "missing"},
      {"oni:", "want oni:FILE"},
      {"oni:" + (dir / "missing.oni"), "cannot open the file"},
      {"v4l2:", "want v4l2:/dev/videoN"},
      {"v4l2:" + (dir / "video0"), "no such device"},
  };
  for (const auto& [spec, expected] : cases) {
    const std::string why = error_of(spec);
    EXPECT_NE(why.find(expected), std::string::npos) << "spec '" << spec << "' gave: " << why;
    EXPECT_EQ(why.find('\n'), std::string::npos) << why;
  }
}
