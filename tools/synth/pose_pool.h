// The pose pool: every sampled mocap frame of the selected clips, optionally widened by synthetic
// variation that stays human, pruned to distinct poses by furthest-neighbour selection (the
// paper's D_pose = 5 cm on the 16 joints after aligning the hips).
//
// Variation (all deterministic from PoseVariation::seed):
// - mirror: the left/right mirror image of every real pose (bones swapped, rotations reflected
//   in x). Rendering also mirrors half the frames; mirroring in the pool lets pruning see both.
// - rotation noise: copies of real poses with a random rotation added to the spine, neck, head,
//   clavicles, upper arms, forearms, hands, thighs, shins and feet, each at most its class's
//   angle (kNoiseLimitsDeg in pose_pool.cc); elbows and knees turn only about their hinge axis.
//   A copy is kept only if every perturbed bone still points, relative to its parent, in a
//   direction the real mocap reaches (a 6-degree direction grid per bone, filled from every
//   real pose and grown by one cell): the data are the anatomical limits. Copies that leave
//   them are drawn again (up to 8 times) and dropped after that.
// - recombination: the lower body (hips, legs) of one real pose with the upper body (spine up)
//   of a real pose from another clip, the upper body kept relative to its own hips.
//
// Pose kinds are reported separately, so the pool report shows what each source contributed.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "tools/synth/human_model.h"
#include "tools/synth/motion.h"
#include "tools/synth/posing.h"

namespace dp::synth {

struct PoseVariation {
  bool mirror = false;
  int noise_copies = 0;               // rotation-noise copies per real pose (0..4)
  double recombined_per_pose = 0;     // recombined poses per real pose (0..4)
  double noise_scale = 1.0;           // multiplies every class's noise angle (0..2)
  uint64_t seed = 1;
  bool any() const { return mirror || noise_copies > 0 || recombined_per_pose > 0; }
};

enum class PoseKind : uint8_t { kReal = 0, kMirror = 1, kNoise = 2, kRecombined = 3 };
constexpr int kPoseKindCount = 4;
const char* pose_kind_name(PoseKind k);  // "real", "mirror", "noise", "recombined"

struct PosePoolReport {
  struct Category {
    std::string name;
    int clips = 0;
    long source_frames = 0;   // frames in the files
    size_t sampled = 0;       // real poses before pruning (after the frame stride)
    size_t kept = 0;          // real poses kept
    size_t pooled = 0;        // poses of every kind before pruning (a variant counts in its source's category)
    size_t pooled_kept = 0;   // poses of every kind kept
  };
  std::vector<Category> categories;       // sorted by name
  size_t generated[kPoseKindCount] = {};  // before pruning, per kind
  size_t kept[kPoseKindCount] = {};
  size_t noise_rejected = 0;              // noise draws outside the direction limits (drawn again)
  size_t noise_dropped = 0;               // noise copies dropped after kNoiseDraws rejections
  double retarget_seconds = 0, variation_seconds = 0, prune_seconds = 0;  // wall time
  double prune_cpu_seconds = 0;                                           // CPU time of the pruning thread
};

// The real poses of a pool: every sampled frame of the clips retargeted onto the rig, in clip
// order, with what the variation, the pruning and the report need of the clips. It depends on the
// clips, the frame stride and the human assets only, never on the variation seed, so one set
// serves every shard of a corpus (pose_cache.h stores it in a file).
struct RealPoses {
  std::vector<BodyPose> poses;
  std::vector<std::string> origin;                   // "CLIP:FRAME"
  std::vector<int> clip_of;                          // index of the pose's clip
  std::vector<int> category_of_clip;                 // per clip: its row of `categories`
  std::vector<PosePoolReport::Category> categories;  // sorted by name; kept = 0
  double retarget_seconds = 0;                       // wall time of retarget_pool
};

// categories[i] names clips[i]'s category ("" = "(none)").
RealPoses retarget_pool(const HumanAssets& assets, const std::vector<MotionClip>& clips,
                        const std::vector<std::string>& categories);

// The pool from its real poses: variation (seeded by variation.seed), then furthest-neighbour
// pruning at min_distance metres (0 keeps every pose). The library's origin strings are
// "CLIP:FRAME" for real poses and carry a suffix for the others ("02_01:240 mirror",
// "02_01:240 noise 1", "02_01:240+07_03:88"). Equal real poses give the same pool bit for bit,
// whether they were just retargeted or read back from a pose cache.
PoseLibrary build_pose_pool(const HumanAssets& assets, RealPoses real, const PoseVariation& variation,
                            double min_distance, PosePoolReport* report = nullptr);
// retarget_pool, then the above.
PoseLibrary build_pose_pool(const HumanAssets& assets, const std::vector<MotionClip>& clips,
                            const std::vector<std::string>& categories, const PoseVariation& variation,
                            double min_distance, PosePoolReport* report = nullptr);

// The mirror image of a pose (left and right bones swapped, reflected in x).
BodyPose mirror_pose(const HumanAssets& assets, const BodyPose& pose);

// Joints relative to the hips head on the base body (what pruning compares).
JointSet aligned_joints(const HumanAssets& assets, const Skeleton& rest, const BodyPose& pose);

// Printable table of the report (one row per category, then per kind, then the times).
std::string format_pose_pool_report(const PosePoolReport& report, double min_distance);

}  // namespace dp::synth
