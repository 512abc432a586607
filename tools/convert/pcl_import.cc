#include "tools/convert/pcl_import.h"

#include <cstdio>
#include <memory>

#include "tools/common/body_model.h"
#include "tools/common/error.h"

namespace dp::tools {

const char* const kPclPartNames[kPclPartCount] = {
    "Lfoot",  "Lleg",     "Lknee",    "Lthigh", "Rfoot",  "Rleg",   "Rknee",  "Rthigh", "Rhips",
    "Lhips",  "Neck",     "Rarm",     "Relbow", "Rforearm", "Rhand", "Larm",  "Lelbow", "Lforearm",
    "Lhand",  "FaceLB",   "FaceRB",   "FaceLT", "FaceRT", "Rchest", "Lchest"};

namespace {

enum PclPart {
  kLfoot, kLleg, kLknee, kLthigh, kRfoot, kRleg, kRknee, kRthigh, kRhips, kLhips, kNeck, kRarm,
  kRelbow, kRforearm, kRhand, kLarm, kLelbow, kLforearm, kLhand, kFaceLB, kFaceRB, kFaceLT,
  kFaceRT, kRchest, kLchest
};
constexpr uint32_t bit(int p) { return 1u << p; }

}  // namespace

uint32_t pcl_joint_parts(int joint) {
  // Our joint order: head neck shoulder_l/r elbow_l/r wrist_l/r hand_l/r knee_l/r ankle_l/r foot_l/r.
  // PCL has no shoulder, wrist or ankle label: the nearest parts stand in (upper arm; forearm+hand;
  // lower leg+foot), which pulls those modes towards the part centres (docs/convert.md).
  static const uint32_t masks[kJointCount] = {
      bit(kFaceLB) | bit(kFaceRB) | bit(kFaceLT) | bit(kFaceRT),
      bit(kNeck),
      bit(kLarm), bit(kRarm),
      bit(kLelbow), bit(kRelbow),
      bit(kLforearm) | bit(kLhand), bit(kRforearm) | bit(kRhand),
      bit(kLhand), bit(kRhand),
      bit(kLknee), bit(kRknee),
      bit(kLleg) | bit(kLfoot), bit(kRleg) | bit(kRfoot),
      bit(kLfoot), bit(kRfoot)};
  return joint >= 0 && joint < kJointCount ? masks[joint] : 0;
}

blob::BlobContents pcl_blob_contents(const std::vector<PclTree>& trees) {
  if (trees.empty() || trees.size() > size_t(blob::kMaxTrees))
    fail("convert --from-pcl: need 1.." + std::to_string(blob::kMaxTrees) + " trees");
  blob::BlobContents c;
  c.method = blob::Method::kBpc;
  c.depth = trees[0].depth;
  c.reference_focal_px = 525.0f;
  for (const char* name : kPclPartNames) c.part_names.push_back(name);
  for (const char* name : kJointNames) c.joint_names.push_back(name);
  // One leaf record per label that occurs, in label order (all 25 for PCL's depth-20 trees), so
  // the leaf count never exceeds what small trees can reference.
  int record_of_label[kPclPartCount];
  bool used[kPclPartCount] = {};
  for (const PclTree& t : trees) {
    if (t.depth != c.depth) fail("convert --from-pcl: trees of different heights");
    for (uint8_t l : t.leaf_labels) used[l] = true;
  }
  int records = 0;
  for (int label = 0; label < kPclPartCount; ++label) {
    record_of_label[label] = used[label] ? records++ : -1;
    if (!used[label]) continue;
    for (int p = 0; p < kPclPartCount; ++p) c.bpc_leaves.push_back(p == label ? 32768 : 0);
  }
  for (const PclTree& t : trees) {
    std::vector<uint32_t> index(t.leaf_labels.size());
    for (size_t i = 0; i < index.size(); ++i) index[i] = uint32_t(record_of_label[t.leaf_labels[i]]);
    blob::append_heap_tree(&c, t.nodes, index);
  }
  c.config = blob::default_runtime_config(kJointCount);
  for (int j = 0; j < kJointCount; ++j) c.config.joints[j].part_mask = pcl_joint_parts(j);
  // PCL frames are 640×480: evaluate every foreground pixel of such a frame (no striding).
  c.config.max_evaluated_pixels = 640 * 480;
  c.max_width = 640;
  c.max_height = 480;
  return c;
}

}  // namespace dp::tools
