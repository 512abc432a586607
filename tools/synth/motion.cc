#include "tools/synth/motion.h"

#include <zlib.h>

#include <cctype>
#include <charconv>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string_view>

#include "tools/common/error.h"
#include "tools/synth/skeleton_naming.h"

namespace dp::synth {
using dp::tools::fail;

MocapText read_mocap_text(const std::string& path) {
  MocapText t;
  t.path = path;
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) fail("cannot open " + path);
  gzbuffer(f, 1 << 17);
  char chunk[1 << 16];
  for (;;) {
    const int n = gzread(f, chunk, sizeof chunk);
    if (n < 0) {
      int code = 0;
      const std::string why = gzerror(f, &code);
      gzclose_r(f);
      fail(path + ": corrupt or truncated gzip data (" + why + ")");
    }
    if (n == 0) break;
    if (t.bytes.size() + size_t(n) > kMaxMocapFileBytes) {
      gzclose_r(f);
      fail(path + ": larger than " + std::to_string(kMaxMocapFileBytes >> 20) + " MiB decompressed (kMaxMocapFileBytes)");
    }
    t.bytes.append(chunk, size_t(n));
  }
  int code = 0;
  const std::string why = gzerror(f, &code);
  // A gzip stream cut short reads as end of file with Z_BUF_ERROR pending.
  const int closed = gzclose_r(f);
  if (code != Z_OK || closed != Z_OK)
    fail(path + ": corrupt or truncated gzip data (" + (code != Z_OK ? why : std::string("unexpected end of file")) + ")");
  t.ends_with_line_break = !t.bytes.empty() && t.bytes.back() == '\n';
  return t;
}

