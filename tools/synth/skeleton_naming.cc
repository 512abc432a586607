#include "tools/synth/skeleton_naming.h"

#include <algorithm>
#include <cctype>
#include <set>

#include "tools/common/error.h"

namespace dp::synth {

namespace {

std::string lower(const std::string& s) {
  std::string out = s;
  for (char& c : out) c = char(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// Left-side entries are written once; the right side swaps the side words.
struct SidedEntry {
  const char* rig_left;
  const char* rig_right;
  const char* joint_left;
  const char* joint_right;
  const char* tail_left;
  const char* tail_right;
  bool required;
};

SkeletonNaming make_naming(const char* name, const char* describe, std::vector<JointMapEntry> centre,
                           const std::vector<SidedEntry>& sided) {
  SkeletonNaming n{name, describe, std::move(centre)};
  for (const SidedEntry& e : sided) n.entries.push_back({e.rig_left, e.joint_left, e.tail_left, e.required});
  for (const SidedEntry& e : sided) n.entries.push_back({e.rig_right, e.joint_right, e.tail_right, e.required});
  return n;
}

std::vector<SkeletonNaming> build_namings() {
  std::vector<SkeletonNaming> all;
  // CMU's 31 joints under the rig's own names (cgspeed "MotionBuilder-friendly", assimp's CMU
  // clips). LeftShoulder is the clavicle here.
  all.push_back(make_naming(
      "motionbuilder", "CMU 31-joint skeleton, MotionBuilder names (Hips, LeftUpLeg, LeftShoulder = clavicle, LeftArm)",
      {{"Hips", "Hips", "", true},
       {"LowerBack", "LowerBack", "", false},
       {"Spine", "Spine", "", true},
       {"Spine1", "Spine1", "Neck", true},
       {"Neck", "Neck", "", true},
       {"Neck1", "Neck1", "", false},
       {"Head", "Head", "", true}},
      {{"LeftShoulder", "RightShoulder", "LeftShoulder", "RightShoulder", "", "", true},
       {"LeftArm", "RightArm", "LeftArm", "RightArm", "", "", true},
       {"LeftForeArm", "RightForeArm", "LeftForeArm", "RightForeArm", "", "", true},
       {"LeftHand", "RightHand", "LeftHand", "RightHand", "", "", true},
       {"LeftFingerBase", "RightFingerBase", "LeftFingerBase", "RightFingerBase", "", "", false},
       {"LThumb", "RThumb", "LThumb", "RThumb", "", "", false},
       {"LHipJoint", "RHipJoint", "LHipJoint", "RHipJoint", "", "", false},
       {"LeftUpLeg", "RightUpLeg", "LeftUpLeg", "RightUpLeg", "", "", true},
       {"LeftLeg", "RightLeg", "LeftLeg", "RightLeg", "", "", true},
       {"LeftFoot", "RightFoot", "LeftFoot", "RightFoot", "", "", true},
       {"LeftToeBase", "RightToeBase", "LeftToeBase", "RightToeBase", "", "", false}}));
  // cgspeed "DAZ-friendly": 43 joints, T-pose rest with straight legs. The head's only children
  // are the eyes, so it has no usable rest direction; the hand points at the middle finger; the
  // buttock joints are skipped (hip -> thigh spans the rig's LHipJoint).
  all.push_back(make_naming(
      "daz", "DAZ 43-joint skeleton (hip abdomen chest neck head, lCollar lShldr lForeArm lHand, lThigh lShin lFoot)",
      {{"Hips", "hip", "", true},
       {"LowerBack", "abdomen", "chest", true},
       {"Spine", "abdomen", "chest", true},
       {"Spine1", "chest", "neck", true},
       {"Neck", "neck", "head", true},
       {"Neck1", "neck", "head", true},
       {"Head", "head", "-", true}},
      {{"LeftShoulder", "RightShoulder", "lCollar", "rCollar", "lShldr", "rShldr", true},
       {"LeftArm", "RightArm", "lShldr", "rShldr", "lForeArm", "rForeArm", true},
       {"LeftForeArm", "RightForeArm", "lForeArm", "rForeArm", "lHand", "rHand", true},
       {"LeftHand", "RightHand", "lHand", "rHand", "lMid1", "rMid1", true},
       {"LHipJoint", "RHipJoint", "hip", "hip", "lThigh", "rThigh", true},
       {"LeftUpLeg", "RightUpLeg", "lThigh", "rThigh", "lShin", "rShin", true},
       {"LeftLeg", "RightLeg", "lShin", "rShin", "lFoot", "rFoot", true},
       {"LeftFoot", "RightFoot", "lFoot", "rFoot", "", "", true}}));
  // cgspeed "3ds Max-friendly" biped names: LeftHip is the thigh, LeftShoulder the UPPER ARM,
  // LeftCollar the clavicle. Chest2 (and Chest3/Chest4 in some exports) may be absent.
  all.push_back(make_naming(
      "3dsmax", "3ds Max biped names (LeftHip, LeftKnee, LeftAnkle, lowerback, Chest, LeftCollar, LeftShoulder = upper arm, LeftElbow, LeftWrist)",
      {{"Hips", "Hips", "", true},
       {"LowerBack", "lowerback", "Chest", false},
       {"Spine", "Chest", "Neck", true},
       {"Spine1", "Chest2", "Neck", false},
       {"Neck", "Neck", "Head", true},
       {"Neck1", "Neck", "Head", true},
       {"Head", "Head", "", true}},
      {{"LeftShoulder", "RightShoulder", "LeftCollar", "RightCollar", "LeftShoulder", "RightShoulder", true},
       {"LeftArm", "RightArm", "LeftShoulder", "RightShoulder", "LeftElbow", "RightElbow", true},
       {"LeftForeArm", "RightForeArm", "LeftElbow", "RightElbow", "LeftWrist", "RightWrist", true},
       {"LeftHand", "RightHand", "LeftWrist", "RightWrist", "", "", true},
       {"LHipJoint", "RHipJoint", "Hips", "Hips", "LeftHip", "RightHip", true},
       {"LeftUpLeg", "RightUpLeg", "LeftHip", "RightHip", "LeftKnee", "RightKnee", true},
       {"LeftLeg", "RightLeg", "LeftKnee", "RightKnee", "LeftAnkle", "RightAnkle", true},
       {"LeftFoot", "RightFoot", "LeftAnkle", "RightAnkle", "LeftToe", "RightToe", false},
       {"LeftToeBase", "RightToeBase", "LeftToe", "RightToe", "", "", false}}));
  // CMU's ASF bone names kept in a BVH (amc2bvh-style conversions; one DAZ-folder clip is one).
  // The root may be called anything ("root", "hip"): "" names the ROOT joint.
  all.push_back(make_naming(
      "cmu-asf-names", "CMU ASF bone names in a BVH (root, lowerback, upperback, thorax, lclavicle, lhumerus, lradius, lfemur, ltibia)",
      {{"Hips", "", "", true},
       {"LowerBack", "lowerback", "", true},
       {"Spine", "upperback", "", true},
       {"Spine1", "thorax", "", true},
       {"Neck", "lowerneck", "", true},
       {"Neck1", "upperneck", "", false},
       {"Head", "head", "", true}},
      {{"LeftShoulder", "RightShoulder", "lclavicle", "rclavicle", "", "", true},
       {"LeftArm", "RightArm", "lhumerus", "rhumerus", "", "", true},
       {"LeftForeArm", "RightForeArm", "lradius", "rradius", "", "", true},
       {"LeftHand", "RightHand", "lwrist", "rwrist", "", "", true},
       {"LeftFingerBase", "RightFingerBase", "lhand", "rhand", "", "", false},
       {"LThumb", "RThumb", "lthumb", "rthumb", "", "", false},
       {"LHipJoint", "RHipJoint", "lhipjoint", "rhipjoint", "", "", false},
       {"LeftUpLeg", "RightUpLeg", "lfemur", "rfemur", "", "", true},
       {"LeftLeg", "RightLeg", "ltibia", "rtibia", "", "", true},
       {"LeftFoot", "RightFoot", "lfoot", "rfoot", "", "", true},
       {"LeftToeBase", "RightToeBase", "ltoes", "rtoes", "", "", false}}));
  // MakeHuman's default rig (163 bones; BVH export keeps the bone names): a five-bone spine,
  // three neck bones, two-part limbs (upperarm01/02, lowerleg01/02) spanned by their first bone.
  all.push_back(make_naming(
      "makehuman", "MakeHuman default rig (root, spine05..spine01, neck01, head, clavicle.L, upperarm01.L, lowerarm01.L, wrist.L, pelvis.L, upperleg01.L, lowerleg01.L, foot.L)",
      {{"Hips", "root", "", true},
       {"LowerBack", "spine05", "spine03", true},
       {"Spine", "spine03", "spine01", true},
       {"Spine1", "spine01", "neck01", true},
       {"Neck", "neck01", "head", true},
       {"Neck1", "neck01", "head", true},
       {"Head", "head", "-", true}},
      {{"LeftShoulder", "RightShoulder", "clavicle.L", "clavicle.R", "upperarm01.L", "upperarm01.R", true},
       {"LeftArm", "RightArm", "upperarm01.L", "upperarm01.R", "lowerarm01.L", "lowerarm01.R", true},
       {"LeftForeArm", "RightForeArm", "lowerarm01.L", "lowerarm01.R", "wrist.L", "wrist.R", true},
       {"LeftHand", "RightHand", "wrist.L", "wrist.R", "finger3-1.L", "finger3-1.R", false},
       {"LHipJoint", "RHipJoint", "pelvis.L", "pelvis.R", "upperleg01.L", "upperleg01.R", true},
       {"LeftUpLeg", "RightUpLeg", "upperleg01.L", "upperleg01.R", "lowerleg01.L", "lowerleg01.R", true},
       {"LeftLeg", "RightLeg", "lowerleg01.L", "lowerleg01.R", "foot.L", "foot.R", true},
       {"LeftFoot", "RightFoot", "foot.L", "foot.R", "toe1-1.L", "toe1-1.R", false}}));
  return all;
}

}  // namespace

const std::vector<SkeletonNaming>& bvh_skeleton_namings() {
  static const std::vector<SkeletonNaming> namings = build_namings();
  return namings;
}

const SkeletonNaming& recognise_bvh_skeleton(const std::vector<std::string>& joint_names, const std::string& path) {
  std::set<std::string> have;
  for (const std::string& n : joint_names) have.insert(lower(n));
  auto present = [&](const char* name) { return have.count(lower(name)) > 0; };
  const SkeletonNaming* best = nullptr;
  double best_score = -1;
  std::vector<std::string> best_missing;
  for (const SkeletonNaming& n : bvh_skeleton_namings()) {
    std::vector<std::string> missing;
    int required = 0, found = 0;
    for (const JointMapEntry& e : n.entries) {
      if (!e.required) continue;
      for (const char* name : {e.joint, e.tail}) {
        if (name[0] == 0 || (name[0] == '-' && name[1] == 0)) continue;
        ++required;
        if (present(name)) ++found;
        else if (std::find(missing.begin(), missing.end(), name) == missing.end()) missing.push_back(name);
      }
    }
    const double score = required ? double(found) / required : 0;
    if (score > best_score) {
      best_score = score;
      best = &n;
      best_missing = missing;
    }
  }
  if (!best_missing.empty()) {
    std::string list;
    for (const std::string& m : best_missing) list += (list.empty() ? "" : ", ") + m;
    std::string known;
    for (const SkeletonNaming& n : bvh_skeleton_namings()) known += (known.empty() ? "" : ", ") + std::string(n.name);
    dp::tools::fail(path + ": BVH skeleton not recognised (known namings: " + known + "); closest naming '" +
                    best->name + "' lacks joints " + list + " — refusing rather than putting limbs on the wrong bones");
  }
  return *best;
}

}  // namespace dp::synth
