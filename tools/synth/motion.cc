#include "tools/synth/motion.h"

#include <cctype>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include "tools/common/error.h"

namespace dp::synth {
using dp::tools::fail;

namespace {

struct LineReader {
  std::string path;
  std::ifstream in;
  int line_no = 0;
  explicit LineReader(const std::string& p) : path(p), in(p) {
    if (!in) fail("cannot open " + path);
  }
  bool next(std::string& line) {
    if (!std::getline(in, line)) return false;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  [[noreturn]] void error(const std::string& what) const {
    fail(path + ":" + std::to_string(line_no) + ": " + what);
  }
};

std::vector<std::string> tokens_of(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream ss(line);
  std::string t;
  while (ss >> t) out.push_back(t);
  return out;
}

double to_number(const LineReader& r, const std::string& text) {
  char* end = nullptr;
  double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end || !std::isfinite(v)) r.error("expected a number, got '" + text + "'");
  return v;
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Rotation for angles applied one after another about the named axes (first listed first).
Mat3 ordered_rotation(const std::string& axis_order, const double* radians) {
  Mat3 r;
  for (size_t i = 0; i < axis_order.size(); ++i) {
    char a = char(std::tolower(static_cast<unsigned char>(axis_order[i])));
    Mat3 step = a == 'x' ? rot_x(radians[i]) : a == 'y' ? rot_y(radians[i]) : rot_z(radians[i]);
    r = step * r;
  }
  return r;
}

const std::map<std::string, std::string>& asf_to_rig() {
  static const std::map<std::string, std::string> table = {
      {"root", "Hips"},           {"lowerback", "LowerBack"},   {"upperback", "Spine"},
      {"thorax", "Spine1"},       {"lowerneck", "Neck"},        {"upperneck", "Neck1"},
      {"head", "Head"},           {"lclavicle", "LeftShoulder"}, {"lhumerus", "LeftArm"},
      {"lradius", "LeftForeArm"}, {"lwrist", "LeftHand"},       {"lhand", "LeftFingerBase"},
      {"lfingers", "LeftHandFinger1"}, {"lthumb", "LThumb"},    {"rclavicle", "RightShoulder"},
      {"rhumerus", "RightArm"},   {"rradius", "RightForeArm"},  {"rwrist", "RightHand"},
      {"rhand", "RightFingerBase"}, {"rfingers", "RightHandFinger1"}, {"rthumb", "RThumb"},
      {"lhipjoint", "LHipJoint"}, {"lfemur", "LeftUpLeg"},      {"ltibia", "LeftLeg"},
      {"lfoot", "LeftFoot"},      {"ltoes", "LeftToeBase"},     {"rhipjoint", "RHipJoint"},
      {"rfemur", "RightUpLeg"},   {"rtibia", "RightLeg"},       {"rfoot", "RightFoot"},
      {"rtoes", "RightToeBase"}};
  return table;
}

struct AsfBone {
  std::string name;
  Vec3 direction;
  double length = 0;
  Mat3 axis;                 // local frame at rest, in world coordinates
  std::string dof_axes;      // e.g. "xyz" for "dof rx ry rz"; root: rotation channels only
  std::vector<int> channel_kind;  // per dof in file order: 0..2 = translation x/y/z, 3..5 = rotation
  int parent = -1;
};

}  // namespace

int MotionClip::segment_index(const std::string& rig_name) const {
  for (size_t i = 0; i < segments.size(); ++i)
    if (segments[i] == rig_name) return int(i);
  return -1;
}

std::string rig_name_for_asf_bone(const std::string& asf_name) {
  auto it = asf_to_rig().find(lower(asf_name));
  return it == asf_to_rig().end() ? std::string() : it->second;
}

MotionClip load_asf_amc(const std::string& asf_path, const std::string& amc_path, int frame_stride) {
  if (frame_stride < 1) fail("frame stride must be >= 1");
  std::vector<AsfBone> bones;
  std::map<std::string, int> by_name;
  bool degrees = true;
  {
    LineReader r(asf_path);
    AsfBone root;
    root.name = "root";
    bones.push_back(root);
    by_name["root"] = 0;
    std::string line, section;
    AsfBone* cur = nullptr;
    bool in_limits = false;
    bool saw_bonedata = false, saw_hierarchy = false;
    while (r.next(line)) {
      auto t = tokens_of(line);
      if (t.empty() || t[0][0] == '#') continue;
      if (t[0][0] == ':') {
        section = lower(t[0]);
        in_limits = false;
        if (section == ":bonedata") saw_bonedata = true;
        if (section == ":hierarchy") saw_hierarchy = true;
        if (section == ":units" || section == ":root" || section == ":bonedata" ||
            section == ":hierarchy" || section == ":documentation" || section == ":version" ||
            section == ":name")
          continue;
        r.error("unknown ASF section '" + t[0] + "'");
      }
      if (section == ":units") {
        if (t.size() < 2) r.error("units line needs a value");
        if (lower(t[0]) == "angle") degrees = lower(t[1]).rfind("deg", 0) == 0;
      } else if (section == ":root") {
        AsfBone& b = bones[0];
        std::string k = lower(t[0]);
        if (k == "order") {
          b.dof_axes.clear();
          b.channel_kind.clear();
          for (size_t i = 1; i < t.size(); ++i) {
            std::string c = lower(t[i]);
            if (c.size() != 2 || (c[0] != 't' && c[0] != 'r') || c[1] < 'x' || c[1] > 'z')
              r.error("bad root channel '" + t[i] + "'");
            int axis = c[1] - 'x';
            b.channel_kind.push_back(c[0] == 't' ? axis : 3 + axis);
            if (c[0] == 'r') b.dof_axes += c[1];
          }
        } else if (k == "axis") {
          if (t.size() != 2) r.error("root axis needs one order like XYZ");
        } else if (k == "orientation") {
          if (t.size() != 4) r.error("root orientation needs 3 angles");
          double a[3];
          for (int i = 0; i < 3; ++i) a[i] = to_number(r, t[1 + i]) * (degrees ? kDegToRad : 1.0);
          b.axis = ordered_rotation("xyz", a);
        } else if (k == "position") {
          if (t.size() != 4) r.error("root position needs 3 numbers");
        } else {
          r.error("unknown root keyword '" + t[0] + "'");
        }
      } else if (section == ":bonedata") {
        std::string k = lower(t[0]);
        if (k == "begin") {
          bones.emplace_back();
          cur = &bones.back();
          in_limits = false;
        } else if (k == "end") {
          if (!cur) r.error("'end' without 'begin'");
          if (cur->name.empty()) r.error("bone without a name");
          by_name[cur->name] = int(bones.size() - 1);
          cur = nullptr;
          in_limits = false;
        } else if (!cur) {
          r.error("bone data outside begin/end");
        } else if (k == "id") {
        } else if (k == "name") {
          if (t.size() != 2) r.error("name needs one word");
          cur->name = t[1];
        } else if (k == "direction") {
          if (t.size() != 4) r.error("direction needs 3 numbers");
          cur->direction = Vec3{to_number(r, t[1]), to_number(r, t[2]), to_number(r, t[3])}.normalized();
        } else if (k == "length") {
          if (t.size() != 2) r.error("length needs one number");
          cur->length = to_number(r, t[1]);
        } else if (k == "axis") {
          if (t.size() != 5) r.error("axis needs 3 angles and an order");
          double a[3];
          for (int i = 0; i < 3; ++i) a[i] = to_number(r, t[1 + i]) * (degrees ? kDegToRad : 1.0);
          std::string order = lower(t[4]);
          if (order.size() != 3) r.error("bad axis order '" + t[4] + "'");
          cur->axis = ordered_rotation(order, a);
        } else if (k == "dof") {
          for (size_t i = 1; i < t.size(); ++i) {
            std::string c = lower(t[i]);
            if (c == "l") { cur->channel_kind.push_back(-1); continue; }
            if (c.size() != 2 || (c[0] != 't' && c[0] != 'r') || c[1] < 'x' || c[1] > 'z')
              r.error("bad dof '" + t[i] + "'");
            cur->channel_kind.push_back(c[0] == 't' ? c[1] - 'x' : 3 + (c[1] - 'x'));
            if (c[0] == 'r') cur->dof_axes += c[1];
          }
        } else if (k == "limits") {
          in_limits = true;
        } else if (in_limits && t[0][0] == '(') {
        } else if (k == "bodymass" || k == "cofmass") {
        } else {
          r.error("unknown bone keyword '" + t[0] + "'");
        }
      } else if (section == ":hierarchy") {
        std::string k = lower(t[0]);
        if (k == "begin" || k == "end") continue;
        auto p = by_name.find(t[0]);
        if (p == by_name.end()) r.error("hierarchy names unknown bone '" + t[0] + "'");
        for (size_t i = 1; i < t.size(); ++i) {
          auto c = by_name.find(t[i]);
          if (c == by_name.end()) r.error("hierarchy names unknown bone '" + t[i] + "'");
          bones[c->second].parent = p->second;
        }
      }
    }
    if (!saw_bonedata || !saw_hierarchy) fail(asf_path + ": not an ASF skeleton (no :bonedata or :hierarchy)");
  }
  // Evaluation order: parents before children.
  std::vector<int> order;
  {
    std::vector<int> state(bones.size(), 0);
    for (size_t i = 0; i < bones.size(); ++i) {
      std::vector<int> chain;
      for (int b = int(i); b >= 0 && state[b] == 0; b = bones[b].parent) {
        state[b] = 1;
        chain.push_back(b);
        if (chain.size() > bones.size()) fail(asf_path + ": cycle in hierarchy");
      }
      for (auto it = chain.rbegin(); it != chain.rend(); ++it) order.push_back(*it);
    }
    for (size_t i = 1; i < bones.size(); ++i)
      if (bones[i].parent < 0) fail(asf_path + ": bone '" + bones[i].name + "' is not in the hierarchy");
  }

  MotionClip clip;
  {
    std::string stem = amc_path.substr(amc_path.find_last_of('/') + 1);
    clip.name = stem.substr(0, stem.find('.'));
  }
  clip.frame_stride = frame_stride;
  std::vector<int> segment_of(bones.size(), -1);
  for (size_t i = 0; i < bones.size(); ++i) {
    std::string rig = rig_name_for_asf_bone(bones[i].name);
    if (rig.empty()) continue;
    segment_of[i] = int(clip.segments.size());
    clip.segments.push_back(rig);
    clip.rest_directions.push_back(i == 0 ? Vec3{} : bones[i].direction);
  }

  LineReader r(amc_path);
  std::string line;
  std::vector<std::vector<double>> values(bones.size());
  int current_frame = -1;
  auto finish_frame = [&]() {
    if (current_frame < 0) return;
    clip.source_frame_count++;
    if ((clip.source_frame_count - 1) % frame_stride != 0) return;
    std::vector<Mat3> world(bones.size());
    std::vector<Mat3> seg(clip.segments.size());
    for (int b : order) {
      const AsfBone& bone = bones[b];
      double angles[3] = {0, 0, 0};
      size_t n = 0;
      const std::vector<double>& v = values[b];
      for (size_t c = 0; c < bone.channel_kind.size() && c < v.size(); ++c)
        if (bone.channel_kind[c] >= 3 && n < 3) angles[n++] = v[c] * (degrees ? kDegToRad : 1.0);
      Mat3 motion = ordered_rotation(bone.dof_axes.substr(0, n), angles);
      Mat3 local = bone.axis * motion * bone.axis.transposed();
      world[b] = bone.parent < 0 ? local : world[bone.parent] * local;
      if (segment_of[b] >= 0) seg[segment_of[b]] = world[b];
    }
    clip.frames.push_back(std::move(seg));
  };
  bool header = true;
  while (r.next(line)) {
    auto t = tokens_of(line);
    if (t.empty() || t[0][0] == '#') continue;
    if (t[0][0] == ':') {
      if (!header) r.error("keyword '" + t[0] + "' after the first frame");
      continue;
    }
    header = false;
    if (t.size() == 1 && std::isdigit(static_cast<unsigned char>(t[0][0]))) {
      finish_frame();
      current_frame = int(to_number(r, t[0]));
      for (auto& v : values) v.clear();
      continue;
    }
    if (current_frame < 0) r.error("bone values before the first frame number");
    auto b = by_name.find(t[0]);
    if (b == by_name.end()) r.error("unknown bone '" + t[0] + "' (not in " + asf_path + ")");
    const AsfBone& bone = bones[b->second];
    if (t.size() - 1 != bone.channel_kind.size())
      r.error("bone '" + t[0] + "' has " + std::to_string(t.size() - 1) + " values, the skeleton declares " +
              std::to_string(bone.channel_kind.size()));
    std::vector<double>& v = values[b->second];
    v.clear();
    for (size_t i = 1; i < t.size(); ++i) v.push_back(to_number(r, t[i]));
  }
  finish_frame();
  if (clip.frames.empty()) fail(amc_path + ": no frames");
  return clip;
}

MotionClip load_bvh(const std::string& path, int frame_stride) {
  if (frame_stride < 1) fail("frame stride must be >= 1");
  struct Joint {
    std::string name;
    int parent = -1;
    Vec3 offset;
    std::vector<int> channel_kind;  // 0..2 position xyz, 3..5 rotation xyz
    int first_channel = 0;
    Vec3 first_child_offset;
    bool has_child = false;
  };
  std::vector<Joint> joints;
  LineReader r(path);
  std::string line;
  // Tokens from the hierarchy may share lines ("{", "}"); read token-wise with line numbers.
  std::vector<std::pair<std::string, int>> tok;
  bool in_motion = false;
  while (!in_motion && r.next(line)) {
    for (auto& t : tokens_of(line)) {
      if (t == "MOTION") { in_motion = true; break; }
      tok.push_back({t, r.line_no});
    }
  }
  if (!in_motion) r.error("no MOTION section");
  size_t p = 0;
  auto at_line = [&](size_t i) { return i < tok.size() ? tok[i].second : r.line_no; };
  auto err = [&](size_t i, const std::string& what) -> void {
    fail(path + ":" + std::to_string(at_line(i)) + ": " + what);
  };
  auto need = [&](size_t i) -> const std::string& {
    if (i >= tok.size()) err(i, "unexpected end of hierarchy");
    return tok[i].first;
  };
  auto num = [&](size_t i) {
    const std::string& s = need(i);
    char* end = nullptr;
    double v = std::strtod(s.c_str(), &end);
    if (*end || s.empty() || !std::isfinite(v)) err(i, "expected a number, got '" + s + "'");
    return v;
  };
  if (need(p) != "HIERARCHY") err(p, "file does not start with HIERARCHY");
  ++p;
  std::vector<int> stack;
  int channel_total = 0;
  bool pending_end_site = false;
  int depth_of_end_site = -1;
  while (p < tok.size()) {
    const std::string& k = tok[p].first;
    if (k == "ROOT" || k == "JOINT") {
      if ((k == "ROOT") != stack.empty()) err(p, k == "ROOT" ? "ROOT inside a joint" : "JOINT outside ROOT");
      Joint j;
      j.name = need(p + 1);
      j.parent = stack.empty() ? -1 : stack.back();
      joints.push_back(j);
      p += 2;
      if (need(p) != "{") err(p, "expected '{' after " + j.name);
      stack.push_back(int(joints.size() - 1));
      ++p;
    } else if (k == "End") {
      if (need(p + 1) != "Site") err(p + 1, "expected 'End Site'");
      if (need(p + 2) != "{") err(p + 2, "expected '{' after End Site");
      if (stack.empty()) err(p, "End Site outside a joint");
      pending_end_site = true;
      depth_of_end_site = int(stack.size());
      p += 3;
    } else if (k == "OFFSET") {
      Vec3 o{num(p + 1), num(p + 2), num(p + 3)};
      if (stack.empty()) err(p, "OFFSET outside a joint");
      if (pending_end_site) {
        Joint& owner = joints[stack.back()];
        if (!owner.has_child) { owner.first_child_offset = o; owner.has_child = true; }
      } else {
        Joint& j = joints[stack.back()];
        j.offset = o;
        if (j.parent >= 0 && !joints[j.parent].has_child) {
          joints[j.parent].first_child_offset = o;
          joints[j.parent].has_child = true;
        }
      }
      p += 4;
    } else if (k == "CHANNELS") {
      if (stack.empty() || pending_end_site) err(p, "CHANNELS outside a joint");
      int n = int(num(p + 1));
      if (n < 0 || n > 6) err(p + 1, "bad channel count");
      Joint& j = joints[stack.back()];
      j.first_channel = channel_total;
      for (int i = 0; i < n; ++i) {
        const std::string& c = need(p + 2 + i);
        if (c.size() != 9 || (c.substr(1) != "position" && c.substr(1) != "rotation"))
          err(p + 2 + i, "unknown channel '" + c + "'");
        int axis = std::tolower(static_cast<unsigned char>(c[0])) - 'x';
        if (axis < 0 || axis > 2) err(p + 2 + i, "unknown channel '" + c + "'");
        j.channel_kind.push_back(c.substr(1) == "position" ? axis : 3 + axis);
      }
      channel_total += n;
      p += 2 + n;
    } else if (k == "}") {
      if (pending_end_site && int(stack.size()) == depth_of_end_site) {
        pending_end_site = false;
      } else {
        if (stack.empty()) err(p, "unbalanced '}'");
        stack.pop_back();
      }
      ++p;
    } else {
      err(p, "unknown keyword '" + k + "'");
    }
  }
  if (!stack.empty() || pending_end_site) err(p, "unbalanced braces in HIERARCHY");
  if (joints.empty()) err(p, "no joints");

  int frame_count = -1;
  double frame_time = 0;
  while (r.next(line)) {
    auto t = tokens_of(line);
    if (t.empty()) continue;
    if (t[0] == "Frames:") {
      if (t.size() != 2) r.error("Frames: needs a count");
      frame_count = int(to_number(r, t[1]));
    } else if (t[0] == "Frame" && t.size() == 3 && t[1] == "Time:") {
      frame_time = to_number(r, t[2]);
      break;
    } else {
      r.error("expected 'Frames:' and 'Frame Time:'");
    }
  }
  if (frame_count < 0 || !(frame_time > 0)) r.error("missing or bad 'Frames:' / 'Frame Time:'");

  MotionClip clip;
  {
    std::string stem = path.substr(path.find_last_of('/') + 1);
    clip.name = stem.substr(0, stem.find('.'));
  }
  clip.source_frame_rate = 1.0 / frame_time;
  clip.frame_stride = frame_stride;
  std::vector<int> segment_of(joints.size(), -1);
  for (size_t i = 0; i < joints.size(); ++i) {
    segment_of[i] = int(clip.segments.size());
    clip.segments.push_back(joints[i].name);
    clip.rest_directions.push_back(i == 0 || !joints[i].has_child ? Vec3{} : joints[i].first_child_offset.normalized());
  }
  std::vector<double> row;
  while (r.next(line)) {
    auto t = tokens_of(line);
    if (t.empty()) continue;
    if (int(t.size()) != channel_total)
      r.error("frame has " + std::to_string(t.size()) + " values, the hierarchy declares " + std::to_string(channel_total));
    clip.source_frame_count++;
    if (clip.source_frame_count > frame_count) r.error("more frames than 'Frames: " + std::to_string(frame_count) + "'");
    if ((clip.source_frame_count - 1) % frame_stride != 0) continue;
    row.clear();
    for (auto& s : t) row.push_back(to_number(r, s));
    std::vector<Mat3> world(joints.size());
    std::vector<Mat3> seg(clip.segments.size());
    for (size_t i = 0; i < joints.size(); ++i) {  // parents precede children in BVH order
      const Joint& j = joints[i];
      Mat3 local;
      for (size_t c = 0; c < j.channel_kind.size(); ++c) {
        int kind = j.channel_kind[c];
        if (kind < 3) continue;
        double a = row[j.first_channel + c] * kDegToRad;
        local = local * (kind == 3 ? rot_x(a) : kind == 4 ? rot_y(a) : rot_z(a));
      }
      world[i] = j.parent < 0 ? local : world[j.parent] * local;
      seg[segment_of[i]] = world[i];
    }
    clip.frames.push_back(std::move(seg));
  }
  if (clip.source_frame_count != frame_count)
    fail(path + ": 'Frames: " + std::to_string(frame_count) + "' but " + std::to_string(clip.source_frame_count) + " frame rows");
  if (clip.frames.empty()) fail(path + ": no frames");
  return clip;
}

}  // namespace dp::synth
