#include "tools/synth/human_model.h"

#include <zlib.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tools/common/error.h"

namespace dp::synth {
using dp::tools::fail;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

constexpr double kDecimetre = 0.1;

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail("cannot open " + path + " (is --assets pointing at ../shared/assets?)");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

json parse_json_file(const std::string& path) {
  try {
    return json::parse(slurp(path));
  } catch (const json::exception& e) {
    fail(path + ": malformed JSON: " + e.what());
  }
}

std::string gunzip_file(const std::string& path) {
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) fail("cannot open " + path);
  std::string out;
  char buf[1 << 16];
  for (;;) {
    int n = gzread(f, buf, sizeof buf);
    if (n < 0) {
      gzclose(f);
      fail(path + ": corrupt gzip data");
    }
    if (n == 0) break;
    out.append(buf, size_t(n));
  }
  gzclose(f);
  return out;
}

void load_obj(const std::string& path, HumanAssets& a) {
  std::ifstream f(path);
  if (!f) fail("cannot open " + path + " (is --assets pointing at ../shared/assets?)");
  std::string line, group;
  int line_no = 0;
  while (std::getline(f, line)) {
    ++line_no;
    if (line.size() < 2) continue;
    if (line[0] == 'v' && line[1] == ' ') {
      float x, y, z;
      if (std::sscanf(line.c_str() + 2, "%f %f %f", &x, &y, &z) != 3)
        fail(path + ":" + std::to_string(line_no) + ": bad vertex line");
      a.base_vertices.push_back({float(x * kDecimetre), float(y * kDecimetre), float(z * kDecimetre)});
    } else if (line[0] == 'g' && line[1] == ' ') {
      group = line.substr(2);
      while (!group.empty() && (group.back() == '\r' || group.back() == ' ')) group.pop_back();
    } else if (line[0] == 'f' && line[1] == ' ' && group == "body") {
      std::istringstream ss(line.substr(2));
      std::string corner;
      std::vector<uint32_t> idx;
      while (ss >> corner) {
        long v = std::strtol(corner.c_str(), nullptr, 10);
        if (v <= 0 || v > kBodyVertexCount)
          fail(path + ":" + std::to_string(line_no) + ": body face uses vertex " + std::to_string(v) +
               " outside the body group 1.." + std::to_string(kBodyVertexCount));
        idx.push_back(uint32_t(v - 1));
      }
      if (idx.size() < 3) fail(path + ":" + std::to_string(line_no) + ": face with fewer than 3 corners");
      for (size_t i = 1; i + 1 < idx.size(); ++i) a.body_triangles.push_back({idx[0], idx[i], idx[i + 1]});
    }
  }
  if (a.base_vertices.size() < size_t(kBodyVertexCount) || a.body_triangles.empty())
    fail(path + ": expected the hm08 base mesh (>= 13380 vertices and a 'body' group)");
}

std::vector<uint32_t> group_vertices(const json& groups, const std::string& name, const std::string& path) {
  if (!groups.contains(name)) fail(path + ": no vertex group '" + name + "'");
  std::vector<uint32_t> out;
  for (const json& range : groups.at(name)) {
    uint32_t lo = range.at(0).get<uint32_t>(), hi = range.at(1).get<uint32_t>();
    for (uint32_t v = lo; v <= hi; ++v) out.push_back(v);
  }
  return out;
}

// Blender armature space (z up, -y forward) <-> the mesh frame (y up, +z forward).
Vec3 to_blender(const Vec3& v) { return {v.x, -v.z, v.y}; }
Mat3 blender_to_mesh(const Mat3& b) {
  Mat3 p;  // mesh = p * blender
  p.m = {1, 0, 0, 0, 0, 1, 0, -1, 0};
  return p * b * p.transposed();
}

}  // namespace

int HumanAssets::bone_index(const std::string& name) const {
  for (size_t i = 0; i < bones.size(); ++i)
    if (bones[i].name == name) return int(i);
  return -1;
}

const ShapeTarget* HumanAssets::target(const std::string& name) const {
  for (const ShapeTarget& t : targets)
    if (t.name == name) return &t;
  return nullptr;
}

