// Retargeting CMU motion onto the cmu_mb rig, posing (linear blend skinning), the 16 output
// joints, the per-vertex part labels, and the pose library (furthest-neighbour pruning).
//
// A BodyPose is, per rig bone, the world rotation G_b taking the bone from the A-pose rest to its
// posed orientation (mesh frame: y up, rest facing +z). Bones rotate about their heads; the Hips
// head stays at its rest position. G_b = Q_b * K_b * T_b where T_b is the A->T correction
// (t-pose.json), K_b the smallest rotation taking our T-pose bone direction onto the clip's rest
// direction (e.g. CMU's 20-degree leg splay), and Q_b the clip's world rotation of that segment.
// The clip's heading (yaw of the hips) is removed, so every pose faces +z; tilt is kept.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "tools/common/body_model.h"
#include "tools/synth/human_model.h"
#include "tools/synth/motion.h"

namespace dp::synth {

struct BodyPose {
  std::vector<Mat3> bone_world;  // one per HumanAssets::bones entry
};

using JointSet = std::array<Vec3, dp::tools::kJointCount>;  // metres, meta joint order

// The rest pose (all identity), i.e. the A-pose.
BodyPose rest_pose(const HumanAssets& assets);
// The T-pose (tpose_world), the neutral pose of the motion data.
BodyPose t_pose(const HumanAssets& assets);

// Pose for frame k (index into clip.frames) of a clip.
BodyPose retarget_frame(const HumanAssets& assets, const Skeleton& rest, const MotionClip& clip, size_t k);

// Posed bone heads/tails (Hips head fixed at its rest position).
Skeleton pose_skeleton(const HumanAssets& assets, const Skeleton& rest, const BodyPose& pose);
// The 16 joints (kJointNames order; the rig point each one is: posing.cc) on a posed skeleton.
JointSet joints_of(const HumanAssets& assets, const Skeleton& posed);

// An affine map in float: m[0..8] the 3x3 linear part (row-major), m[9..11] the translation.
struct SkinTransform {
  float m[12] = {0};
  Vec3f apply(const Vec3f& p) const {
    return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[9], m[3] * p.x + m[4] * p.y + m[5] * p.z + m[10],
            m[6] * p.x + m[7] * p.y + m[8] * p.z + m[11]};
  }
  Vec3f rotate(const Vec3f& d) const {
    return {m[0] * d.x + m[1] * d.y + m[2] * d.z, m[3] * d.x + m[4] * d.y + m[5] * d.z,
            m[6] * d.x + m[7] * d.y + m[8] * d.z};
  }
};
// Per bone: rest -> posed, x' = G_b (x - rest head) + posed head.
std::vector<SkinTransform> bone_skin_transforms(const HumanAssets& assets, const Skeleton& rest, const Skeleton& posed,
                                               const BodyPose& pose);
// Linear blend of the bone transforms by vertex v's skin weights (any mesh vertex, helpers too;
// all zero for a vertex without weights).
SkinTransform vertex_skin_transform(const HumanAssets& assets, const std::vector<SkinTransform>& bones, uint32_t v);

// Linear blend skinning of the body vertices (first kBodyVertexCount of `shaped`). `out` is
// resized to kBodyVertexCount.
void skin_body(const HumanAssets& assets, const std::vector<Vec3f>& shaped, const Skeleton& rest,
               const Skeleton& posed, const BodyPose& pose, std::vector<Vec3f>& out);

// Part id (0..30, body_model.h order) per body vertex, from the rest mesh: our fixed rule
// (dominant skin-weight segment, the Left/Right groups, planes and radii around the joints;
// docs/parts.md). The same table serves every shape and pose.
std::vector<uint8_t> vertex_part_labels(const HumanAssets& assets);

// Furthest-neighbour (farthest-point) selection: starts from item 0 and repeatedly adds the item
// farthest (d = max over joints of Euclidean distance) from everything selected, until that
// distance is below `min_distance`. Returns the selected indices in selection order. Every
// unselected item is then within min_distance of a selected one.
// Runs in about (poses kept) x (poses within the current radius) distance tests: a grid over the
// most variable joint bounds which poses a new selection can move closer (docs/synthetic_data.md
// has the time on the full CMU pool). Gives exactly the selection of the plain O(N x kept) scan,
// furthest_neighbour_selection_reference, which the tests compare it with.
std::vector<size_t> furthest_neighbour_selection(const std::vector<JointSet>& items, double min_distance);
std::vector<size_t> furthest_neighbour_selection_reference(const std::vector<JointSet>& items, double min_distance);
double pose_distance(const JointSet& a, const JointSet& b);

struct PoseLibrary {
  std::vector<BodyPose> poses;
  std::vector<std::string> origin;   // "02_01:240" (clip, source frame)
  size_t candidate_count = 0;        // sampled frames before pruning
};
// Samples every clip frame present (clips are already stride-sampled), measures joints relative
// to the hips on the base body, and keeps the furthest-neighbour selection at `min_distance` m.
// keep_order: keep every frame in clip order instead (synth --sequence).
PoseLibrary build_pose_library(const HumanAssets& assets, const std::vector<MotionClip>& clips, double min_distance,
                               bool keep_order = false);

}  // namespace dp::synth
