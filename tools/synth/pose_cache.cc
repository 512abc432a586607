#include "tools/synth/pose_cache.h"

#include <sys/stat.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "tools/common/error.h"
#include "tools/common/file_io.h"

namespace dp::synth {
using dp::tools::fail;
namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'D', 'P', 'P', 'O', 'S', 'E', 'S', '\n'};

// "size S mtime T" of a file (T in ns since the epoch), or fails naming it.
std::string file_stamp(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) fail("pose cache: cannot stat " + path);
  return "size " + std::to_string(static_cast<long long>(st.st_size)) + " mtime " +
         std::to_string(static_cast<long long>(st.st_mtim.tv_sec)) + "." +
         std::to_string(static_cast<long long>(st.st_mtim.tv_nsec));
}

// CRC-32 and size of the running executable: the code that parses and retargets clips.
std::string executable_stamp() {
  std::ifstream in("/proc/self/exe", std::ios::binary);
  if (!in) fail("pose cache: cannot read the running executable (/proc/self/exe) for the cache key");
  std::vector<char> buf(1 << 20);
  uLong crc = crc32(0L, Z_NULL, 0);
  unsigned long long size = 0;
  while (in) {
    in.read(buf.data(), std::streamsize(buf.size()));
    const std::streamsize got = in.gcount();
    if (got <= 0) break;
    crc = crc32(crc, reinterpret_cast<const Bytef*>(buf.data()), uInt(got));
    size += static_cast<unsigned long long>(got);
  }
  char line[64];
  std::snprintf(line, sizeof line, "crc32 %08lx size %llu", static_cast<unsigned long>(crc), size);
  return line;
}

class Writer {
 public:
  void bytes(const void* p, size_t n) { out_.append(static_cast<const char*>(p), n); }
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) out_.push_back(char((v >> (8 * i)) & 0xFF));
  }
  void u64(uint64_t v) {
    for (int i = 0; i < 8; ++i) out_.push_back(char((v >> (8 * i)) & 0xFF));
  }
  void i32(int32_t v) { u32(static_cast<uint32_t>(v)); }
  void f64(double v) {
    uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    u64(bits);
  }
  void str(const std::string& s) {
    u64(s.size());
    bytes(s.data(), s.size());
  }
  std::string& data() { return out_; }

 private:
  std::string out_;
};

// Reads what Writer wrote; every read is bounded by the bytes left (ok() turns false instead).
class Reader {
 public:
  Reader(const uint8_t* p, size_t n) : p_(p), left_(n) {}
  bool ok() const { return ok_; }
  size_t left() const { return left_; }
  bool take(void* out, size_t n) {
    if (!ok_ || n > left_) return ok_ = false;
    std::memcpy(out, p_, n);
    p_ += n;
    left_ -= n;
    return true;
  }
  uint32_t u32() {
    uint8_t b[4] = {};
    take(b, 4);
    return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
  }
  uint64_t u64() {
    const uint64_t lo = u32();
    return lo | uint64_t(u32()) << 32;
  }
  int32_t i32() { return static_cast<int32_t>(u32()); }
  double f64() {
    const uint64_t bits = u64();
    double v;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  std::string str() {
    const uint64_t n = u64();
    if (!ok_ || n > left_) {
      ok_ = false;
      return {};
    }
    std::string s(reinterpret_cast<const char*>(p_), size_t(n));
    p_ += n;
    left_ -= size_t(n);
    return s;
  }
  // A count of items of at least `min_item_bytes` each: refused when the bytes left cannot hold it.
  uint64_t count(size_t min_item_bytes) {
    const uint64_t n = u64();
    if (ok_ && min_item_bytes > 0 && n > left_ / min_item_bytes) ok_ = false;
    return ok_ ? n : 0;
  }

 private:
  const uint8_t* p_;
  size_t left_;
  bool ok_ = true;
};

// The first line where two keys differ, for the refusal message.
std::string first_difference(const std::string& ours, const std::string& theirs) {
  size_t a = 0, b = 0;
  while (a < ours.size() || b < theirs.size()) {
    const size_t ea = std::min(ours.find('\n', a), ours.size()), eb = std::min(theirs.find('\n', b), theirs.size());
    const std::string la = ours.substr(a, ea - a), lb = theirs.substr(b, eb - b);
    if (la != lb)
      return "this run has '" + (la.empty() ? std::string("(nothing)") : la) + "', the file '" +
             (lb.empty() ? std::string("(nothing)") : lb) + "'";
    a = ea + 1;
    b = eb + 1;
  }
  return "the keys differ";
}

}  // namespace

std::string pose_cache_key(const std::string& assets_dir, const std::vector<ClipEntry>& entries, int frame_stride) {
  std::string key = "depthpose pose cache " + std::to_string(kPoseCacheVersion) + "\n";
  key += "executable " + executable_stamp() + "\n";
  key += "frame stride " + std::to_string(frame_stride) + "\n";
  for (const ClipEntry& e : entries) {
    key += "clip " + e.id + " subject " + e.subject + " format " + e.format + " frames " + std::to_string(e.frames) +
           " category '" + e.category + "'\n";
    key += "  file " + e.path + " " + file_stamp(e.path) + "\n";
    if (!e.asf_path.empty()) key += "  file " + e.asf_path + " " + file_stamp(e.asf_path) + "\n";
  }
  // The human assets (mesh, rig, skinning, T-pose) retargeting uses: every file under makehuman/.
  const fs::path human = fs::path(assets_dir) / "makehuman";
  std::vector<std::string> files;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(human, ec), end; !ec && it != end; it.increment(ec))
    if (it->is_regular_file(ec)) files.push_back(it->path().string());
  if (ec) fail("pose cache: cannot list " + human.string() + ": " + ec.message());
  std::sort(files.begin(), files.end());
  for (const std::string& f : files) key += "asset " + f + " " + file_stamp(f) + "\n";
  return key;
}

