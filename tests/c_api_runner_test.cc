// Runs the C API's C test (tests/c_api_test.c) and the documented example
// (docs/examples/c_api_example.c), both compiled as C (mk/c_api.mk), on frames of models/demo.oni.
#include <gtest/gtest.h>

#include <cstdlib>
#include <vector>

#include "forest_blob/blob_writer.h"
#include "platform/frame_source.h"

extern "C" int dp_c_api_selftest(const void* blob, size_t blob_bytes, const uint16_t* depth, int frames, int w, int h,
                                 char* message, size_t message_bytes);
extern "C" int depthpose_example(const void* blob, size_t blob_bytes, const uint16_t* depth, int frames, int w, int h);

namespace {

constexpr int kFrames = 6;

struct Frames {
  int width = 0, height = 0;
  std::vector<uint16_t> depth;  // kFrames frames back to back
};

Frames demo_frames() {
  Frames f;
  std::unique_ptr<dp::platform::FrameSource> source = dp::platform::open_source("oni:models/demo.oni", {});
  f.width = source->width();
  f.height = source->height();
  const size_t n = size_t(f.width) * size_t(f.height);
  f.depth.resize(n * kFrames);
  dp::platform::FrameInfo info;
  for (int i = 0; i < kFrames; ++i)
    if (source->next(f.depth.data() + n * size_t(i), &info) != dp::platform::NextStatus::kFrame)
      ADD_FAILURE() << "models/demo.oni: frame " << i << " unreadable";
  return f;
}

}  // namespace

TEST(CApi, TheCTestSucceedsOnTheDemoRecording) {
  std::vector<uint8_t> blob = dp::blob::read_blob_file("models/ojr.blob");
  const Frames f = demo_frames();
  char message[256] = "";
  const int line = dp_c_api_selftest(blob.data(), blob.size(), f.depth.data(), kFrames, f.width, f.height, message,
                                     sizeof message);
  EXPECT_EQ(line, 0) << "tests/c_api_test.c:" << line << ": " << message;
}

TEST(CApi, TheDocumentedExampleRuns) {
  std::vector<uint8_t> blob = dp::blob::read_blob_file("models/ojr.blob");
  const Frames f = demo_frames();
  testing::internal::CaptureStdout();
  const int rc = depthpose_example(blob.data(), blob.size(), f.depth.data(), kFrames, f.width, f.height);
  const std::string out = testing::internal::GetCapturedStdout();
  EXPECT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("user 1: head at"), std::string::npos) << out;
}
