// Helpers for the app/platform tests: temporary directories and small generated datasets.
#pragma once
#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "tools/common/dataset.h"
#include "tools/common/error.h"
#include "tools/common/png_io.h"
#include "tools/demo/fixtures.h"

namespace dp::apptest {

// The ToolError message `fn` throws, or "(no error)".
inline std::string error_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const tools::ToolError& e) {
    return e.what();
  }
  return "(no error)";
}

// A fresh directory under /tmp, removed with its contents at scope exit.
struct TempDir {
  std::string path;
  TempDir() {
    char pattern[] = "/tmp/depthpose_app_XXXXXX";
    const char* p = mkdtemp(pattern);
    EXPECT_NE(p, nullptr);
    path = p ? p : "/tmp";
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  std::string operator/(const std::string& name) const { return path + "/" + name; }
};

// Frame i: a disc at a position that moves with i on a zero background (zero border included).
inline tools::SyntheticFrame moving_disc(int i, int width = 160, int height = 120) {
  return tools::make_disc_frame(width, height, 50.0f + 7.0f * float(i), 40.0f + 3.0f * float(i), 6.0f,
                                uint16_t(1500 + 37 * i));
}

// Frame i: pseudo-random depths 500..4595 mm inside a zero border (compresses badly, so the
// frame data fills most of a recording).
inline tools::SyntheticFrame noisy_frame(int i, int width = 160, int height = 120) {
  tools::SyntheticFrame f = tools::make_disc_frame(width, height, 0.0f, 0.0f, 0.0f, 1000);
  uint32_t x = 2463534242u + uint32_t(i) * 7919u;
  for (int v = 1; v + 1 < height; ++v)
    for (int u = 1; u + 1 < width; ++u) {
      x ^= x << 13;
      x ^= x >> 17;
      x ^= x << 5;
      f.depth_mm[size_t(v) * width + u] = uint16_t(500 + (x & 4095));
    }
  return f;
}

// Writes `frames` as a layout-v1 dataset (depth only).
inline void write_dataset(const std::string& dir, const std::vector<tools::SyntheticFrame>& frames) {
  const int width = frames.at(0).width, height = frames.at(0).height;
  tools::DatasetMeta meta;
  meta.width = width;
  meta.height = height;
  const CameraIntrinsics k = tools::kinect_intrinsics(width, height);
  meta.fx = k.fx;
  meta.fy = k.fy;
  meta.cx = k.cx;
  meta.cy = k.cy;
  tools::create_dataset(dir, meta, false);
  std::vector<tools::FrameRecord> records;
  for (size_t i = 0; i < frames.size(); ++i) {
    tools::ImageU16 image{width, height, frames[i].depth_mm};
    tools::FrameRecord r;
    r.id = tools::frame_id(i);
    tools::write_png_u16(dir + "/depth/" + r.id + ".png", image);
    records.push_back(r);
  }
  tools::write_frames_jsonl(dir, records);
}

// Writes a dataset of `count` moving-disc frames; returns the frames.
inline std::vector<tools::SyntheticFrame> write_disc_dataset(const std::string& dir, int count, int width = 160,
                                                             int height = 120) {
  std::vector<tools::SyntheticFrame> frames;
  for (int i = 0; i < count; ++i) frames.push_back(moving_disc(i, width, height));
  write_dataset(dir, frames);
  return frames;
}

}  // namespace dp::apptest
