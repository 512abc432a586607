#include "tools/common/dataset.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tools/common/body_model.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/common/json_fields.h"
#include "tools/common/limits.h"

namespace dp::tools {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// A JSON number as a double, or ToolError naming `where` and `field`.
double json_number(const json& v, const std::string& where, const std::string& field) {
  if (!v.is_number()) fail(where + ": " + field + " is not a number");
  return v.get<double>();
}

}  // namespace

JointTruth joint_truth_from_values(double x, double y, double z, bool visible, const std::string& where) {
  const double values[3] = {x, y, z};
  for (int k = 0; k < 3; ++k)
    if (!(std::fabs(values[k]) <= limits::kMaxJointCoordinateM))
      fail(where + ": joint coordinate " + "xyz"[k] + " = " + number(values[k]) + " m is not within ±" +
           number(limits::kMaxJointCoordinateM) + " m");
  return JointTruth{float(x), float(y), float(z), visible};
}

JointTruth joint_truth_from_json(const json& e, const std::string& where) {
  if (!e.is_array() || e.size() != 4) fail(where + ": a joint must be [x,y,z,visible]");
  const double x = json_number(e[0], where, "joint x"), y = json_number(e[1], where, "joint y"),
               z = json_number(e[2], where, "joint z");
  bool visible;
  if (e[3].is_boolean()) visible = e[3].get<bool>();
  else visible = json_number(e[3], where, "joint visible flag") != 0;
  return joint_truth_from_values(x, y, z, visible, where);
}

void check_intrinsics(double fx, double fy, double cx, double cy, const std::string& where) {
  const double f[2] = {fx, fy};
  for (int k = 0; k < 2; ++k)
    if (!(f[k] >= limits::kMinFocalPx && f[k] <= limits::kMaxFocalPx))
      fail(where + ": " + (k ? "fy" : "fx") + " = " + number(f[k]) + " px is outside " + number(limits::kMinFocalPx) +
           ".." + number(limits::kMaxFocalPx) + " px");
  const double c[2] = {cx, cy};
  for (int k = 0; k < 2; ++k)
    if (!(std::fabs(c[k]) <= limits::kMaxPrincipalPointPx))
      fail(where + ": " + (k ? "cy" : "cx") + " = " + number(c[k]) + " px is not within ±" +
           number(limits::kMaxPrincipalPointPx) + " px");
}

Dataset open_dataset(const std::string& dir) {
  Dataset ds;
  ds.dir = dir;
  const std::string meta_path = dir + "/meta.json";
  if (!fs::is_directory(dir)) fail("dataset directory " + dir + " does not exist");
  json m;
  try {
    m = json::parse(read_file_text(meta_path, "dataset meta.json"));
  } catch (const json::exception& e) {
    fail(meta_path + ": malformed JSON: " + e.what());
  }
  try {
    if (m.value("format", "") != "depthpose-dataset")
      fail(meta_path + ": \"format\" is not \"depthpose-dataset\"");
    const int64_t version = m.contains("version") ? json_integer_field(m, "version", 0, INT32_MAX, meta_path) : 0;
    if (version != 1) fail(meta_path + ": unsupported dataset version " + std::to_string(version) + " (this build reads 1)");
    ds.meta.width = int(json_integer_field(m, "width", 1, 8192, meta_path));
    ds.meta.height = int(json_integer_field(m, "height", 1, 8192, meta_path));
    ds.meta.fx = m.at("fx").get<double>();
    ds.meta.fy = m.at("fy").get<double>();
    ds.meta.cx = m.at("cx").get<double>();
    ds.meta.cy = m.at("cy").get<double>();
    ds.meta.parts = m.value("parts", std::vector<std::string>{});
    ds.meta.joints = m.value("joints", std::vector<std::string>{});
    json extra = json::object();
    for (auto it = m.begin(); it != m.end(); ++it) {
      static const char* known[] = {"format", "version", "width", "height", "fx", "fy", "cx", "cy", "parts", "joints"};
      bool k = false;
      for (const char* n : known) k = k || it.key() == n;
      if (!k) extra[it.key()] = it.value();
    }
    ds.meta.extra_json = extra.dump();
  } catch (const json::exception& e) {
    fail(meta_path + ": missing or mistyped field: " + e.what());
  }
  if (ds.meta.width <= 0 || ds.meta.height <= 0 || ds.meta.width > 8192 || ds.meta.height > 8192)
    fail(meta_path + ": implausible image size " + std::to_string(ds.meta.width) + "x" + std::to_string(ds.meta.height));
  check_intrinsics(ds.meta.fx, ds.meta.fy, ds.meta.cx, ds.meta.cy, meta_path);
  ds.has_parts = fs::is_directory(dir + "/parts");

  const std::string frames_path = dir + "/frames.jsonl";
  const std::string text = read_file_text(frames_path, "frames.jsonl");
  std::istringstream f(text);
  std::string line;
  size_t line_no = 0;
  while (std::getline(f, line)) {
    ++line_no;
    if (line.empty()) continue;
    const std::string where = frames_path + " line " + std::to_string(line_no);
    json j;
    try {
      j = json::parse(line);
    } catch (const json::exception& e) {
      fail(where + ": malformed JSON: " + e.what());
    }
    FrameRecord r;
    try {
      r.id = j.at("id").get<std::string>();
      if (r.id.empty() || r.id.find('/') != std::string::npos || r.id.find("..") != std::string::npos)
        fail(where + ": bad frame id '" + r.id + "'");
      if (!j.is_object()) fail(where + ": a frame line must be a JSON object");
      if (!j.contains("joints") && !ds.meta.joints.empty())
        fail(where + ": no \"joints\" (meta.json names " + std::to_string(ds.meta.joints.size()) +
             " joints; every frame must give them, [x,y,z,visible] each)");
      if (j.contains("joints")) {
        const json& js = j.at("joints");
        if (!js.is_array()) fail(where + ": \"joints\" is not an array");
        if (js.size() != ds.meta.joints.size())
          fail(where + ": has " + std::to_string(js.size()) + " joints, meta.json names " +
               std::to_string(ds.meta.joints.size()));
        for (const json& e : js) r.joints.push_back(joint_truth_from_json(e, where));
      }
      json extra = j;
      extra.erase("id");
      extra.erase("joints");
      r.extra_json = extra.dump();
    } catch (const json::exception& e) {
      fail(where + ": missing or mistyped field: " + e.what());
    }
    ds.frames.push_back(std::move(r));
  }
  return ds;
}

