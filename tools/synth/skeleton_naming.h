// Joint maps from the skeletons mocap files arrive in onto the cmu_mb rig (our 31 bones).
//
// A BVH file names its joints after the tool that exported it. The same word can mean different
// bones: "LeftShoulder" is the clavicle in MotionBuilder naming but the upper arm in 3ds Max
// naming. So a skeleton is recognised by its whole set of joint names, never joint by joint:
// every known naming is scored by how many of its required joints the file has, the best one is
// taken, and if it still lacks a required joint the file is refused with a message naming the
// missing joints (a body with limbs on the wrong bones must never be rendered).
//
// Each map entry drives one rig bone from one source joint: the rig bone takes the source
// joint's world rotation, swung so that it points from the source joint to the entry's tail
// joint as the source skeleton does in that frame (tails may skip joints the rig lacks, e.g.
// DAZ's buttock between hip and thigh). The rest-pose correction is the tail direction in the
// source's rest pose (e.g. CMU's 20-degree leg splay, DAZ's straight legs, MakeHuman's A-pose):
// retarget_frame turns our T-posed bone onto it before applying the motion (posing.h).
//
// Names compare case-insensitively. Rig bones a naming does not drive (toes, fingers when absent)
// keep their T-pose relation to their parent.
#pragma once
#include <string>
#include <vector>

namespace dp::synth {

struct JointMapEntry {
  const char* rig_bone;  // cmu_mb bone name
  const char* joint;     // source joint whose world rotation drives it ("" = the ROOT joint)
  // Source joint at the far end of the segment; "" = the joint's first child (or its End Site);
  // "-" = no usable direction in the source (rest direction taken as ours, e.g. a head whose
  // only children are eyes).
  const char* tail;
  bool required;         // a skeleton lacking it (joint or tail) is refused
};

struct SkeletonNaming {
  const char* name;      // "motionbuilder", "daz", "3dsmax", "makehuman"
  const char* describe;  // one line for messages and docs
  std::vector<JointMapEntry> entries;
};

// The BVH namings we map (motionbuilder = cgspeed's CMU conversion and CMU's own names; daz =
// cgspeed's 43-joint DAZ-friendly skeleton; 3dsmax = cgspeed's 3ds Max-friendly biped names;
// cmu-asf-names = CMU's ASF bone names kept in a BVH; makehuman = MakeHuman's default rig as its
// BVH export names it).
const std::vector<SkeletonNaming>& bvh_skeleton_namings();

// The naming whose required joints `joint_names` best covers. Throws dp::tools::ToolError
// "<path>: BVH skeleton not recognised ... lacks joints A, B (closest naming: N)" when even the
// best naming lacks a required joint or tail.
const SkeletonNaming& recognise_bvh_skeleton(const std::vector<std::string>& joint_names, const std::string& path);

}  // namespace dp::synth
