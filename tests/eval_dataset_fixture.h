// Tiny datasets (layout v1) built by the eval tests: discs of constant depth with known joints.
#pragma once
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "forest_blob/blob_writer.h"
#include "tools/common/dataset.h"
#include "tools/common/png_io.h"
#include "tools/demo/fixtures.h"

namespace dp::evaltest {

struct Disc {
  float u, v, radius;
  uint16_t depth_mm;
};

// A fresh directory under /tmp, removed by the destructor.
struct TempDir {
  std::string path;
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "dp_eval_XXXXXX").string();
    char* made = mkdtemp(tmpl.data());
    EXPECT_NE(made, nullptr);
    path = made ? made : "";
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

// Mean 3D point of the disc's pixels (metres, camera frame).
inline tools::JointTruth disc_centroid(const tools::SyntheticFrame& f) {
  double sx = 0, sy = 0, sz = 0;
  int n = 0;
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u) {
      const uint16_t d = f.depth_mm[size_t(v) * f.width + u];
      if (!d) continue;
      const double z = d * 0.001;
      sx += (u - f.intrinsics.cx) * z / f.intrinsics.fx;
      sy += -(v - f.intrinsics.cy) * z / f.intrinsics.fy;
      sz += z;
      ++n;
    }
  return tools::JointTruth{float(sx / n), float(sy / n), float(sz / n), true};
}

struct DiscDatasetSpec {
  int width = 160, height = 120;
  std::vector<Disc> discs;
  std::vector<std::string> joint_names{"joint0", "joint1"};
  std::vector<std::string> part_names{"part0", "part1", "part2", "part3"};
  bool with_parts = true;
  // Parts labels inside a disc: left half (u < centre) = left_label, the rest = right_label.
  uint8_t left_label = 2, right_label = 2;
  float joint_dz_m = 0.0f;  // joints at the disc centroid + (0, 0, joint_dz_m)
};

// Writes the dataset under `dir` and returns the ground-truth joints per frame.
inline std::vector<tools::JointTruth> write_disc_dataset(const std::string& dir, const DiscDatasetSpec& spec) {
  tools::DatasetMeta meta;
  meta.width = spec.width;
  meta.height = spec.height;
  const CameraIntrinsics k = tools::kinect_intrinsics(spec.width, spec.height);
  meta.fx = k.fx;
  meta.fy = k.fy;
  meta.cx = k.cx;
  meta.cy = k.cy;
  meta.parts = spec.part_names;
  meta.joints = spec.joint_names;
  tools::create_dataset(dir, meta, spec.with_parts);
  std::vector<tools::FrameRecord> records;
  std::vector<tools::JointTruth> truths;
  for (size_t i = 0; i < spec.discs.size(); ++i) {
    const Disc& d = spec.discs[i];
    const tools::SyntheticFrame f = tools::make_disc_frame(spec.width, spec.height, d.u, d.v, d.radius, d.depth_mm);
    tools::ImageU16 depth{spec.width, spec.height, f.depth_mm};
    tools::FrameRecord r;
    r.id = tools::frame_id(i);
    tools::write_png_u16(dir + "/depth/" + r.id + ".png", depth);
    if (spec.with_parts) {
      tools::ImageU8 parts{spec.width, spec.height, std::vector<uint8_t>(f.depth_mm.size(), 255)};
      for (int v = 0; v < spec.height; ++v)
        for (int u = 0; u < spec.width; ++u)
          if (f.depth_mm[size_t(v) * spec.width + u]) parts.pixels[size_t(v) * spec.width + u] = u < d.u ? spec.left_label : spec.right_label;
      tools::write_png_u8(dir + "/parts/" + r.id + ".png", parts);
    }
    tools::JointTruth t = disc_centroid(f);
    t.z += spec.joint_dz_m;
    truths.push_back(t);
    r.joints.assign(spec.joint_names.size(), t);
    records.push_back(r);
  }
  tools::write_frames_jsonl(dir, records);
  return truths;
}

inline std::vector<Disc> three_discs() {
  return {Disc{50, 40, 4, 2000}, Disc{100, 70, 4, 2500}, Disc{80, 60, 5, 1800}};
}

}  // namespace dp::evaltest