HumanAssets load_human_assets(const std::string& assets_dir) {
  HumanAssets a;
  const std::string mh = assets_dir + "/makehuman";
  if (!fs::is_directory(mh)) fail("assets directory " + mh + " does not exist (pass --assets ../shared/assets)");
  load_obj(mh + "/3dobjs/base.obj", a);
  const size_t vertex_count = a.base_vertices.size();

  const std::string groups_path = mh + "/mesh_metadata/basemesh_vertex_groups.json";
  json groups = parse_json_file(groups_path);
  try {
    a.vertex_side.assign(kBodyVertexCount, 0);
    for (uint32_t v : group_vertices(groups, "Left", groups_path))
      if (v < uint32_t(kBodyVertexCount)) a.vertex_side[v] = 1;
    for (uint32_t v : group_vertices(groups, "Right", groups_path))
      if (v < uint32_t(kBodyVertexCount)) a.vertex_side[v] = -1;
  } catch (const json::exception& e) {
    fail(groups_path + ": malformed vertex group: " + e.what());
  }

  const std::string rig_path = mh + "/rigs/standard/rig.cmu_mb.json";
  json rig = parse_json_file(rig_path);
  try {
    std::map<std::string, json> pending;
    for (auto it = rig.begin(); it != rig.end(); ++it) pending[it.key()] = it.value();
    // Parents first; repeated passes are fine for 31 bones.
    while (!pending.empty()) {
      bool progressed = false;
      for (auto it = pending.begin(); it != pending.end();) {
        const json& b = it->second;
        std::string parent = b.contains("parent") && b["parent"].is_string() ? b["parent"].get<std::string>() : "";
        int pi = parent.empty() ? -1 : a.bone_index(parent);
        if (!parent.empty() && pi < 0) {
          ++it;
          continue;
        }
        RigBone bone;
        bone.name = it->first;
        bone.parent = pi;
        auto end_vertices = [&](const json& end) {
          if (end.contains("cube_name")) return group_vertices(groups, end.at("cube_name").get<std::string>(), groups_path);
          if (end.contains("vertex_indices")) return end.at("vertex_indices").get<std::vector<uint32_t>>();
          fail(rig_path + ": bone " + it->first + " has an end with neither cube_name nor vertex_indices");
        };
        bone.head_cube = end_vertices(b.at("head"));
        bone.tail_cube = end_vertices(b.at("tail"));
        bone.roll = b.value("roll", 0.0);
        for (uint32_t v : bone.head_cube)
          if (v >= vertex_count) fail(rig_path + ": joint cube of " + bone.name + " beyond the mesh");
        for (uint32_t v : bone.tail_cube)
          if (v >= vertex_count) fail(rig_path + ": joint cube of " + bone.name + " beyond the mesh");
        a.bones.push_back(bone);
        it = pending.erase(it);
        progressed = true;
      }
      if (!progressed) fail(rig_path + ": bone '" + pending.begin()->first + "' has an unknown parent");
    }
  } catch (const json::exception& e) {
    fail(rig_path + ": malformed rig: " + e.what());
  }
  for (const char* required : {"Hips", "Head", "Neck1", "LeftArm", "LeftForeArm", "LeftHand", "LeftFingerBase",
                               "LeftLeg", "LeftFoot", "LeftToeBase", "RightArm", "RightLeg"})
    if (a.bone_index(required) < 0) fail(rig_path + ": rig lacks bone '" + std::string(required) + "'");

  const std::string weights_path = mh + "/rigs/standard/weights.cmu_mb.json";
  {
    json w = parse_json_file(weights_path);
    // Every mesh vertex that has weights gets its row: garments are bound to helper vertices.
    std::vector<std::vector<std::pair<uint16_t, float>>> per_vertex(vertex_count);
    try {
      for (auto it = w.at("weights").begin(); it != w.at("weights").end(); ++it) {
        int b = a.bone_index(it.key());
        if (b < 0) fail(weights_path + ": weights for unknown bone '" + it.key() + "'");
        for (const json& pair : it.value()) {
          uint32_t v = pair.at(0).get<uint32_t>();
          float wt = pair.at(1).get<float>();
          if (v < vertex_count && wt > 0) per_vertex[v].push_back({uint16_t(b), wt});
        }
      }
    } catch (const json::exception& e) {
      fail(weights_path + ": malformed weights: " + e.what());
    }
    a.skin_offsets.push_back(0);
    for (size_t v = 0; v < vertex_count; ++v) {
      auto& list = per_vertex[v];
      if (list.empty() && v < size_t(kBodyVertexCount)) fail(weights_path + ": body vertex " + std::to_string(v) + " has no weights");
      std::sort(list.begin(), list.end(), [](auto& x, auto& y) { return x.first < y.first; });
      float sum = 0;
      for (auto& p : list) sum += p.second;  // an unweighted helper vertex keeps an empty row
      for (auto& p : list) {
        a.skin_bones.push_back(p.first);
        a.skin_weights.push_back(p.second / sum);
      }
      a.skin_offsets.push_back(uint32_t(a.skin_bones.size()));
    }
  }

  // Shape targets: every *.target.gz under targets/macrodetails, named by relative path.
  const std::string target_dir = mh + "/targets/macrodetails";
  if (!fs::is_directory(target_dir)) fail("missing shape target directory " + target_dir);
  std::vector<std::string> files;
  for (auto& e : fs::recursive_directory_iterator(target_dir)) {
    std::string p = e.path().string();
    if (e.is_regular_file() && p.size() > 10 && p.compare(p.size() - 10, 10, ".target.gz") == 0) files.push_back(p);
  }
  std::sort(files.begin(), files.end());
  for (const std::string& p : files) {
    ShapeTarget t;
    t.name = p.substr(target_dir.size() + 1, p.size() - target_dir.size() - 1 - 10);
    std::string text = gunzip_file(p);
    const char* s = text.c_str();
    int line_no = 0;
    while (*s) {
      ++line_no;
      const char* eol = std::strchr(s, '\n');
      if (!eol) eol = s + std::strlen(s);
      while (s < eol && (*s == ' ' || *s == '\t' || *s == '\r')) ++s;
      if (s < eol && *s != '#') {
        char* end;
        long v = std::strtol(s, &end, 10);
        float d[3];
        const char* q = end;
        bool ok = end != s;
        for (int i = 0; i < 3 && ok; ++i) {
          char* e2;
          d[i] = std::strtof(q, &e2);
          ok = e2 != q;
          q = e2;
        }
        if (!ok || v < 0 || size_t(v) >= vertex_count)
          fail(p + ": line " + std::to_string(line_no) + ": expected 'vertex dx dy dz' with a vertex of the base mesh");
        t.vertices.push_back(uint32_t(v));
        t.deltas.push_back({float(d[0] * kDecimetre), float(d[1] * kDecimetre), float(d[2] * kDecimetre)});
      }
      s = *eol ? eol + 1 : eol;
    }
    a.targets.push_back(std::move(t));
  }
  if (!a.target("universal-female-young-averagemuscle-averageweight") && a.targets.size() < 10)
    fail(target_dir + ": macrodetail targets missing");

  // A-pose -> T-pose: the pose file's Euler XYZ rotations act in Blender bone frames (y along the
  // bone, roll 0), composed down the hierarchy as Blender poses bones.
  const std::string tpose_path = mh + "/poses/cmu_mb_fk/t-pose.json";
  json tpose = parse_json_file(tpose_path);
  {
    Skeleton rest = measure_skeleton(a, a.base_vertices);
    std::vector<Mat3> rest_frame(a.bones.size()), posed(a.bones.size());
    a.tpose_world.resize(a.bones.size());
    for (size_t b = 0; b < a.bones.size(); ++b) {
      Vec3 dir = to_blender(rest.tails[b] - rest.heads[b]);
      rest_frame[b] = rotation_between({0, 1, 0}, dir) * rot_y(a.bones[b].roll);
      Mat3 local;
      try {
        const json& rot = tpose.at("bone_rotations");
        if (rot.contains(a.bones[b].name)) {
          const json& e = rot.at(a.bones[b].name);
          local = rot_z(e.at(2).get<double>()) * rot_y(e.at(1).get<double>()) * rot_x(e.at(0).get<double>());
        }
      } catch (const json::exception& e) {
        fail(tpose_path + ": malformed pose: " + e.what());
      }
      int p = a.bones[b].parent;
      posed[b] = p < 0 ? rest_frame[b] * local : posed[p] * rest_frame[p].transposed() * rest_frame[b] * local;
      a.tpose_world[b] = blender_to_mesh(posed[b] * rest_frame[b].transposed());
    }
  }
  return a;
}

