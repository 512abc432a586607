#include "tools/convert/pcl_import.h"

#include <bzlib.h>

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

// Streams a bzip2 file and hands out whitespace-separated integers; the whole text is never held.
class Bz2Integers {
 public:
  explicit Bz2Integers(const std::string& path) : path_(path) {
    file_ = std::fopen(path.c_str(), "rb");
    if (!file_) fail(path + ": cannot open PCL tree file");
    int err = BZ_OK;
    bz_ = BZ2_bzReadOpen(&err, file_, 0, 0, nullptr, 0);
    if (err != BZ_OK) { close(); fail(path + ": not a bzip2 stream"); }
  }
  ~Bz2Integers() { close(); }
  Bz2Integers(const Bz2Integers&) = delete;
  Bz2Integers& operator=(const Bz2Integers&) = delete;

  // Next integer; false at the end of the stream. Throws on a non-numeric token.
  bool next(long* value) {
    int c = get();
    while (c == ' ' || c == '\n' || c == '\r' || c == '\t') c = get();
    if (c < 0) return false;
    bool negative = false;
    if (c == '-' || c == '+') { negative = c == '-'; c = get(); }
    if (c < '0' || c > '9') fail(path_ + ": unexpected character in PCL tree file");
    long v = 0;
    while (c >= '0' && c <= '9') {
      v = v * 10 + (c - '0');
      if (v > 1000000000L) fail(path_ + ": number too large in PCL tree file");
      c = get();
    }
    if (c >= 0 && c != ' ' && c != '\n' && c != '\r' && c != '\t')
      fail(path_ + ": unexpected character in PCL tree file");
    *value = negative ? -v : v;
    return true;
  }
  const std::string& path() const { return path_; }

 private:
  int get() {
    if (pos_ == len_) {
      if (eof_) return -1;
      int err = BZ_OK;
      len_ = BZ2_bzRead(&err, bz_, buffer_, sizeof buffer_);
      pos_ = 0;
      if (err == BZ_STREAM_END) {
        eof_ = true;
        // One tree is one bzip2 stream: bytes after it (a second stream, garbage) are refused,
        // not ignored.
        void* unused = nullptr;
        int unused_bytes = 0, e2 = BZ_OK;
        BZ2_bzReadGetUnused(&e2, bz_, &unused, &unused_bytes);
        if (e2 != BZ_OK || unused_bytes > 0 || std::fgetc(file_) != EOF)
          fail(path_ + ": trailing data after the bzip2 stream (a PCL tree file holds one stream)");
      } else if (err != BZ_OK) {
        fail(path_ + ": corrupt bzip2 data");
      }
      if (len_ <= 0) { len_ = 0; return -1; }
    }
    return static_cast<unsigned char>(buffer_[pos_++]);
  }
  void close() {
    if (bz_) { int err; BZ2_bzReadClose(&err, bz_); bz_ = nullptr; }
    if (file_) { std::fclose(file_); file_ = nullptr; }
  }
  std::string path_;
  FILE* file_ = nullptr;
  BZFILE* bz_ = nullptr;
  char buffer_[1 << 16];
  int len_ = 0, pos_ = 0;
  bool eof_ = false;
};

int16_t checked_int16(const Bz2Integers& in, long v, long limit, const char* what) {
  if (v < -limit || v > limit) fail(in.path() + ": " + what + " " + std::to_string(v) + " out of range");
  return int16_t(v);
}

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

PclTree read_pcl_tree(const std::string& path) {
  Bz2Integers in(path);
  PclTree t;
  long v = 0;
  if (!in.next(&v)) fail(path + ": empty PCL tree file");
  if (v < 1 || v > blob::kMaxDepth)
    fail(path + ": tree height " + std::to_string(v) + " outside 1.." + std::to_string(blob::kMaxDepth));
  t.depth = int(v);
  t.nodes.resize(blob::nodes_per_tree(t.depth));
  t.leaf_labels.resize(blob::leaves_per_tree(t.depth));
  long f[5];
  for (auto& n : t.nodes) {
    for (long& x : f)
      if (!in.next(&x)) fail(path + ": file ends inside the node list");
    n.du1 = checked_int16(in, f[0], blob::kMaxProbeOffsetPxm, "probe offset");
    n.dv1 = checked_int16(in, f[1], blob::kMaxProbeOffsetPxm, "probe offset");
    n.du2 = checked_int16(in, f[2], blob::kMaxProbeOffsetPxm, "probe offset");
    n.dv2 = checked_int16(in, f[3], blob::kMaxProbeOffsetPxm, "probe offset");
    n.threshold_mm = checked_int16(in, f[4], 32767, "threshold");
  }
  for (auto& l : t.leaf_labels) {
    if (!in.next(&v)) fail(path + ": file ends inside the leaf labels");
    if (v < 0 || v >= kPclPartCount) fail(path + ": leaf label " + std::to_string(v) + " is not a PCL part (0..24)");
    l = uint8_t(v);
  }
  if (in.next(&v)) fail(path + ": trailing data after the leaf labels");
  return t;
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
    c.tree_nodes.push_back(t.nodes);
    std::vector<uint32_t> index(t.leaf_labels.size());
    for (size_t i = 0; i < index.size(); ++i) index[i] = uint32_t(record_of_label[t.leaf_labels[i]]);
    c.tree_leaf_index.push_back(std::move(index));
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
