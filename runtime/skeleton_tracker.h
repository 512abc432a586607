// dp::SkeletonTracker: from per-frame joint proposals (Pipeline::process / process_user) to one
// skeleton per user that fits a body — the "downstream kinematic tracker" the forest leaves to others.
//
// Per user and frame (update()):
//   candidates  each joint's first max_candidates proposals and, for a left or right joint, those
//               of the same joint on the other side (at a cost), plus its last position (a
//               prediction, when the user was seen before), plus "absent".
//   choice      a dynamic program over the joint tree (neck at the root; head; shoulder → elbow →
//               wrist → hand; neck → knee → ankle → foot), conditioned on each pair of shoulder
//               candidates, minimises the sum of
//                 - proposal cost: −log(confidence / first proposal's confidence), weighted;
//                 - continuity: squared distance to the joint's last position over the motion scale,
//                   weighted by that position's reported confidence over the best tracked class's;
//                 - bone cost: squared deviation of each bone's length from this user's estimate;
//                 - side cost: a left joint on the right of the torso's mid-plane (or the
//                   reverse), the mid-plane being the one of the shoulder pair;
//                 - facing cost: the torso's facing (up × (shoulder_l − shoulder_r)) turning away
//                   from its last direction, or facing away from the camera on a new user.
//               The costs and their weights are declared once in skeleton_tracker.cc.
//   bones       each user's bone lengths are the median of the last kBoneSamples lengths measured
//               between two tracked joints; until kBoneSamplesTrusted exist, generic adult lengths
//               with a wide tolerance stand in.
//   states      tracked: the chosen proposal fits its parent bone; inferred: a prediction was chosen,
//               or a proposal that does not fit its bone; missing: no proposal and no history.
//   confidence  in [0, 1], calibrated: of the joints reported at confidence c, about a fraction c
//               lie within 0.1 m of the truth (a table per forest method fitted on validation
//               sequences; its error on held-out synthetic sequences in docs/skeleton.md).
//   filter      each reported joint goes through its JointFilter (skeleton_filter.h); a tracked joint
//               that fits well is kept within the filter's max_offset_m of its chosen proposal
//               (JointFilter::limit_offset; kFilterLimitMinEvidence in skeleton_tracker.cc).
//   bones       a quaternion per bone from the filtered joints (Skeleton::bone_rotation).
//
// Contract (firmware style, as dp::Pipeline): the tracker is a fixed-size object (state for
// kMaxUsers users is a member array) with no arena and no allocation; init() validates the config
// and the blob's joint set; update() runs a bounded amount of work (max_candidates ≤ kMaxProposals,
// so C ≤ 2·kMaxProposals + 2 candidates per joint: the shoulder pairs cost O(C² · 15 · C²)
// additions, the two limb-pair chains O(6 · C⁴)); no exceptions.
// Units: metres in the camera frame (runtime/depthpose.h); y is treated as "up" for the facing.
#pragma once
#include <stdint.h>

#include "runtime/depthpose.h"
#include "runtime/segmentation/segmentation_result.h"
#include "runtime/segmentation/segmenter_config.h"
#include "runtime/skeleton_filter.h"

