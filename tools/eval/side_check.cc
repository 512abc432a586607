#include "tools/eval/side_check.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/common/json_fields.h"

namespace dp::tools {
namespace {

Pixel read_pixel(const nlohmann::json& v, const SideTruth& t, const std::string& where) {
  if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number())
    fail(where + " is not a pixel [u, v]");
  Pixel p{v[0].get<double>(), v[1].get<double>()};
  if (!(p.u >= 0 && p.u < t.width && p.v >= 0 && p.v < t.height))
    fail(where + " = [" + std::to_string(p.u) + ", " + std::to_string(p.v) + "] is outside the " +
         std::to_string(t.width) + "x" + std::to_string(t.height) + " image");
  return p;
}

double read_finite(const nlohmann::json& o, const char* key, double lo, double hi, const std::string& where) {
  if (!o.contains(key) || !o.at(key).is_number()) fail(where + ": \"" + key + "\" is missing or not a number");
  double v = o.at(key).get<double>();
  if (!(v >= lo && v <= hi))
    fail(where + ": \"" + key + "\" = " + std::to_string(v) + " is outside " + std::to_string(lo) + ".." +
         std::to_string(hi));
  return v;
}

double distance(Pixel a, Pixel b) { return std::hypot(a.u - b.u, a.v - b.v); }

}  // namespace

Pixel project(const SideTruth& c, const std::array<double, 3>& p) {
  return {c.cx + c.fx * p[0] / p[2], c.cy - c.fy * p[1] / p[2]};
}

SideTruth load_side_truth(const std::string& path) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_file_text(path, "side truth"));
  } catch (const nlohmann::json::exception& e) {
    fail(path + ": not JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("camera") || !j.at("camera").is_object())
    fail(path + ": no \"camera\" object");
  SideTruth t;
  const auto& cam = j.at("camera");
  const std::string cw = path + ": camera";
  t.width = static_cast<int>(json_integer_field(cam, "width", 1, 8192, cw));
  t.height = static_cast<int>(json_integer_field(cam, "height", 1, 8192, cw));
  t.fx = read_finite(cam, "fx", 1, 1e5, cw);
  t.fy = read_finite(cam, "fy", 1, 1e5, cw);
  t.cx = read_finite(cam, "cx", 0, t.width, cw);
  t.cy = read_finite(cam, "cy", 0, t.height, cw);
  if (!j.contains("frames") || !j.at("frames").is_array() || j.at("frames").empty())
    fail(path + ": \"frames\" is missing or empty");
  for (size_t f = 0; f < j.at("frames").size(); ++f) {
    const auto& jf = j.at("frames")[f];
    const std::string fw = path + ": frames[" + std::to_string(f) + "]";
    if (!jf.is_object() || !jf.contains("file") || !jf.at("file").is_string() || jf.at("file").get<std::string>().empty())
      fail(fw + ": no \"file\"");
    SideTruthFrame frame;
    frame.file = jf.at("file").get<std::string>();
    if (frame.file.find('/') != std::string::npos) fail(fw + ": \"file\" must be a name in the frames folder");
    if (!jf.contains("people") || !jf.at("people").is_array() || jf.at("people").empty())
      fail(fw + " (" + frame.file + "): \"people\" is missing or empty");
    for (size_t p = 0; p < jf.at("people").size(); ++p) {
      const auto& jp = jf.at("people")[p];
      const std::string pw = fw + ".people[" + std::to_string(p) + "]";
      if (!jp.is_object() || !jp.contains("head")) fail(pw + ": no \"head\"");
      PersonSides person;
      person.head = read_pixel(jp.at("head"), t, pw + ".head");
      int marked = 0;
      for (const char* side : {"left", "right"}) {
        if (!jp.contains(side) || !jp.at(side).is_object()) fail(pw + ": no \"" + side + "\" object");
        for (const auto& [key, value] : jp.at(side).items()) {
          auto it = std::find_if(kSideJoints.begin(), kSideJoints.end(), [&](const char* n) { return key == n; });
          if (it == kSideJoints.end())
            fail(pw + "." + side + ": unknown joint \"" + key + "\" (expected shoulder, elbow, hand)");
          auto& slot = (side[0] == 'l' ? person.left : person.right)[it - kSideJoints.begin()];
          slot = read_pixel(value, t, pw + "." + side + "." + key);
        }
      }
      for (size_t k = 0; k < kSideJoints.size(); ++k) {
        if (person.left[k].has_value() != person.right[k].has_value())
          fail(pw + ": \"" + kSideJoints[k] + "\" is marked on one side only (mark both or neither)");
        marked += person.left[k].has_value() ? 1 : 0;
      }
      if (marked == 0) fail(pw + ": no joint marked");
      frame.people.push_back(person);
    }
    t.frames.push_back(std::move(frame));
  }
  return t;
}

FrameVerdict judge_sides(const SideTruth& camera, const SideTruthFrame& truth,
                         const std::vector<ReportedSkeleton>& skeletons, double max_head_px) {
  FrameVerdict verdict;
  verdict.people.resize(truth.people.size());
  // Nearest (person, skeleton) head pairs first, one-to-one.
  struct Pair {
    double d;
    size_t person, skeleton;
  };
  std::vector<Pair> pairs;
  for (size_t p = 0; p < truth.people.size(); ++p)
    for (size_t s = 0; s < skeletons.size(); ++s)
      if (skeletons[s].head && (*skeletons[s].head)[2] > 0) {
        double d = distance(project(camera, *skeletons[s].head), truth.people[p].head);
        if (d <= max_head_px) pairs.push_back({d, p, s});
      }
  std::stable_sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.d < b.d; });
  std::vector<bool> skeleton_used(skeletons.size(), false);
  for (const Pair& pr : pairs)
    if (verdict.people[pr.person].skeleton < 0 && !skeleton_used[pr.skeleton]) {
      verdict.people[pr.person].skeleton = static_cast<int>(pr.skeleton);
      skeleton_used[pr.skeleton] = true;
    }

  bool all_matched = true;
  for (size_t p = 0; p < truth.people.size(); ++p) {
    const PersonSides& marked = truth.people[p];
    PersonVerdict& pv = verdict.people[p];
    for (size_t k = 0; k < kSideJoints.size(); ++k) {
      pv.left[k] = pv.right[k] = SideOutcome::kMissing;
      if (!marked.left[k]) continue;
      for (int side = 0; side < 2; ++side) {
        SideOutcome& out = side == 0 ? pv.left[k] : pv.right[k];
        const Pixel own = side == 0 ? *marked.left[k] : *marked.right[k];
        const Pixel other = side == 0 ? *marked.right[k] : *marked.left[k];
        const std::optional<std::array<double, 3>>* joint = nullptr;
        if (pv.skeleton >= 0) joint = side == 0 ? &skeletons[pv.skeleton].left[k] : &skeletons[pv.skeleton].right[k];
        if (joint == nullptr || !joint->has_value() || (**joint)[2] <= 0) {
          out = SideOutcome::kMissing;
          ++pv.missing;
          continue;
        }
        const Pixel at = project(camera, **joint);
        out = distance(at, own) <= distance(at, other) ? SideOutcome::kCorrect : SideOutcome::kSwapped;
        ++(out == SideOutcome::kCorrect ? pv.correct : pv.swapped);
      }
    }
    all_matched = all_matched && pv.skeleton >= 0;
    verdict.swapped += pv.swapped;
    verdict.missing += pv.missing;
  }
  verdict.sides_correct = all_matched && verdict.swapped == 0;
  return verdict;
}

}  // namespace dp::tools
