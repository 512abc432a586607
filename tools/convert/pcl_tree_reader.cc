// Reading PCL people-detector tree files (bzip2 ASCII): kept apart from the blob building in
// pcl_import.cc so the reader can be built alone (the fuzz target tests/fuzz/pcl_tree_fuzz.cc).
#include <bzlib.h>

#include <cstdio>

#include "forest_blob/blob_format.h"
#include "tools/common/error.h"
#include "tools/convert/pcl_import.h"

namespace dp::tools {

namespace {

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

PclTree read_pcl_tree(const std::string& path) {
  Bz2Integers in(path);
  PclTree t;
  long v = 0;
  if (!in.next(&v)) fail(path + ": empty PCL tree file");
  if (v < 1 || v > blob::kMaxDepth)
    fail(path + ": tree height " + std::to_string(v) + " outside 1.." + std::to_string(blob::kMaxDepth));
  t.depth = int(v);
  t.nodes.resize(blob::nodes_per_heap(t.depth));
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

}  // namespace dp::tools