std::vector<std::pair<const ShapeTarget*, float>> target_weights(const HumanAssets& a, const ShapeControls& c) {
  auto clamp01 = [](double v) { return std::min(1.0, std::max(0.0, v)); };
  const double g = clamp01(c.gender), age = clamp01(c.age), m = clamp01(c.muscle), w = clamp01(c.weight),
               h = clamp01(c.height), pr = clamp01(c.proportions);
  std::vector<std::pair<std::string, double>> gender = {{"female", 1 - g}, {"male", g}};
  std::vector<std::pair<std::string, double>> ages;
  if (age < 0.5) {
    double young = std::max(0.0, (age - 0.1875) * 3.2);
    double baby = std::max(0.0, 1 - age * 5.333333);
    double child = std::max(0.0, std::min(1.0, 5.333333 * age) - young);
    ages = {{"baby", baby}, {"child", child}, {"young", young}};
  } else {
    double old = age * 2 - 1;
    ages = {{"young", 1 - old}, {"old", old}};
  }
  auto three = [](double v, const char* lo, const char* mid, const char* hi) {
    double l = std::max(0.0, 1 - 2 * v), u = std::max(0.0, 2 * v - 1);
    return std::vector<std::pair<std::string, double>>{{lo, l}, {mid, 1 - l - u}, {hi, u}};
  };
  auto muscles = three(m, "minmuscle", "averagemuscle", "maxmuscle");
  auto weights = three(w, "minweight", "averageweight", "maxweight");
  std::vector<std::pair<std::string, double>> heights = {{"minheight", std::max(0.0, 1 - 2 * h)},
                                                         {"maxheight", std::max(0.0, 2 * h - 1)}};
  std::vector<std::pair<std::string, double>> props = {{"uncommonproportions", std::max(0.0, 1 - 2 * pr)},
                                                       {"idealproportions", std::max(0.0, 2 * pr - 1)}};
  double race_sum = std::max(1e-9, c.african + c.asian + c.caucasian);
  std::vector<std::pair<std::string, double>> races = {
      {"african", c.african / race_sum}, {"asian", c.asian / race_sum}, {"caucasian", c.caucasian / race_sum}};

  std::vector<std::pair<const ShapeTarget*, float>> out;
  auto add = [&](const std::string& name, double weight) {
    if (weight <= 1e-6) return;
    if (const ShapeTarget* t = a.target(name)) out.push_back({t, float(weight)});
  };
  for (auto& [gn, gw] : gender)
    for (auto& [an, aw] : ages) {
      for (auto& [rn, rw] : races) add(rn + "-" + gn + "-" + an, rw * gw * aw);
      for (auto& [mn, mw] : muscles)
        for (auto& [wn, ww] : weights) {
          std::string base = gn + "-" + an + "-" + mn + "-" + wn;
          double bw = gw * aw * mw * ww;
          add("universal-" + base, bw);
          for (auto& [hn, hw] : heights) add("height/" + base + "-" + hn, bw * hw);
          for (auto& [pn, pw] : props) add("proportions/" + base + "-" + pn, bw * pw);
        }
    }
  return out;
}

