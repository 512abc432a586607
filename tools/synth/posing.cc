#include "tools/synth/posing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <queue>

#include "tools/common/error.h"

namespace dp::synth {
using dp::tools::fail;

namespace {
int bone_or_fail(const HumanAssets& a, const char* name) {
  int b = a.bone_index(name);
  if (b < 0) fail(std::string("rig lacks bone ") + name);
  return b;
}
}  // namespace

BodyPose rest_pose(const HumanAssets& a) {
  BodyPose p;
  p.bone_world.assign(a.bones.size(), Mat3::identity());
  return p;
}

BodyPose t_pose(const HumanAssets& a) {
  BodyPose p;
  p.bone_world = a.tpose_world;
  return p;
}

BodyPose retarget_frame(const HumanAssets& a, const Skeleton& rest, const MotionClip& clip, size_t k) {
  BodyPose pose;
  pose.bone_world.resize(a.bones.size());
  const std::vector<Mat3>& frame = clip.frames.at(k);
  std::vector<Mat3> q(a.bones.size());
  for (size_t b = 0; b < a.bones.size(); ++b) {
    int s = clip.segment_index(a.bones[b].name);
    const Mat3& tb = a.tpose_world[b];
    if (s < 0) {
      // Not in the clip: keep the T-pose relation to the parent.
      int p = a.bones[b].parent;
      pose.bone_world[b] = p < 0 ? tb : pose.bone_world[p] * a.tpose_world[p].transposed() * tb;
      continue;
    }
    Mat3 align;
    const Vec3& src = clip.rest_directions[s];
    Vec3 ours = tb * (rest.tails[b] - rest.heads[b]);
    if (src.norm() > 0.5 && ours.norm() > 1e-9) align = rotation_between(ours, src);
    pose.bone_world[b] = frame[s] * align * tb;
  }
  // Remove the heading so the body faces +z; keep tilt.
  const int hips = bone_or_fail(a, "Hips");
  Vec3 forward = pose.bone_world[hips] * Vec3{0, 0, 1};
  if (std::hypot(forward.x, forward.z) > 1e-6) {
    Mat3 unyaw = rot_y(-std::atan2(forward.x, forward.z));
    for (Mat3& m : pose.bone_world) m = unyaw * m;
  }
  return pose;
}

Skeleton pose_skeleton(const HumanAssets& a, const Skeleton& rest, const BodyPose& pose) {
  Skeleton s;
  s.heads.resize(a.bones.size());
  s.tails.resize(a.bones.size());
  for (size_t b = 0; b < a.bones.size(); ++b) {
    int p = a.bones[b].parent;
    s.heads[b] = p < 0 ? rest.heads[b] : s.heads[p] + pose.bone_world[p] * (rest.heads[b] - rest.heads[p]);
    s.tails[b] = s.heads[b] + pose.bone_world[b] * (rest.tails[b] - rest.heads[b]);
  }
  return s;
}

JointSet joints_of(const HumanAssets& a, const Skeleton& s) {
  auto head = [&](const char* n) { return s.heads[bone_or_fail(a, n)]; };
  auto tail = [&](const char* n) { return s.tails[bone_or_fail(a, n)]; };
  JointSet j;
  j[0] = (head("Head") + tail("Head")) * 0.5;
  j[1] = head("Neck1");
  j[2] = head("LeftArm");
  j[3] = head("RightArm");
  j[4] = head("LeftForeArm");
  j[5] = head("RightForeArm");
  j[6] = head("LeftHand");
  j[7] = head("RightHand");
  j[8] = (head("LeftHand") + tail("LeftFingerBase")) * 0.5;
  j[9] = (head("RightHand") + tail("RightFingerBase")) * 0.5;
  j[10] = head("LeftLeg");
  j[11] = head("RightLeg");
  j[12] = head("LeftFoot");
  j[13] = head("RightFoot");
  j[14] = head("LeftToeBase");
  j[15] = head("RightToeBase");
  return j;
}

std::vector<SkinTransform> bone_skin_transforms(const HumanAssets& a, const Skeleton& rest, const Skeleton& posed,
                                               const BodyPose& pose) {
  std::vector<SkinTransform> bone(a.bones.size());
  for (size_t b = 0; b < a.bones.size(); ++b) {
    const Mat3& g = pose.bone_world[b];
    Vec3 t = posed.heads[b] - g * rest.heads[b];
    for (int i = 0; i < 9; ++i) bone[b].m[i] = float(g.m[i]);
    bone[b].m[9] = float(t.x);
    bone[b].m[10] = float(t.y);
    bone[b].m[11] = float(t.z);
  }
  return bone;
}

SkinTransform vertex_skin_transform(const HumanAssets& a, const std::vector<SkinTransform>& bones, uint32_t v) {
  SkinTransform m;
  for (uint32_t i = a.skin_offsets[v]; i < a.skin_offsets[v + 1]; ++i) {
    const SkinTransform& A = bones[a.skin_bones[i]];
    const float w = a.skin_weights[i];
    for (int k = 0; k < 12; ++k) m.m[k] += w * A.m[k];
  }
  return m;
}

void skin_body(const HumanAssets& a, const std::vector<Vec3f>& shaped, const Skeleton& rest, const Skeleton& posed,
               const BodyPose& pose, std::vector<Vec3f>& out) {
  const std::vector<SkinTransform> bones = bone_skin_transforms(a, rest, posed, pose);
  out.resize(kBodyVertexCount);
  for (int v = 0; v < kBodyVertexCount; ++v) out[v] = vertex_skin_transform(a, bones, uint32_t(v)).apply(shaped[v]);
}

std::vector<uint8_t> vertex_part_labels(const HumanAssets& a) {
  enum Segment { kHead, kNeck, kTorso, kUpperArm, kForeArm, kHand, kThigh, kShin, kFoot, kSegmentCount };
  // Segment and side of each bone.
  struct BoneClass {
    Segment segment;
    int side;  // +1 left, -1 right, 0 centre
  };
  const std::map<std::string, BoneClass> classes = {
      {"Head", {kHead, 0}},          {"Neck", {kNeck, 0}},           {"Neck1", {kNeck, 0}},
      {"Hips", {kTorso, 0}},         {"LowerBack", {kTorso, 0}},     {"Spine", {kTorso, 0}},
      {"Spine1", {kTorso, 0}},       {"LHipJoint", {kTorso, 1}},     {"RHipJoint", {kTorso, -1}},
      {"LeftShoulder", {kTorso, 1}}, {"RightShoulder", {kTorso, -1}}, {"LeftArm", {kUpperArm, 1}},
      {"RightArm", {kUpperArm, -1}}, {"LeftForeArm", {kForeArm, 1}}, {"RightForeArm", {kForeArm, -1}},
      {"LeftHand", {kHand, 1}},      {"RightHand", {kHand, -1}},     {"LeftFingerBase", {kHand, 1}},
      {"RightFingerBase", {kHand, -1}}, {"LeftHandFinger1", {kHand, 1}}, {"RightHandFinger1", {kHand, -1}},
      {"LThumb", {kHand, 1}},        {"RThumb", {kHand, -1}},        {"LeftUpLeg", {kThigh, 1}},
      {"RightUpLeg", {kThigh, -1}},  {"LeftLeg", {kShin, 1}},        {"RightLeg", {kShin, -1}},
      {"LeftFoot", {kFoot, 1}},      {"RightFoot", {kFoot, -1}},     {"LeftToeBase", {kFoot, 1}},
      {"RightToeBase", {kFoot, -1}}};
  std::vector<BoneClass> bone_class;
  for (const RigBone& b : a.bones) {
    auto it = classes.find(b.name);
    if (it == classes.end()) fail("rig bone " + b.name + " has no part class");
    bone_class.push_back(it->second);
  }
  const Skeleton s = measure_skeleton(a, a.base_vertices);
  auto head = [&](const char* n) { return s.heads[bone_or_fail(a, n)]; };
  auto tail = [&](const char* n) { return s.tails[bone_or_fail(a, n)]; };
  const double head_split_y = head("Head").y + 0.45 * (tail("Head").y - head("Head").y);
  const double torso_split_y = head("Spine").y + 0.3 * (head("Spine1").y - head("Spine").y);

  // Left-side reference points; the right side mirrors x.
  struct Limb {
    Vec3 shoulder, elbow, wrist, hand_dir, upper_dir, fore_dir, hip, knee, ankle, thigh_dir, shin_dir;
  };
  auto limb = [&](bool left) {
    auto n = [&](const char* l, const char* r) { return left ? l : r; };
    Limb L;
    L.shoulder = head(n("LeftArm", "RightArm"));
    L.elbow = head(n("LeftForeArm", "RightForeArm"));
    L.wrist = head(n("LeftHand", "RightHand"));
    L.upper_dir = (L.elbow - L.shoulder).normalized();
    L.fore_dir = (L.wrist - L.elbow).normalized();
    L.hand_dir = (tail(n("LeftFingerBase", "RightFingerBase")) - L.wrist).normalized();
    L.hip = head(n("LeftUpLeg", "RightUpLeg"));
    L.knee = head(n("LeftLeg", "RightLeg"));
    L.ankle = head(n("LeftFoot", "RightFoot"));
    L.thigh_dir = (L.knee - L.hip).normalized();
    L.shin_dir = (L.ankle - L.knee).normalized();
    return L;
  };
  const Limb limbs[2] = {limb(true), limb(false)};

  // Joint-centred part sizes (metres, on the base body).
  constexpr double kShoulderRadius = 0.085, kElbowHalf = 0.045, kWristHalf = 0.03, kKneeHalf = 0.06,
                   kAnkleRadius = 0.065, kAnkleHalf = 0.04;
  using P = int;
  std::vector<uint8_t> labels(kBodyVertexCount);
  for (int v = 0; v < kBodyVertexCount; ++v) {
    double seg_weight[kSegmentCount] = {0};
    double side_weight = 0;
    for (uint32_t i = a.skin_offsets[v]; i < a.skin_offsets[v + 1]; ++i) {
      const BoneClass& c = bone_class[a.skin_bones[i]];
      seg_weight[c.segment] += a.skin_weights[i];
      side_weight += c.side * a.skin_weights[i];
    }
    int seg = int(std::max_element(seg_weight, seg_weight + kSegmentCount) - seg_weight);
    const Vec3f& q = a.base_vertices[v];
    const Vec3 p{q.x, q.y, q.z};
    int side = a.vertex_side[v] != 0 ? a.vertex_side[v] : (p.x > 0 ? 1 : p.x < 0 ? -1 : (side_weight >= 0 ? 1 : -1));
    if (seg != kHead && seg != kNeck && seg != kTorso) side = side_weight >= 0 ? 1 : -1;  // limbs by their bones
    const bool left = side > 0;
    const Limb& L = limbs[left ? 0 : 1];
    auto lr = [&](P l) { return uint8_t(left ? l : dp::tools::kPartMirror[l]); };
    uint8_t label = 0;
    switch (seg) {
      case kHead: label = lr(p.y >= head_split_y ? 0 : 2); break;  // head_lu / head_lw
      case kNeck: label = 4; break;
      case kTorso:
        label = lr(p.y >= torso_split_y ? 17 : 19);  // torso_lu / torso_lw
        if ((p - L.shoulder).norm() < kShoulderRadius) label = lr(5);
        break;
      case kUpperArm:
        label = lr(7);
        if ((p - L.shoulder).norm() < kShoulderRadius) label = lr(5);
        if ((p - L.elbow).dot(L.upper_dir) > -kElbowHalf) label = lr(11);
        break;
      case kForeArm:
        label = lr(9);
        if ((p - L.elbow).dot(L.fore_dir) < kElbowHalf) label = lr(11);
        if ((p - L.wrist).dot(L.fore_dir) > -kWristHalf) label = lr(13);
        break;
      case kHand:
        label = lr(15);
        if ((p - L.wrist).dot(L.hand_dir) < kWristHalf * 0.5) label = lr(13);
        break;
      case kThigh:
        label = lr(21);
        if ((p - L.knee).dot(L.thigh_dir) > -kKneeHalf) label = lr(25);
        break;
      case kShin:
        label = lr(23);
        if ((p - L.knee).dot(L.shin_dir) < kKneeHalf) label = lr(25);
        if ((p - L.ankle).dot(L.shin_dir) > -kAnkleHalf) label = lr(27);
        break;
      case kFoot:
        label = lr(29);
        if ((p - L.ankle).norm() < kAnkleRadius) label = lr(27);
        break;
    }
    labels[v] = label;
  }
  return labels;
}

double pose_distance(const JointSet& a, const JointSet& b) {
  double m = 0;
  for (size_t j = 0; j < a.size(); ++j) m = std::max(m, (a[j] - b[j]).norm());
  return m;
}

std::vector<size_t> furthest_neighbour_selection_reference(const std::vector<JointSet>& items, double min_distance) {
  std::vector<size_t> selected;
  if (items.empty()) return selected;
  std::vector<double> nearest(items.size(), std::numeric_limits<double>::infinity());
  size_t next = 0;
  for (;;) {
    selected.push_back(next);
    const JointSet& s = items[next];
    size_t best = 0;
    double best_d = -1;
    for (size_t i = 0; i < items.size(); ++i) {
      double& n = nearest[i];
      if (n > 0) {
        // d >= n as soon as one joint is that far: no update needed, stop early.
        double d2max = 0, n2 = n * n;
        for (size_t j = 0; j < s.size() && d2max < n2; ++j) {
          Vec3 e = items[i][j] - s[j];
          d2max = std::max(d2max, e.dot(e));
        }
        if (d2max < n2) n = std::sqrt(d2max);
      }
      if (n > best_d) {
        best_d = n;
        best = i;
      }
    }
    if (!(best_d >= min_distance)) break;
    next = best;
  }
  return selected;
}

std::vector<size_t> furthest_neighbour_selection(const std::vector<JointSet>& items, double min_distance) {
  std::vector<size_t> selected;
  const size_t n = items.size();
  if (n == 0) return selected;
  // Every nearest-distance is at most r, the current maximum, so a new centre s can only lower
  // the items within r of it. d(i, s) >= |x_i - x_s| for any one coordinate of any joint, so a
  // grid over three coordinates (the most variable ones, from three different joints) finds
  // those items without scanning the pool.
  struct KeyAxis {
    int joint, axis;
  };
  std::vector<KeyAxis> key;
  {
    std::vector<std::pair<double, int>> variance;  // (variance, joint * 3 + axis)
    for (int j = 0; j < dp::tools::kJointCount; ++j)
      for (int ax = 0; ax < 3; ++ax) {
        double sum = 0, sum2 = 0;
        for (const JointSet& it : items) {
          const double v = ax == 0 ? it[j].x : ax == 1 ? it[j].y : it[j].z;
          sum += v;
          sum2 += v * v;
        }
        variance.push_back({sum2 / double(n) - (sum / double(n)) * (sum / double(n)), j * 3 + ax});
      }
    std::sort(variance.begin(), variance.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    for (const auto& [var, code] : variance) {
      bool joint_used = false;
      for (const KeyAxis& k : key) joint_used = joint_used || k.joint == code / 3;
      if (!joint_used) key.push_back({code / 3, code % 3});
      if (key.size() == 3) break;
    }
  }
  auto key_value = [&](size_t i, int k) {
    const Vec3& p = items[i][key[size_t(k)].joint];
    return key[size_t(k)].axis == 0 ? p.x : key[size_t(k)].axis == 1 ? p.y : p.z;
  };
  const double cell = std::max(min_distance, 0.01);
  struct Cell {
    int x, y, z;
    std::vector<uint32_t> members;
  };
  std::vector<Cell> cells;
  std::map<std::array<int, 3>, size_t> cell_of;
  for (size_t i = 0; i < n; ++i) {
    const std::array<int, 3> c = {int(std::floor(key_value(i, 0) / cell)), int(std::floor(key_value(i, 1) / cell)),
                                  int(std::floor(key_value(i, 2) / cell))};
    auto it = cell_of.find(c);
    if (it == cell_of.end()) {
      it = cell_of.emplace(c, cells.size()).first;
      cells.push_back({c[0], c[1], c[2], {}});
    }
    cells[it->second].members.push_back(uint32_t(i));
  }
  // Pool copy in cell order (a cell's members are contiguous in memory), joints ordered from the
  // most variable down, so the early-out below usually stops at the first joint. The maximum over
  // joints does not depend on their order: distances are exactly those of the plain scan.
  std::vector<int> joint_order(dp::tools::kJointCount);
  {
    std::vector<std::pair<double, int>> spread;
    for (int j = 0; j < dp::tools::kJointCount; ++j) {
      Vec3 mean;
      for (const JointSet& it : items) mean += it[j];
      mean = mean * (1.0 / double(n));
      double var = 0;
      for (const JointSet& it : items) var += (it[j] - mean).dot(it[j] - mean);
      spread.push_back({-var, j});
    }
    std::sort(spread.begin(), spread.end());
    for (int j = 0; j < dp::tools::kJointCount; ++j) joint_order[size_t(j)] = spread[size_t(j)].second;
  }
  std::vector<JointSet> packed(n);
  std::vector<uint32_t> packed_index(n);  // packed slot -> item
  std::vector<uint32_t> slot_of(n);       // item -> packed slot
  {
    size_t slot = 0;
    for (Cell& k : cells) {
      for (uint32_t& i : k.members) {
        for (int j = 0; j < dp::tools::kJointCount; ++j) packed[slot][size_t(j)] = items[i][size_t(joint_order[size_t(j)])];
        packed_index[slot] = i;
        slot_of[i] = uint32_t(slot);
        i = uint32_t(slot++);
      }
    }
  }
  std::vector<double> nearest(n, std::numeric_limits<double>::infinity());  // by packed slot
  // Max-heap of (nearest distance, -index): the largest distance, then the smallest index, as
  // the plain scan picks. Entries go stale when an item's distance drops; they are skipped.
  using Entry = std::pair<double, int64_t>;
  std::priority_queue<Entry> heap;
  auto update = [&](size_t slot, const JointSet& s) {
    double& m = nearest[slot];
    if (!(m > 0)) return;
    double d2max = 0;
    const double m2 = m * m;
    const JointSet& it = packed[slot];
    for (size_t j = 0; j < s.size() && d2max < m2; ++j) {
      const Vec3 e = it[j] - s[j];
      d2max = std::max(d2max, e.dot(e));
    }
    if (d2max < m2) {
      m = std::sqrt(d2max);
      heap.push({m, -int64_t(packed_index[slot])});
    }
  };
  // An item whose nearest distance fell below min_distance can never be selected (distances only
  // fall, and the selection stops once the largest is below min_distance), so its distance no
  // longer matters: it leaves its cell's member list the first time a scan sees it there. Late
  // in the selection nearly every item is covered, and the scans touch only the few that are not.
  // The selection is unchanged: every item that can still be selected is updated as before.
  auto scan_cell = [&](Cell& k, const JointSet& s) {
    std::vector<uint32_t>& m = k.members;
    for (size_t t = 0; t < m.size();) {
      update(m[t], s);
      if (nearest[m[t]] < min_distance) {
        m[t] = m.back();
        m.pop_back();
      } else {
        ++t;
      }
    }
  };
  size_t next = 0;
  double radius = std::numeric_limits<double>::infinity();
  for (;;) {
    selected.push_back(next);
    nearest[slot_of[next]] = 0;
    const JointSet s = packed[slot_of[next]];
    // The cells that can hold an item within `radius` of s: along each key coordinate, those
    // meeting [v - radius, v + radius] (widened by a nanometre against rounding), 2-3 cells once
    // the radius nears the cell size.
    const bool bounded = std::isfinite(radius);
    std::array<int, 3> lo{}, hi{};
    double box_cells = bounded ? 1 : 1e300;
    for (int k = 0; k < 3 && bounded; ++k) {
      const double v = key_value(next, k), r = radius + 1e-9;
      lo[size_t(k)] = int(std::floor((v - r) / cell));
      hi[size_t(k)] = int(std::floor((v + r) / cell));
      box_cells *= double(hi[size_t(k)] - lo[size_t(k)] + 1);
    }
    if (!bounded || box_cells > double(cells.size())) {
      for (Cell& k : cells)
        if (!bounded || (k.x >= lo[0] && k.x <= hi[0] && k.y >= lo[1] && k.y <= hi[1] && k.z >= lo[2] && k.z <= hi[2]))
          scan_cell(k, s);
    } else {
      for (int x = lo[0]; x <= hi[0]; ++x)
        for (int y = lo[1]; y <= hi[1]; ++y)
          for (int z = lo[2]; z <= hi[2]; ++z) {
            auto it = cell_of.find({x, y, z});
            if (it != cell_of.end()) scan_cell(cells[it->second], s);
          }
    }
    while (!heap.empty() && heap.top().first != nearest[slot_of[size_t(-heap.top().second)]]) heap.pop();
    if (heap.empty() || !(heap.top().first >= min_distance)) break;
    radius = heap.top().first;
    next = size_t(-heap.top().second);
    heap.pop();
  }
  return selected;
}

PoseLibrary build_pose_library(const HumanAssets& a, const std::vector<MotionClip>& clips, double min_distance,
                               bool keep_order) {
  const Skeleton rest = measure_skeleton(a, a.base_vertices);
  const int hips = bone_or_fail(a, "Hips");
  std::vector<BodyPose> candidates;
  std::vector<std::string> origin;
  std::vector<JointSet> joints;
  for (const MotionClip& c : clips) {
    for (size_t k = 0; k < c.frames.size(); ++k) {
      BodyPose p = retarget_frame(a, rest, c, k);
      Skeleton s = pose_skeleton(a, rest, p);
      JointSet j = joints_of(a, s);
      for (Vec3& x : j) x = x - s.heads[hips];
      candidates.push_back(std::move(p));
      joints.push_back(j);
      origin.push_back(c.name + ":" + std::to_string(k * c.frame_stride));
    }
  }
  PoseLibrary lib;
  lib.candidate_count = candidates.size();
  if (keep_order) {
    lib.poses = std::move(candidates);
    lib.origin = std::move(origin);
    return lib;
  }
  for (size_t i : furthest_neighbour_selection(joints, min_distance)) {
    lib.poses.push_back(std::move(candidates[i]));
    lib.origin.push_back(origin[i]);
  }
  return lib;
}

}  // namespace dp::synth
