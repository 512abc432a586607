#include "tools/synth/pose_pool.h"

#include <algorithm>
#include <bitset>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>

#include "tools/common/error.h"
#include "tools/synth/random.h"

namespace dp::synth {
using dp::tools::fail;

namespace {

// Largest noise angle per bone class (degrees, uniform in [-limit, +limit] about a random axis;
// hinges about their axis). Chosen to move hands and feet by a few centimetres to ~10 cm, the
// scale of D_pose, so noise copies fill gaps between captured poses rather than invent new ones.
struct NoiseLimit {
  const char* bone;
  double degrees;
  bool hinge;
};
constexpr NoiseLimit kNoiseLimitsDeg[] = {
    {"LowerBack", 5, false},    {"Spine", 5, false},         {"Spine1", 5, false},      {"Neck", 8, false},
    {"Head", 10, false},        {"LeftShoulder", 5, false},  {"RightShoulder", 5, false}, {"LeftArm", 15, false},
    {"RightArm", 15, false},    {"LeftForeArm", 15, true},   {"RightForeArm", 15, true}, {"LeftHand", 15, false},
    {"RightHand", 15, false},   {"LeftUpLeg", 10, false},    {"RightUpLeg", 10, false}, {"LeftLeg", 12, true},
    {"RightLeg", 12, true},     {"LeftFoot", 10, false},     {"RightFoot", 10, false}};
constexpr int kNoiseDraws = 8;

// Direction grid on the unit sphere: 6-degree cells in polar angle and azimuth.
constexpr int kThetaCells = 30, kPhiCells = 60;
using DirectionCells = std::bitset<kThetaCells * kPhiCells>;
int direction_cell(const Vec3& d) {
  const double theta = std::acos(std::clamp(d.z, -1.0, 1.0));
  const double phi = std::atan2(d.y, d.x) + M_PI;
  const int t = std::min(kThetaCells - 1, int(theta / M_PI * kThetaCells));
  const int p = std::min(kPhiCells - 1, int(phi / (2 * M_PI) * kPhiCells));
  return t * kPhiCells + p;
}
DirectionCells grown(const DirectionCells& c) {
  DirectionCells out;
  for (int t = 0; t < kThetaCells; ++t)
    for (int p = 0; p < kPhiCells; ++p) {
      if (!c[size_t(t * kPhiCells + p)]) continue;
      for (int dt = -1; dt <= 1; ++dt)
        for (int dp = -1; dp <= 1; ++dp) {
          const int tt = t + dt;
          if (tt < 0 || tt >= kThetaCells) continue;
          out.set(size_t(tt * kPhiCells + (p + dp + kPhiCells) % kPhiCells));
        }
    }
  return out;
}

std::string mirrored_name(const std::string& n) {
  if (n.rfind("Left", 0) == 0) return "Right" + n.substr(4);
  if (n.rfind("Right", 0) == 0) return "Left" + n.substr(5);
  if (n.size() > 1 && (n[0] == 'L' || n[0] == 'R') && std::isupper(static_cast<unsigned char>(n[1])))
    return std::string(1, n[0] == 'L' ? 'R' : 'L') + n.substr(1);
  return n;
}

bool is_lower_body(const std::string& n) {
  for (const char* b : {"Hips", "LHipJoint", "RHipJoint", "LeftUpLeg", "RightUpLeg", "LeftLeg", "RightLeg", "LeftFoot",
                        "RightFoot", "LeftToeBase", "RightToeBase"})
    if (n == b) return true;
  return false;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// CPU time of the calling thread (seconds): the pruning figure stays meaningful on a busy machine.
double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace

const char* pose_kind_name(PoseKind k) {
  switch (k) {
    case PoseKind::kReal: return "real";
    case PoseKind::kMirror: return "mirror";
    case PoseKind::kNoise: return "noise";
    case PoseKind::kRecombined: return "recombined";
  }
  return "?";
}

BodyPose mirror_pose(const HumanAssets& a, const BodyPose& pose) {
  Mat3 s;
  s.m = {-1, 0, 0, 0, 1, 0, 0, 0, 1};
  BodyPose out;
  out.bone_world.resize(a.bones.size());
  for (size_t b = 0; b < a.bones.size(); ++b) {
    const int m = a.bone_index(mirrored_name(a.bones[b].name));
    if (m < 0) fail("rig bone " + a.bones[b].name + " has no mirror partner");
    out.bone_world[b] = s * pose.bone_world[size_t(m)] * s;
  }
  return out;
}

JointSet aligned_joints(const HumanAssets& a, const Skeleton& rest, const BodyPose& pose) {
  const Skeleton s = pose_skeleton(a, rest, pose);
  JointSet j = joints_of(a, s);
  const Vec3 hips = s.heads[size_t(a.bone_index("Hips"))];
  for (Vec3& x : j) x = x - hips;
  return j;
}

RealPoses retarget_pool(const HumanAssets& a, const std::vector<MotionClip>& clips,
                        const std::vector<std::string>& categories) {
  if (categories.size() != clips.size()) fail("pose pool: one category per clip expected");
  const auto t0 = std::chrono::steady_clock::now();
  const Skeleton rest = measure_skeleton(a, a.base_vertices);
  RealPoses real;
  std::map<std::string, size_t> category_row;
  for (size_t c = 0; c < clips.size(); ++c) {
    category_row[categories[c].empty() ? "(none)" : categories[c]] = 0;
    for (size_t k = 0; k < clips[c].frames.size(); ++k) {
      real.poses.push_back(retarget_frame(a, rest, clips[c], k));
      real.origin.push_back(clips[c].name + ":" + std::to_string(k * size_t(clips[c].frame_stride)));
      real.clip_of.push_back(int(c));
    }
  }
  for (auto& [name, row] : category_row) {
    row = real.categories.size();
    real.categories.push_back({name});
  }
  for (size_t c = 0; c < clips.size(); ++c) {
    const size_t row = category_row[categories[c].empty() ? "(none)" : categories[c]];
    real.category_of_clip.push_back(int(row));
    PosePoolReport::Category& r = real.categories[row];
    r.clips++;
    r.source_frames += clips[c].source_frame_count;
    r.sampled += clips[c].frames.size();
  }
  real.retarget_seconds = seconds_since(t0);
  return real;
}

PoseLibrary build_pose_pool(const HumanAssets& a, const std::vector<MotionClip>& clips,
                            const std::vector<std::string>& categories, const PoseVariation& v, double min_distance,
                            PosePoolReport* report) {
  return build_pose_pool(a, retarget_pool(a, clips, categories), v, min_distance, report);
}

PoseLibrary build_pose_pool(const HumanAssets& a, RealPoses real, const PoseVariation& v, double min_distance,
                            PosePoolReport* report) {
  if (v.noise_copies < 0 || v.noise_copies > 4) fail("pose pool: noise copies must be 0..4");
  if (!(v.recombined_per_pose >= 0 && v.recombined_per_pose <= 4)) fail("pose pool: recombined per pose must be 0..4");
  if (!(v.noise_scale >= 0 && v.noise_scale <= 2)) fail("pose pool: noise scale must be 0..2");
  const size_t real_count = real.poses.size();
  if (real.origin.size() != real_count || real.clip_of.size() != real_count)
    fail("pose pool: real poses, origins and clips differ in count");
  for (const int c : real.clip_of)
    if (c < 0 || size_t(c) >= real.category_of_clip.size()) fail("pose pool: a real pose names no clip");
  for (const int row : real.category_of_clip)
    if (row < 0 || size_t(row) >= real.categories.size()) fail("pose pool: a clip names no category");
  PosePoolReport local;
  PosePoolReport& r = report ? *report : local;
  r = PosePoolReport{};
  r.categories = real.categories;
  r.retarget_seconds = real.retarget_seconds;
  const size_t clip_count = real.category_of_clip.size();
  const Skeleton rest = measure_skeleton(a, a.base_vertices);
  const size_t bones = a.bones.size();
  for (const BodyPose& p : real.poses)
    if (p.bone_world.size() != bones) fail("pose pool: a real pose has another bone count than the rig");

  std::vector<BodyPose> poses = std::move(real.poses);
  std::vector<std::string> origin = std::move(real.origin);
  std::vector<PoseKind> kind(real_count, PoseKind::kReal);
  std::vector<int> clip_of = std::move(real.clip_of);

  // Variation.
  auto t0 = std::chrono::steady_clock::now();
  std::vector<Vec3> rest_dir(bones);
  for (size_t b = 0; b < bones; ++b) rest_dir[b] = (rest.tails[b] - rest.heads[b]).normalized();
  auto local_direction = [&](const BodyPose& p, size_t b) {
    const int parent = a.bones[b].parent;
    const Mat3 local = parent < 0 ? p.bone_world[b] : p.bone_world[size_t(parent)].transposed() * p.bone_world[b];
    return local * rest_dir[b];
  };
  if (v.mirror)
    for (size_t i = 0; i < real_count; ++i) {
      poses.push_back(mirror_pose(a, poses[i]));
      origin.push_back(origin[i] + " mirror");
      kind.push_back(PoseKind::kMirror);
      clip_of.push_back(clip_of[i]);
    }
  if (v.noise_copies > 0) {
    struct Noisy {
      size_t bone;
      double limit;
      bool hinge;
      Vec3 hinge_axis;  // rest frame
    };
    std::vector<Noisy> noisy;
    for (const NoiseLimit& n : kNoiseLimitsDeg) {
      const int b = a.bone_index(n.bone);
      if (b < 0) fail(std::string("rig lacks bone ") + n.bone);
      Vec3 axis{1, 0, 0};  // knees: flexion about the body's left-right axis
      if (std::string(n.bone).find("ForeArm") != std::string::npos)
        axis = rest_dir[size_t(b)].cross(Vec3{0, 0, 1}).normalized();  // elbow: in the frontal plane
      noisy.push_back({size_t(b), n.degrees * kDegToRad * v.noise_scale, n.hinge, axis});
    }
    // The direction limits: every real pose's local bone directions (both sides when mirrored
    // poses are in the pool too), grown by one cell.
    std::vector<DirectionCells> allowed(bones);
    for (size_t i = 0; i < poses.size(); ++i)
      for (const Noisy& n : noisy) allowed[n.bone].set(size_t(direction_cell(local_direction(poses[i], n.bone))));
    for (const Noisy& n : noisy) allowed[n.bone] = grown(allowed[n.bone]);
    std::vector<int> order_index(bones, -1);
    for (size_t i = 0; i < noisy.size(); ++i) order_index[noisy[i].bone] = int(i);
    for (size_t i = 0; i < real_count; ++i)
      for (int copy = 0; copy < v.noise_copies; ++copy) {
        Rng rng = Rng::for_frame(v.seed, i, 100 + uint64_t(copy));
        bool kept = false;
        BodyPose out;
        for (int draw = 0; draw < kNoiseDraws && !kept; ++draw) {
          const BodyPose& src = poses[i];
          out.bone_world.assign(bones, Mat3::identity());
          for (size_t b = 0; b < bones; ++b) {  // parents first
            const int parent = a.bones[b].parent;
            Mat3 m = parent < 0 ? src.bone_world[b]
                                : out.bone_world[size_t(parent)] * src.bone_world[size_t(parent)].transposed() *
                                      src.bone_world[b];
            if (order_index[b] >= 0) {
              const Noisy& n = noisy[size_t(order_index[b])];
              Vec3 axis;
              if (n.hinge) {
                axis = m * n.hinge_axis;
              } else {
                do axis = {rng.gaussian(), rng.gaussian(), rng.gaussian()};
                while (axis.norm() < 1e-6);
              }
              m = rot_axis(axis.normalized(), rng.uniform(-n.limit, n.limit)) * m;
            }
            out.bone_world[b] = m;
          }
          kept = true;
          for (const Noisy& n : noisy)
            kept = kept && allowed[n.bone][size_t(direction_cell(local_direction(out, n.bone)))];
          if (!kept) r.noise_rejected++;
        }
        if (!kept) {
          r.noise_dropped++;
          continue;
        }
        poses.push_back(std::move(out));
        origin.push_back(origin[i] + " noise " + std::to_string(copy + 1));
        kind.push_back(PoseKind::kNoise);
        clip_of.push_back(clip_of[i]);
      }
  }
  if (v.recombined_per_pose > 0 && real_count > 1) {
    const size_t count = size_t(std::llround(v.recombined_per_pose * double(real_count)));
    const size_t hips = size_t(a.bone_index("Hips"));
    std::vector<char> lower(bones);
    for (size_t b = 0; b < bones; ++b) lower[b] = is_lower_body(a.bones[b].name);
    Rng rng = Rng::for_frame(v.seed, 0, 200);
    for (size_t k = 0; k < count; ++k) {
      const size_t i = size_t(rng.below(real_count));
      size_t j = size_t(rng.below(real_count));
      for (int tries = 0; tries < 8 && clip_of[j] == clip_of[i] && clip_count > 1; ++tries)
        j = size_t(rng.below(real_count));
      BodyPose out;
      out.bone_world.resize(bones);
      const Mat3 reattach = poses[i].bone_world[hips] * poses[j].bone_world[hips].transposed();
      for (size_t b = 0; b < bones; ++b)
        out.bone_world[b] = lower[b] ? poses[i].bone_world[b] : reattach * poses[j].bone_world[b];
      poses.push_back(std::move(out));
      origin.push_back(origin[i] + "+" + origin[j]);
      kind.push_back(PoseKind::kRecombined);
      clip_of.push_back(clip_of[i]);
    }
  }
  r.variation_seconds = seconds_since(t0);
  for (PoseKind k : kind) r.generated[int(k)]++;

  // Pruning.
  t0 = std::chrono::steady_clock::now();
  const double cpu0 = thread_cpu_seconds();
  std::vector<JointSet> joints(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) joints[i] = aligned_joints(a, rest, poses[i]);
  std::vector<size_t> keep;
  if (min_distance > 0) {
    keep = furthest_neighbour_selection(joints, min_distance);
  } else {
    keep.resize(poses.size());
    for (size_t i = 0; i < keep.size(); ++i) keep[i] = i;
  }
  r.prune_seconds = seconds_since(t0);
  r.prune_cpu_seconds = thread_cpu_seconds() - cpu0;
  PoseLibrary lib;
  lib.candidate_count = poses.size();
  for (size_t i = 0; i < poses.size(); ++i) r.categories[size_t(real.category_of_clip[size_t(clip_of[i])])].pooled++;
  for (size_t i : keep) {
    r.kept[int(kind[i])]++;
    PosePoolReport::Category& row = r.categories[size_t(real.category_of_clip[size_t(clip_of[i])])];
    row.pooled_kept++;
    if (kind[i] == PoseKind::kReal) row.kept++;
    lib.poses.push_back(std::move(poses[i]));
    lib.origin.push_back(std::move(origin[i]));
  }
  return lib;
}

std::string format_pose_pool_report(const PosePoolReport& r, double min_distance) {
  std::string out;
  char line[256];
  // sampled/kept: the category's real poses; pool/pool kept: its poses of every kind (a mirror,
  // noise copy or recombination counts in the category of the clip it comes from).
  std::snprintf(line, sizeof line, "%-44s %6s %9s %9s %9s %9s %9s\n", "category", "clips", "frames", "sampled", "kept",
                "pool", "pool kept");
  out += line;
  PosePoolReport::Category total{"total"};
  for (const auto& c : r.categories) {
    std::snprintf(line, sizeof line, "%-44s %6d %9ld %9zu %9zu %9zu %9zu\n", c.name.substr(0, 44).c_str(), c.clips,
                  c.source_frames, c.sampled, c.kept, c.pooled, c.pooled_kept);
    out += line;
    total.clips += c.clips;
    total.source_frames += c.source_frames;
    total.sampled += c.sampled;
    total.kept += c.kept;
    total.pooled += c.pooled;
    total.pooled_kept += c.pooled_kept;
  }
  std::snprintf(line, sizeof line, "%-44s %6d %9ld %9zu %9zu %9zu %9zu\n", "total", total.clips, total.source_frames,
                total.sampled, total.kept, total.pooled, total.pooled_kept);
  out += line;
  for (int k = 0; k < kPoseKindCount; ++k) {
    std::snprintf(line, sizeof line, "poses %-11s %9zu before pruning, %9zu kept\n", pose_kind_name(PoseKind(k)),
                  r.generated[k], r.kept[k]);
    out += line;
  }
  size_t generated = 0, kept = 0;
  for (int k = 0; k < kPoseKindCount; ++k) {
    generated += r.generated[k];
    kept += r.kept[k];
  }
  std::snprintf(line, sizeof line,
                "pool: %zu poses -> %zu after furthest-neighbour pruning at D_pose = %.0f mm "
                "(noise draws outside the limits: %zu, copies dropped: %zu)\n",
                generated, kept, min_distance * 1000, r.noise_rejected, r.noise_dropped);
  out += line;
  std::snprintf(line, sizeof line, "time: retarget %.1f s, variation %.1f s, pruning %.1f s (%.1f s CPU)\n",
                r.retarget_seconds, r.variation_seconds, r.prune_seconds, r.prune_cpu_seconds);
  out += line;
  return out;
}

}  // namespace dp::synth