bool read_pose_cache(const std::string& path, const std::string& key, size_t bone_count, RealPoses* real,
                     std::vector<std::string>* clip_names, std::string* why) {
  auto refuse = [&](const std::string& reason) {
    *why = "pose cache " + path + " not used: " + reason;
    return false;
  };
  std::error_code ec;
  if (!fs::exists(path, ec)) return refuse("no such file");
  std::vector<uint8_t> bytes;
  try {
    bytes = dp::tools::read_file_bytes(path, "pose cache");
  } catch (const dp::tools::ToolError& e) {
    return refuse(e.what());
  }
  Reader in(bytes.data(), bytes.size());
  char magic[8] = {};
  if (!in.take(magic, 8) || std::memcmp(magic, kMagic, 8) != 0) return refuse("not a depthpose pose cache");
  const uint32_t version = in.u32();
  if (!in.ok()) return refuse("truncated header");
  if (version != kPoseCacheVersion)
    return refuse("format version " + std::to_string(version) + ", this build reads " +
                  std::to_string(kPoseCacheVersion));
  const std::string file_key = in.str();
  if (!in.ok()) return refuse("truncated key");
  if (file_key != key) return refuse("made for other inputs: " + first_difference(key, file_key));
  const uint64_t payload_bytes = in.u64();
  if (!in.ok() || payload_bytes > in.left() || in.left() - payload_bytes != 4)
    return refuse("truncated or oversized payload");
  const size_t payload_at = bytes.size() - 4 - size_t(payload_bytes);
  const uint8_t* payload = bytes.data() + payload_at;
  const uint32_t want_crc = Reader(bytes.data() + bytes.size() - 4, 4).u32();
  if (uint32_t(crc32_z(crc32(0L, Z_NULL, 0), payload, size_t(payload_bytes))) != want_crc)
    return refuse("payload CRC-32 mismatch (corrupt file)");

  Reader p(payload, size_t(payload_bytes));
  RealPoses r;
  std::vector<std::string> names;
  const uint64_t clips = p.count(12);
  for (uint64_t c = 0; c < clips && p.ok(); ++c) {
    names.push_back(p.str());
    r.category_of_clip.push_back(p.i32());
  }
  const uint64_t categories = p.count(28);
  for (uint64_t c = 0; c < categories && p.ok(); ++c) {
    PosePoolReport::Category row;
    row.name = p.str();
    row.clips = p.i32();
    row.source_frames = static_cast<long>(p.u64());
    row.sampled = size_t(p.u64());
    r.categories.push_back(row);
  }
  r.retarget_seconds = p.f64();
  const uint64_t bones = p.u64();
  if (!p.ok()) return refuse("truncated clip table");
  if (bones != bone_count)
    return refuse("poses of " + std::to_string(bones) + " bones, the rig has " + std::to_string(bone_count));
  const uint64_t poses = p.count(12 + 72 * size_t(bones));
  r.origin.reserve(size_t(poses));
  r.clip_of.reserve(size_t(poses));
  for (uint64_t i = 0; i < poses && p.ok(); ++i) {
    r.origin.push_back(p.str());
    r.clip_of.push_back(p.i32());
  }
  r.poses.resize(size_t(poses));
  for (BodyPose& pose : r.poses) {
    pose.bone_world.resize(size_t(bones));
    for (Mat3& m : pose.bone_world)
      for (double& x : m.m) x = p.f64();
  }
  if (!p.ok() || p.left() != 0) return refuse("truncated or malformed payload");
  for (const int row : r.category_of_clip)
    if (row < 0 || uint64_t(row) >= categories) return refuse("a clip names no category");
  for (const int c : r.clip_of)
    if (c < 0 || uint64_t(c) >= clips) return refuse("a pose names no clip");
  *real = std::move(r);
  *clip_names = std::move(names);
  return true;
}

void write_pose_cache(const std::string& path, const std::string& key, const RealPoses& real,
                      const std::vector<std::string>& clip_names) {
  if (clip_names.size() != real.category_of_clip.size()) fail("pose cache: one name per clip expected");
  const size_t bones = real.poses.empty() ? 0 : real.poses[0].bone_world.size();
  Writer p;
  p.u64(clip_names.size());
  for (size_t c = 0; c < clip_names.size(); ++c) {
    p.str(clip_names[c]);
    p.i32(real.category_of_clip[c]);
  }
  p.u64(real.categories.size());
  for (const PosePoolReport::Category& row : real.categories) {
    p.str(row.name);
    p.i32(row.clips);
    p.u64(static_cast<uint64_t>(row.source_frames));
    p.u64(row.sampled);
  }
  p.f64(real.retarget_seconds);
  p.u64(bones);
  p.u64(real.poses.size());
  for (size_t i = 0; i < real.poses.size(); ++i) {
    p.str(real.origin[i]);
    p.i32(real.clip_of[i]);
  }
  for (const BodyPose& pose : real.poses) {
    if (pose.bone_world.size() != bones) fail("pose cache: poses of different bone counts");
    for (const Mat3& m : pose.bone_world)
      for (double x : m.m) p.f64(x);
  }
  Writer f;
  f.bytes(kMagic, 8);
  f.u32(kPoseCacheVersion);
  f.str(key);
  f.u64(p.data().size());
  f.bytes(p.data().data(), p.data().size());
  f.u32(uint32_t(crc32_z(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(p.data().data()), p.data().size())));
  dp::tools::write_file_atomic(path, f.data().data(), f.data().size());
}

}  // namespace dp::synth
