// Small layout-v1 datasets for the trainer's tests and benchmark: a box-shaped "body" whose left
// half (part 0) stands at one depth and right half (part 1) at a depth 1 m further back, in front
// of an empty background (depth 0 = no reading); optionally striped parts 2/3. Joint "a" sits 5 cm behind the centre of the left
// half, joint "b" 5 cm behind the centre of the right half.
#pragma once
#include <stdlib.h>

#include <filesystem>
#include <string>
#include <vector>

#include "tools/common/dataset.h"
#include "tools/common/png_io.h"

namespace dp::train::testing_toy {

struct ToyOptions {
  int frames = 6;
  int width = 64, height = 48;
  double fx = 60, fy = 60;
  bool parts = true;
  int near_mm = 1500;   // part 0; part 1 is 1000 mm further
  bool stripes = false; // parts 2 and 3 as 4-pixel vertical stripes inside parts 0 and 1
};

struct ToyFrame {
  tools::ImageU16 depth;
  tools::ImageU8 parts;
  tools::FrameRecord record;
};

inline ToyFrame make_toy_frame(const ToyOptions& o, int i) {
  ToyFrame f;
  f.depth.width = f.parts.width = o.width;
  f.depth.height = f.parts.height = o.height;
  f.depth.pixels.assign(size_t(o.width) * o.height, 0);
  f.parts.pixels.assign(size_t(o.width) * o.height, 255);
  const int x0 = o.width / 4 + (i % 3) - 1, x1 = 3 * o.width / 4 + (i % 2);
  const int y0 = o.height / 6 + (i % 4), y1 = 5 * o.height / 6 - (i % 3);
  const int mid = (x0 + x1) / 2;
  const int z0 = o.near_mm + 10 * i, z1 = o.near_mm + 1000 + 10 * i;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const bool left = x < mid;
      f.depth.pixels[size_t(y) * o.width + x] = static_cast<uint16_t>(left ? z0 : z1);
      const bool stripe = o.stripes && ((x - x0) / 4) % 2 == 1;
      f.parts.pixels[size_t(y) * o.width + x] = (left ? 0 : 1) + (stripe ? 2 : 0);
    }
  const double cx = (o.width - 1) / 2.0, cy = (o.height - 1) / 2.0;
  auto joint = [&](double u, double v, int z_mm) {
    const double z = z_mm * 0.001;
    return tools::JointTruth{float((u - cx) * z / o.fx), float(-(v - cy) * z / o.fy), float(z + 0.05), true};
  };
  f.record.id = tools::frame_id(i);
  f.record.joints = {joint((x0 + mid - 1) / 2.0, (y0 + y1 - 1) / 2.0, z0),
                     joint((mid + x1 - 1) / 2.0, (y0 + y1 - 1) / 2.0, z1)};
  return f;
}

inline tools::DatasetMeta toy_meta(const ToyOptions& o) {
  tools::DatasetMeta m;
  m.width = o.width;
  m.height = o.height;
  m.fx = o.fx;
  m.fy = o.fy;
  m.cx = (o.width - 1) / 2.0;
  m.cy = (o.height - 1) / 2.0;
  m.parts = {"left", "right"};
  if (o.stripes) m.parts.insert(m.parts.end(), {"left_stripe", "right_stripe"});
  m.joints = {"a", "b"};
  return m;
}

inline void write_toy_dataset(const std::string& dir, const ToyOptions& o = {}) {
  tools::create_dataset(dir, toy_meta(o), o.parts);
  std::vector<tools::FrameRecord> records;
  for (int i = 0; i < o.frames; ++i) {
    ToyFrame f = make_toy_frame(o, i);
    tools::write_png_u16(dir + "/depth/" + f.record.id + ".png", f.depth);
    if (o.parts) tools::write_png_u8(dir + "/parts/" + f.record.id + ".png", f.parts);
    records.push_back(f.record);
  }
  tools::write_frames_jsonl(dir, records);
}

// A fresh directory under /tmp, removed by the destructor.
struct TempDir {
  std::string path;
  TempDir() {
    char tmpl[] = "/tmp/depthpose_train_XXXXXX";
    const char* p = mkdtemp(tmpl);
    path = p ? p : "";
  }
  ~TempDir() {
    std::error_code ec;
    if (!path.empty()) std::filesystem::remove_all(path, ec);
  }
};

}  // namespace dp::train::testing_toy