namespace {

struct LineReader {
  MocapText text;
  size_t pos = 0;
  int line_no = 0;
  bool terminated = true;  // the line last returned ended with a line break
  explicit LineReader(const std::string& p) : text(read_mocap_text(p)) {}
  bool next(std::string_view& line) {
    const std::string& b = text.bytes;
    if (pos >= b.size()) return false;
    size_t e = b.find('\n', pos);
    terminated = e != std::string::npos;
    if (!terminated) e = b.size();
    line = std::string_view(b).substr(pos, e - pos);
    pos = e + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    return true;
  }
  bool next(std::string& line) {
    std::string_view v;
    if (!next(v)) return false;
    line.assign(v);
    return true;
  }
  [[noreturn]] void error(const std::string& what) const {
    fail(text.path + ":" + std::to_string(line_no) + ": " + what);
  }
};

// Whitespace-separated fields of a line, as views into it.
void split_fields(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
}

bool parse_number(std::string_view text, double& v) {
  if (!text.empty() && text[0] == '+') text.remove_prefix(1);
  const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
  return !text.empty() && r.ec == std::errc() && r.ptr == text.data() + text.size() && std::isfinite(v);
}

std::vector<std::string> tokens_of(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream ss(line);
  std::string t;
  while (ss >> t) out.push_back(t);
  return out;
}

double to_number(const LineReader& r, std::string_view text) {
  double v = 0;
  if (!parse_number(text, v)) r.error("expected a number, got '" + std::string(text) + "'");
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

MotionClip load_asf_amc(const std::string& asf_path, const std::string& amc_path, int frame_stride,
                        long expected_frames) {
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

  // The body needs these bones; toes, hands and fingers may be missing (they follow).
  {
    std::string missing;
    for (const char* need : {"root", "lowerback", "upperback", "thorax", "lowerneck", "upperneck", "head",
                             "lclavicle", "lhumerus", "lradius", "lwrist", "lhipjoint", "lfemur", "ltibia", "lfoot",
                             "rclavicle", "rhumerus", "rradius", "rwrist", "rhipjoint", "rfemur", "rtibia", "rfoot"}) {
      bool found = false;
      for (const AsfBone& b : bones) found = found || lower(b.name) == need;
      if (!found) missing += (missing.empty() ? "" : ", ") + std::string(need);
    }
    if (!missing.empty())
      fail(asf_path + ": ASF skeleton lacks bones " + missing + " (CMU bone names expected)");
  }
  MotionClip clip;
  {
    std::string stem = amc_path.substr(amc_path.find_last_of('/') + 1);
    clip.name = stem.substr(0, stem.find('.'));
  }
  clip.skeleton = "cmu-asf";
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
  std::string_view line;
  std::vector<std::string_view> t;
  std::vector<std::vector<double>> values(bones.size());
  std::vector<char> seen(bones.size(), 0);
  long current_frame = -1;
  int frame_line = 0;
  // A frame must list every bone that has degrees of freedom, once: a file cut inside its last
  // frame otherwise yields missing bones at zero rotation.
  auto finish_frame = [&]() {
    if (current_frame < 0) return;
    std::string missing;
    for (size_t b = 0; b < bones.size(); ++b)
      if (!bones[b].channel_kind.empty() && !seen[b]) missing += (missing.empty() ? "" : " ") + bones[b].name;
    if (!missing.empty())
      fail(amc_path + ": frame " + std::to_string(current_frame) + " (line " + std::to_string(frame_line) +
           ") lacks bones " + missing + " (file truncated inside a frame?)");
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
  bool unterminated_data = false;
  while (r.next(line)) {
    split_fields(line, t);
    if (t.empty() || t[0][0] == '#') continue;
    unterminated_data = !r.terminated;
    if (t[0][0] == ':') {
      if (!header) r.error("keyword '" + std::string(t[0]) + "' after the first frame");
      continue;
    }
    header = false;
    if (t.size() == 1 && std::isdigit(static_cast<unsigned char>(t[0][0]))) {
      finish_frame();
      const double number = to_number(r, t[0]);
      if (number != std::floor(number) || number > 1e9) r.error("bad frame number '" + std::string(t[0]) + "'");
      current_frame = long(number);
      frame_line = r.line_no;
      for (auto& v : values) v.clear();
      std::fill(seen.begin(), seen.end(), 0);
      continue;
    }
    if (current_frame < 0) r.error("bone values before the first frame number");
    const std::string in_frame = "frame " + std::to_string(current_frame) + ": ";
    const std::string name(t[0]);
    auto b = by_name.find(name);
    if (b == by_name.end()) r.error(in_frame + "unknown bone '" + name + "' (not in " + asf_path + ")");
    const AsfBone& bone = bones[b->second];
    if (seen[b->second]) r.error(in_frame + "bone '" + name + "' listed twice");
    seen[b->second] = 1;
    if (t.size() - 1 != bone.channel_kind.size())
      r.error(in_frame + "bone '" + name + "' has " + std::to_string(t.size() - 1) +
              " values, the skeleton declares " + std::to_string(bone.channel_kind.size()));
    std::vector<double>& v = values[b->second];
    v.clear();
    for (size_t i = 1; i < t.size(); ++i) {
      double x = 0;
      if (!parse_number(t[i], x)) r.error(in_frame + "expected a number, got '" + std::string(t[i]) + "'");
      v.push_back(x);
    }
  }
  finish_frame();
  if (clip.frames.empty()) fail(amc_path + ": no frames");
  if (expected_frames >= 0 && clip.source_frame_count != expected_frames)
    fail(amc_path + ": " + std::to_string(clip.source_frame_count) + " frames, the clip index declares " +
         std::to_string(expected_frames));
  if (unterminated_data && expected_frames < 0)
    fail(amc_path + ": frame " + std::to_string(current_frame) +
         ": the last line has no line break, so the file looks truncated inside its last frame");
  return clip;
}

MotionClip load_bvh(const std::string& path, int frame_stride, long expected_frames) {
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
      if (k == "ROOT" && !joints.empty()) err(p, "a second ROOT (one skeleton per file)");
      if (joints.size() >= 1000) err(p, "more than 1000 joints");
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
      // Checked as a double first: converting an out-of-range value to int is undefined.
      const double count = num(p + 1);
      if (!(count >= 0 && count <= 6) || count != std::floor(count)) err(p + 1, "bad channel count");
      const int n = int(count);
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

  // Which rig bone each source joint drives (skeleton_naming.h), and the rest-pose geometry.
  std::vector<std::string> names;
  for (const Joint& j : joints) names.push_back(j.name);
  const SkeletonNaming& naming = recognise_bvh_skeleton(names, path);
  auto find_joint = [&](const char* name) {
    for (size_t i = 0; i < joints.size(); ++i)
      if (lower(joints[i].name) == lower(name)) return int(i);
    return -1;
  };
  std::vector<Vec3> rest_pos(joints.size());
  for (size_t i = 0; i < joints.size(); ++i)
    rest_pos[i] = joints[i].parent < 0 ? Vec3{} : rest_pos[joints[i].parent] + joints[i].offset;
  struct Drive {
    int source = -1;
    int tail = -1;       // joint index; -1 = first child / End Site offset; -2 = no direction
    Vec3 rest_direction; // unit, or zero when undefined
  };
  MotionClip clip;
  std::vector<Drive> drives;
  for (const JointMapEntry& e : naming.entries) {
    Drive d;
    d.source = e.joint[0] == 0 ? 0 : find_joint(e.joint);
    const bool no_direction = e.tail[0] == '-' && e.tail[1] == 0;
    d.tail = no_direction ? -2 : e.tail[0] == 0 ? -1 : find_joint(e.tail);
    if (d.source < 0 || (e.tail[0] != 0 && !no_direction && d.tail < 0)) continue;  // optional, absent
    if (d.tail >= 0) {
      d.rest_direction = (rest_pos[d.tail] - rest_pos[d.source]).normalized();
    } else if (d.tail == -1 && joints[d.source].has_child) {
      d.rest_direction = joints[d.source].first_child_offset.normalized();
    }
    if (d.rest_direction.norm() < 0.5) d.tail = -2;  // zero-length bone: no direction
    drives.push_back(d);
    clip.segments.push_back(e.rig_bone);
    clip.rest_directions.push_back(lower(e.rig_bone) == "hips" ? Vec3{} : d.rest_direction);
  }
  // The body must face +z with its left at +x, as the rig does; a mirrored or turned rest pose
  // would swap sides silently.
  {
    const int l = clip.segment_index("LeftUpLeg"), rr = clip.segment_index("RightUpLeg");
    const int la = clip.segment_index("LeftArm"), ra = clip.segment_index("RightArm");
    if (l < 0 || rr < 0 || la < 0 || ra < 0) fail(path + ": skeleton map lacks legs or arms");
    if (!(rest_pos[drives[l].source].x > rest_pos[drives[rr].source].x) ||
        !(rest_pos[drives[la].source].x > rest_pos[drives[ra].source].x))
      fail(path + ": rest pose has its left joints at -x (mirrored or turned skeleton); expected y up, facing +z, left at +x");
  }

  int frame_count = -1;
  double frame_time = 0;
  while (r.next(line)) {
    auto t = tokens_of(line);
    if (t.empty()) continue;
    if (t[0] == "Frames:") {
      if (t.size() != 2) r.error("Frames: needs a count");
      const double n = to_number(r, t[1]);
      if (n < 0 || n > 1e8 || n != std::floor(n)) r.error("bad frame count '" + t[1] + "'");
      frame_count = int(n);
    } else if (t[0] == "Frame" && t.size() == 3 && t[1] == "Time:") {
      frame_time = to_number(r, t[2]);
      break;
    } else {
      r.error("expected 'Frames:' and 'Frame Time:'");
    }
  }
  if (frame_count < 0 || !(frame_time > 0)) r.error("missing or bad 'Frames:' / 'Frame Time:'");
  if (expected_frames >= 0 && frame_count != expected_frames)
    fail(path + ": 'Frames: " + std::to_string(frame_count) + "' but the clip index declares " +
         std::to_string(expected_frames));

  {
    std::string stem = path.substr(path.find_last_of('/') + 1);
    clip.name = stem.substr(0, stem.find('.'));
  }
  clip.skeleton = naming.name;
  clip.source_frame_rate = 1.0 / frame_time;
  clip.frame_stride = frame_stride;
  std::vector<double> row(static_cast<size_t>(channel_total));
  std::vector<std::string_view> t;
  std::vector<Mat3> world(joints.size());
  std::vector<Vec3> pos(joints.size());
  std::string_view view;
  while (r.next(view)) {
    split_fields(view, t);
    if (t.empty()) continue;
    if (int(t.size()) != channel_total)
      r.error("frame has " + std::to_string(t.size()) + " values, the hierarchy declares " + std::to_string(channel_total));
    if (!r.terminated)
      r.error("the last frame row has no line break, so the file looks truncated inside frame " +
              std::to_string(clip.source_frame_count + 1));
    clip.source_frame_count++;
    if (clip.source_frame_count > frame_count) r.error("more frames than 'Frames: " + std::to_string(frame_count) + "'");
    if ((clip.source_frame_count - 1) % frame_stride != 0) continue;
    for (size_t c = 0; c < t.size(); ++c) row[c] = to_number(r, t[c]);
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
      pos[i] = j.parent < 0 ? Vec3{} : pos[j.parent] + world[j.parent] * j.offset;
    }
    std::vector<Mat3> seg(drives.size());
    for (size_t s = 0; s < drives.size(); ++s) {
      const Drive& d = drives[s];
      Mat3 q = world[d.source];
      if (d.tail >= 0 && joints[d.tail].parent != d.source) {
        // The tail lies beyond joints the rig lacks: swing onto where it actually is.
        const Vec3 actual = pos[d.tail] - pos[d.source];
        if (actual.norm() > 1e-9) q = rotation_between(q * d.rest_direction, actual) * q;
      }
      seg[s] = q;
    }
    clip.frames.push_back(std::move(seg));
  }
  if (clip.source_frame_count != frame_count)
    fail(path + ": 'Frames: " + std::to_string(frame_count) + "' but " + std::to_string(clip.source_frame_count) + " frame rows");
  if (clip.frames.empty()) fail(path + ": no frames");
  return clip;
}

}  // namespace dp::synth
