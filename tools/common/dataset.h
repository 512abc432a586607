// Dataset layout v1 (docs/dataset_format.md): the interchange format between synth, train, eval,
// tune and the dataset source of `depthpose run`.
//   DIR/meta.json          {"format":"depthpose-dataset","version":1,"width","height","fx","fy",
//                           "cx","cy","parts":[names],"joints":[names]}
//   DIR/depth/NNNNNN.png   16-bit grey, millimetres, 0 = no reading
//   DIR/parts/NNNNNN.png   8-bit grey, part id, 255 = not body (optional per dataset)
//   DIR/frames.jsonl       one object per line: {"id":"NNNNNN","joints":[[x,y,z,visible]...], ...}
// Joints in metres, camera frame: x right, y up, z forward. Readers throw ToolError naming the
// file and, for frames.jsonl, the line.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "tools/common/png_io.h"

namespace dp::tools {

struct DatasetMeta {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::vector<std::string> parts;
  std::vector<std::string> joints;
  std::string extra_json = "{}";  // further keys written verbatim into meta.json (object)
};

struct JointTruth {
  float x = 0, y = 0, z = 0;  // metres, camera frame
  bool visible = false;
};

struct FrameRecord {
  std::string id;                 // "000123"; names depth/<id>.png and parts/<id>.png
  std::vector<JointTruth> joints; // meta.joints order; empty when the dataset has no joints
  std::string extra_json = "{}";  // the other keys of the line, as a JSON object text
};

struct Dataset {
  std::string dir;
  DatasetMeta meta;
  std::vector<FrameRecord> frames;
  bool has_parts = false;  // parts/ exists

  std::string depth_path(size_t i) const { return dir + "/depth/" + frames[i].id + ".png"; }
  std::string parts_path(size_t i) const { return dir + "/parts/" + frames[i].id + ".png"; }
  // Load one frame's images; throws ToolError naming the file and frame when the PNG is missing,
  // corrupt, or not meta.width x meta.height, and (parts) when a label is neither a part of
  // meta.parts (0..part_label_count()−1) nor 255 (not body).
  ImageU16 load_depth(size_t i) const;
  ImageU8 load_parts(size_t i) const;
  // Part labels a parts image may hold besides 255: meta.parts.size(), or kMaxPartLabels when
  // meta.json names no parts.
  int part_label_count() const;
};

constexpr int kMaxPartLabels = 32;  // = blob::kMaxParts: labels 0..31

// A ground-truth joint from its values: ToolError naming `where` unless |x|, |y|, |z| are within
// limits::kMaxJointCoordinateM (NaN and infinities are refused).
JointTruth joint_truth_from_values(double x, double y, double z, bool visible, const std::string& where);
// The same from a JSON [x,y,z,visible] (visible a boolean or a number, nonzero = visible).
JointTruth joint_truth_from_json(const nlohmann::json& joint, const std::string& where);

// Camera intrinsics in pixels: ToolError naming `where` and the field unless fx, fy lie within
// limits::kMinFocalPx..kMaxFocalPx and |cx|, |cy| ≤ limits::kMaxPrincipalPointPx.
void check_intrinsics(double fx, double fy, double cx, double cy, const std::string& where);

// Reads meta.json and frames.jsonl (not the PNGs). Throws ToolError on a missing file, a bad
// format/version, intrinsics outside limits, a malformed line (naming its line number), a line
// without "joints" when meta.json names joints, a joint count that disagrees with meta.joints, or
// a joint coordinate outside limits (tools/common/limits.h).
Dataset open_dataset(const std::string& dir);

// Writers. create_dataset makes DIR, DIR/depth, DIR/parts and writes meta.json.
void create_dataset(const std::string& dir, const DatasetMeta& meta, bool with_parts = true);
std::string frame_id(size_t index);  // 6-digit zero-padded
std::string frame_record_to_json_line(const FrameRecord& record);
// Writes frames.jsonl from scratch (one line per record, in order).
void write_frames_jsonl(const std::string& dir, const std::vector<FrameRecord>& records);

}  // namespace dp::tools