std::vector<Vec3f> shaped_vertices(const HumanAssets& a, const ShapeControls& c) {
  std::vector<Vec3f> v = a.base_vertices;
  // The hot loop of a synth frame (~850k target entries): raw restrict pointers let the compiler
  // keep the target's arrays and weight in registers; same operations in the same order as the
  // plain form (p += w * delta per entry, targets in target_weights order), so same floats.
  Vec3f* __restrict out = v.data();
  for (auto& [t, w] : target_weights(a, c)) {
    const size_t n = t->vertices.size();
    const uint32_t* __restrict idx = t->vertices.data();
    const Vec3f* __restrict delta = t->deltas.data();
    const float wf = w;
    for (size_t i = 0; i < n; ++i) {
      Vec3f& p = out[idx[i]];
      p.x += wf * delta[i].x;
      p.y += wf * delta[i].y;
      p.z += wf * delta[i].z;
    }
  }
  if (c.extra_height != 1.0 || c.extra_weight != 1.0) {
    float feet = v[0].y, zmin = v[0].z, zmax = v[0].z;
    for (int i = 0; i < kBodyVertexCount; ++i) {
      feet = std::min(feet, v[i].y);
      zmin = std::min(zmin, v[i].z);
      zmax = std::max(zmax, v[i].z);
    }
    const float zc = 0.5f * (zmin + zmax), eh = float(c.extra_height), ew = float(c.extra_weight);
    for (Vec3f& p : v) {
      p.y = feet + (p.y - feet) * eh;
      p.x *= ew;
      p.z = zc + (p.z - zc) * ew;
    }
  }
  return v;
}

double limit_stature(std::vector<Vec3f>& v, double lo, double hi) {
  float feet = v[0].y, crown = v[0].y;
  for (int i = 0; i < kBodyVertexCount; ++i) {
    feet = std::min(feet, v[i].y);
    crown = std::max(crown, v[i].y);
  }
  const double height = double(crown - feet);
  double target = height;
  if (lo > 0 && height < lo) target = lo;
  if (hi > 0 && height > hi) target = hi;
  if (target == height || !(height > 0)) return height;
  const float scale = float(target / height);
  for (Vec3f& p : v) p.y = feet + (p.y - feet) * scale;
  return target;
}

Skeleton measure_skeleton(const HumanAssets& a, const std::vector<Vec3f>& v) {
  Skeleton s;
  auto mean = [&](const std::vector<uint32_t>& idx) {
    Vec3 m;
    for (uint32_t i : idx) m += Vec3{v[i].x, v[i].y, v[i].z};
    return idx.empty() ? m : m * (1.0 / double(idx.size()));
  };
  for (const RigBone& b : a.bones) {
    s.heads.push_back(mean(b.head_cube));
    s.tails.push_back(mean(b.tail_cube));
  }
  return s;
}

}  // namespace dp::synth