namespace dp {

// The joint set the tracker knows (docs/dataset_format.md), in this order.
enum SkeletonJoint : int32_t {
  kHead = 0, kNeck, kShoulderL, kShoulderR, kElbowL, kElbowR, kWristL, kWristR, kHandL, kHandR,
  kKneeL, kKneeR, kAnkleL, kAnkleR, kFootL, kFootR, kSkeletonJoints
};
static_assert(kSkeletonJoints <= kMaxJoints, "the skeleton fits a FrameResult");
// Tree parent of each joint (−1 for the neck, the root); a bone is named by its child joint.
int32_t skeleton_parent(int32_t joint);
// The snake_case name ("head", "shoulder_l", ...); "?" outside 0..kSkeletonJoints−1.
const char* skeleton_joint_name(int32_t joint);

enum class JointState : int32_t { kMissing = 0, kInferred = 1, kTracked = 2 };
const char* joint_state_name(JointState state);  // "missing", "inferred", "tracked"

constexpr int kEvidenceClasses = 16;
constexpr int kBoneSamples = 31;        // lengths kept per bone (odd: a true median)
constexpr int kBoneSamplesTrusted = 8;  // below this the generic lengths apply

struct TrackedJoint {
  float x_m, y_m, z_m;   // filtered position, camera frame (0 when missing)
  float confidence;      // [0, 1], calibrated (see above); 0 when missing
  JointState state;
  int32_t proposal;      // index of the chosen proposal, −1 for a prediction or missing
  int32_t proposal_joint;  // whose proposal: this joint or its mirror (left ↔ right); −1 as above
  // The evidence class the confidence is calibrated on (0..kEvidenceClasses−1; −1 when missing):
  // 0..9 tracked, by tenth of the fit score exp(−local cost / 2); 10..14 a prediction for the
  // 1st, 2nd, 3rd, 4th, ≥5th update in a row; 15 a proposal that does not fit its bone.
  int32_t evidence;
  float raw_m[3];        // the chosen position before the temporal filter
};

struct Skeleton {
  int32_t user_id;           // as given to update()
  int32_t frames_tracked;    // updates since this user's state was (re)started, ≥ 1
  int32_t facing_known;      // 1 when both shoulders were placed this frame
  float facing[3];           // unit, up × (shoulder_l − shoulder_r): where the torso faces
  TrackedJoint joints[kSkeletonJoints];
  float bone_length_m[kSkeletonJoints];  // this user's estimate per bone (child joint), 0 for the neck
  // Bone orientations, per bone (named by its child joint): a unit quaternion (w, x, y, z) in the
  // camera frame that turns the bone's rest direction into its direction this frame. Rest pose:
  // a T-pose facing the camera (facing −z, the subject's left +x, up +y): head and neck→shoulder,
  // arm bones along ±x (left +x), neck→knee and shin along −y, ankle→foot along −z. The rotation
  // is the torso's yaw (rest facing −z → `facing`, about +y; none when the facing is unknown)
  // followed by the shortest turn from the yawed rest direction onto the bone. Valid when the
  // bone's two joints are not missing; otherwise, and for the neck, (1, 0, 0, 0) and valid 0.
  float bone_rotation[kSkeletonJoints][4];
  int32_t bone_rotation_valid[kSkeletonJoints];
  uint64_t cycles;           // counter ticks of this update (runtime/cycle_counter.h)
};

struct SkeletonConfig {
  int32_t max_candidates;         // proposals considered per joint, 1..kMaxProposals
  float frame_period_s;           // time between updates, (0, 1] (the filter's dt)
  int32_t forget_frames;          // a user not updated for this many frames starts afresh, 1..10000
                                  // (its bone lengths kept for user_returned())
  SkeletonFilterParams filter;    // skeleton_filter.h; skeleton_filter_preset(kDefault) by default
};
SkeletonConfig default_skeleton_config();

class SkeletonTracker {
 public:
  // kBadConfig for values outside the ranges above; kBadArgument when the blob's joints are not the
  // 16 of kSkeletonJoints in that order (names compared). Forgets every user. The confidences use
  // the calibration of the blob's forest method (meta.method: BPC, otherwise OJR).
  Status init(const blob::ForestMeta& meta, const SkeletonConfig& config);
  // Replaces the config (e.g. the filter preset) and keeps the users; kBadConfig when invalid.
  Status set_config(const SkeletonConfig& config);
  const SkeletonConfig& config() const { return config_; }

  // Starts a frame: every user's "frames since seen" grows; those over forget_frames are forgotten
  // (their bone lengths stay for user_returned() until forget() or the id's next new person).
  void begin_frame();
  // One user's proposals of this frame (`proposals.joint_count` must be kSkeletonJoints) → `out`.
  // kNotInitialized before init; kBadArgument for a null pointer, user_id outside 1..kMaxUsers or
  // a result with another joint count.
  Status update(int32_t user_id, const FrameResult& proposals, Skeleton* out);
  // Forgets one user now, body measures included: call it when the people finder gives the id to
  // a new person (UserInfo::arrival == kUserNew), so nothing of the id's previous holder carries over.
  void forget(int32_t user_id);
  // The id was given back to its returning person (UserInfo::arrival == kUserReturned, re-identified
  // by the people finder): the next update() restarts the user's motion state (last positions,
  // filters, facing) but keeps the bone lengths measured before it left, also when begin_frame()
  // had already forgotten it. Call before that update().
  void user_returned(int32_t user_id);
  // What the people finder says of this frame's user (UserInfo::id, UserInfo::arrival): kUserNew
  // → forget(), kUserReturned → user_returned(), kUserContinued → nothing. Call before update().
  void note_arrival(int32_t user_id, int32_t arrival);

 private:
  struct UserState {
    int32_t active;
    int32_t returning;  // user_returned() was called: the next update keeps the bone statistics
    int32_t frames_tracked;
    int32_t frames_unseen;
    int32_t has_last[kSkeletonJoints];
    int32_t missed[kSkeletonJoints];   // consecutive updates without a tracked choice
    float last[kSkeletonJoints][3];    // last chosen (unfiltered) position
    float last_confidence[kSkeletonJoints];  // the confidence reported with it, [0, 1]
    int32_t facing_known;
    float facing[3];
    float bone_samples[kSkeletonJoints][kBoneSamples];
    int32_t bone_count[kSkeletonJoints];  // samples held (≤ kBoneSamples)
    int32_t bone_next[kSkeletonJoints];   // ring position of the next sample
    float bone_length[kSkeletonJoints];   // current median, or the generic length
    JointFilter filters[kSkeletonJoints];
  };
  void reset_user(UserState& u);
  void restart_user(UserState& u);  // reset_user keeping the bone statistics
  void update_bones(UserState& u, const Skeleton& s);

  SkeletonConfig config_{};
  bool initialized_ = false;
  const float* calibration_ = nullptr;  // kEvidenceClasses confidences, set by init()
  UserState users_[kMaxUsers + 1];  // by id; [0] unused
};

}  // namespace dp