ImageU16 Dataset::load_depth(size_t i) const {
  const std::string p = depth_path(i);
  if (!fs::exists(p)) fail("frame " + frames[i].id + ": missing depth image " + p);
  ImageU16 img = read_png_u16(p);
  if (img.width != meta.width || img.height != meta.height)
    fail("frame " + frames[i].id + ": " + p + " is " + std::to_string(img.width) + "x" +
         std::to_string(img.height) + ", meta.json says " + std::to_string(meta.width) + "x" +
         std::to_string(meta.height));
  return img;
}

ImageU8 Dataset::load_parts(size_t i) const {
  const std::string p = parts_path(i);
  if (!fs::exists(p)) fail("frame " + frames[i].id + ": missing part label image " + p);
  ImageU8 img = read_png_u8(p);
  if (img.width != meta.width || img.height != meta.height)
    fail("frame " + frames[i].id + ": " + p + " is " + std::to_string(img.width) + "x" +
         std::to_string(img.height) + ", meta.json says " + std::to_string(meta.width) + "x" +
         std::to_string(meta.height));
  const int parts = part_label_count();
  for (size_t k = 0; k < img.pixels.size(); ++k) {
    const int label = img.pixels[k];
    if (label >= parts && label != kNotBodyLabel)
      fail("frame " + frames[i].id + ": " + p + " pixel (" + std::to_string(k % size_t(img.width)) + ", " +
           std::to_string(k / size_t(img.width)) + ") has part label " + std::to_string(label) +
           "; labels are 0.." + std::to_string(parts - 1) + " (meta.json parts) or " +
           std::to_string(kNotBodyLabel) + " (not body)");
  }
  return img;
}

int Dataset::part_label_count() const {
  return meta.parts.empty() ? kMaxPartLabels : int(std::min<size_t>(meta.parts.size(), size_t(kMaxPartLabels)));
}

void create_dataset(const std::string& dir, const DatasetMeta& meta, bool with_parts) {
  std::error_code ec;
  fs::create_directories(dir + "/depth", ec);
  if (ec) fail("cannot create " + dir + "/depth: " + ec.message());
  if (with_parts) {
    fs::create_directories(dir + "/parts", ec);
    if (ec) fail("cannot create " + dir + "/parts: " + ec.message());
  }
  json m = json::parse(meta.extra_json.empty() ? "{}" : meta.extra_json);
  m["format"] = "depthpose-dataset";
  m["version"] = 1;
  m["width"] = meta.width;
  m["height"] = meta.height;
  m["fx"] = meta.fx;
  m["fy"] = meta.fy;
  m["cx"] = meta.cx;
  m["cy"] = meta.cy;
  m["parts"] = meta.parts;
  m["joints"] = meta.joints;
  std::ofstream f(dir + "/meta.json");
  f << m.dump(1) << "\n";
  if (!f) fail("cannot write " + dir + "/meta.json");
}

std::string frame_id(size_t index) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06zu", index);
  return buf;
}

std::string frame_record_to_json_line(const FrameRecord& record) {
  json j = json::parse(record.extra_json.empty() ? "{}" : record.extra_json);
  j["id"] = record.id;
  json js = json::array();
  for (const JointTruth& t : record.joints) js.push_back({t.x, t.y, t.z, t.visible ? 1 : 0});
  j["joints"] = js;
  return j.dump();
}

void write_frames_jsonl(const std::string& dir, const std::vector<FrameRecord>& records) {
  std::ofstream f(dir + "/frames.jsonl");
  for (const FrameRecord& r : records) f << frame_record_to_json_line(r) << "\n";
  if (!f) fail("cannot write " + dir + "/frames.jsonl");
}

}  // namespace dp::tools
