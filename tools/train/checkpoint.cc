#include "tools/train/checkpoint.h"

#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "tools/common/error.h"
#include "tools/common/json_fields.h"

namespace dp::train {
using tools::fail;

namespace {

constexpr char kMagic[8] = {'D', 'P', 'T', 'R', 'C', 'K', 'P', 'T'};
constexpr uint32_t kVersion = 2;  // reads 1 (no retro-fit) and 2
constexpr size_t kNodeInts = 7;

// FNV-1a over 64-bit words (tail bytes one by one): fast enough for gigabytes of probe images.
struct Digest {
  uint64_t h = 0xCBF29CE484222325ull;
  void bytes(const void* data, size_t n) {
    const uint8_t* p = static_cast<const uint8_t*>(data);
    for (; n >= 8; n -= 8, p += 8) {
      uint64_t w;
      std::memcpy(&w, p, 8);
      h = (h ^ w) * 0x100000001B3ull;
    }
    for (; n > 0; --n, ++p) h = (h ^ *p) * 0x100000001B3ull;
  }
  template <typename T>
  void value(const T& v) {
    bytes(&v, sizeof v);
  }
  void text(const std::string& s) {
    value(s.size());
    bytes(s.data(), s.size());
  }
};

template <typename T>
void put(std::vector<uint8_t>& out, T v) {
  const size_t at = out.size();
  out.resize(at + sizeof v);
  std::memcpy(out.data() + at, &v, sizeof v);
}

// zlib CRC-32 of n bytes; crc32's length is 32-bit, so a long file goes in slices.
uint32_t crc_of(const uint8_t* data, size_t n) {
  uLong crc = crc32(0L, Z_NULL, 0);
  for (size_t at = 0; at < n;) {
    const size_t slice = std::min<size_t>(n - at, size_t(1) << 30);
    crc = crc32(crc, data + at, static_cast<uInt>(slice));
    at += slice;
  }
  return static_cast<uint32_t>(crc);
}

}  // namespace

std::string training_data_digest(const TrainingSet& set, Communicator* comm) {
  // One digest per loaded image (its crop, camera, joints and its pixels of every tree), added up
  // modulo 2^64: the sum does not depend on which process holds which images, so ranks add their
  // images' terms and one sum gives the digest of the whole set for any rank count.
  std::vector<Digest> per_image(set.images.size());
  for (size_t i = 0; i < set.images.size(); ++i) {
    const TrainingImage& im = set.images[i];
    Digest& d = per_image[i];
    d.value(uint64_t(i));
    for (int v : {im.width, im.height, im.origin_u, im.origin_v, im.frame_width, im.frame_height, im.focal_factor})
      d.value(v);
    for (double v : {im.camera.fx, im.camera.fy, im.camera.cx, im.camera.cy}) d.value(v);
    const size_t cells = im.crop_elements();  // the data, not make_training_image's padding
    d.value(cells);
    d.bytes(im.probe.data(), cells * sizeof(uint16_t));
    d.value(im.joints.size());
    d.bytes(im.joints.data(), im.joints.size() * sizeof(float));
  }
  // [0]: sum of the image terms; [1 + t]: pixels of tree t.
  std::vector<int64_t> totals(1 + set.tree_pixels.size(), 0);
  for (size_t t = 0; t < set.tree_pixels.size(); ++t) {
    totals[1 + t] = static_cast<int64_t>(set.tree_pixels[t].size());
    for (const TrainingPixel& p : set.tree_pixels[t]) {
      if (p.image >= per_image.size()) fail("training pixel of tree " + std::to_string(t) + " names image " + std::to_string(p.image) + " of " + std::to_string(per_image.size()));
      per_image[p.image].value(uint64_t(t));
      per_image[p.image].bytes(&p, sizeof p);
    }
  }
  uint64_t sum = 0;
  for (size_t i = 0; i < set.images.size(); ++i)
    if (!set.images[i].probe.empty()) sum += per_image[i].h;
  totals[0] = static_cast<int64_t>(sum);
  if (comm) comm->sum(totals.data(), totals.size());
  Digest d;
  d.value(set.images.size());
  for (int64_t v : totals) d.value(v);
  d.value(set.part_names.size());
  for (const std::string& s : set.part_names) d.text(s);
  d.value(set.joint_names.size());
  for (const std::string& s : set.joint_names) d.text(s);
  d.value(set.has_labels);
  d.value(set.has_joints);
  d.value(set.reference_focal_px);
  char b[20];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(d.h));
  return b;
}

void write_checkpoint(const std::string& path, const TrainingCheckpoint& checkpoint) {
  nlohmann::json header;
  header["options"] = nlohmann::json::parse(checkpoint.options_json);
  header["data_digest"] = checkpoint.data_digest;
  header["trees"] = nlohmann::json::array();
  for (const GrowthState& t : checkpoint.trees)
    header["trees"].push_back({{"levels_done", t.levels_done},
                               {"complete", t.complete},
                               {"feature_evaluations", t.feature_evaluations},
                               {"nodes", t.nodes.size()}});
  header["retrofit"] = nlohmann::json::array();
  for (const RetrofitState& r : checkpoint.retrofit)
    header["retrofit"].push_back({{"leaves_done", r.leaves_done}, {"complete", r.complete}, {"votes", r.votes.size()}});
  const std::string text = header.dump();
  std::vector<uint8_t> out(kMagic, kMagic + 8);
  put<uint32_t>(out, kVersion);
  put<uint32_t>(out, static_cast<uint32_t>(text.size()));
  out.insert(out.end(), text.begin(), text.end());
  for (const GrowthState& t : checkpoint.trees)
    for (const DecidedNode& n : t.nodes)
      for (int32_t v : {static_cast<int32_t>(n.heap), int32_t(n.leaf ? 1 : 0), n.du1, n.dv1, n.du2, n.dv2, n.threshold})
        put<int32_t>(out, v);
  for (const RetrofitState& r : checkpoint.retrofit)
    for (const LeafVote& v : r.votes)
      for (float x : {v.dx, v.dy, v.dz, v.weight}) put<float>(out, x);
  put<uint32_t>(out, crc_of(out.data(), out.size()));

  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) fail("cannot write checkpoint " + tmp + ": " + std::strerror(errno));
  size_t done = 0;
  while (done < out.size()) {
    const ssize_t w = ::write(fd, out.data() + done, out.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      fail("cannot write checkpoint " + tmp + ": " + why);
    }
    done += static_cast<size_t>(w);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) fail("cannot write checkpoint " + tmp + ": " + std::strerror(errno));
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    fail("cannot rename checkpoint " + tmp + " to " + path + ": " + std::strerror(errno));
}

TrainingCheckpoint read_checkpoint(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail("cannot open checkpoint " + path);
  const std::vector<uint8_t> data((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  auto bad = [&](const std::string& why) { fail("checkpoint " + path + ": " + why); };
  if (data.size() < 20 || std::memcmp(data.data(), kMagic, 8) != 0)
    bad("not a depthpose training checkpoint (bad magic)");
  uint32_t version, header_bytes, crc;
  std::memcpy(&version, data.data() + 8, 4);
  std::memcpy(&header_bytes, data.data() + 12, 4);
  if (version != 1 && version != kVersion)
    bad("version " + std::to_string(version) + ", this build reads versions 1 and 2");
  std::memcpy(&crc, data.data() + data.size() - 4, 4);
  if (crc != crc_of(data.data(), data.size() - 4))
    bad("CRC-32 mismatch (truncated or damaged file)");
  if (size_t(header_bytes) > data.size() - 20) bad("header length " + std::to_string(header_bytes) + " beyond the file");
  TrainingCheckpoint c;
  nlohmann::json header;
  try {
    header = nlohmann::json::parse(data.begin() + 16, data.begin() + 16 + header_bytes);
    c.options_json = header.at("options").dump();
    c.data_digest = header.at("data_digest").get<std::string>();
    size_t at = 16 + header_bytes;
    for (const auto& t : header.at("trees")) {
      GrowthState g;
      g.levels_done = int(tools::json_integer_field(t, "levels_done", 0, 64, "checkpoint " + path));
      g.complete = t.at("complete").get<bool>();
      g.feature_evaluations = uint64_t(tools::json_integer_field(t, "feature_evaluations", 0, INT64_MAX, "checkpoint " + path));
      const size_t count = size_t(tools::json_integer_field(t, "nodes", 0, INT64_MAX, "checkpoint " + path));
      if (g.levels_done < 0 || count > (data.size() - 4 - at) / (kNodeInts * 4))
        bad("tree " + std::to_string(c.trees.size()) + " lists more nodes than the file holds");
      for (size_t i = 0; i < count; ++i, at += kNodeInts * 4) {
        int32_t v[kNodeInts];
        std::memcpy(v, data.data() + at, sizeof v);
        if (v[0] < 0 || (v[1] != 0 && v[1] != 1)) bad("corrupt node record");
        g.nodes.push_back({static_cast<uint32_t>(v[0]), v[1] == 1, v[2], v[3], v[4], v[5], v[6]});
      }
      c.trees.push_back(std::move(g));
    }
    if (version >= 2)
      for (const auto& t : header.at("retrofit")) {
        RetrofitState r;
        r.leaves_done = size_t(tools::json_integer_field(t, "leaves_done", 0, INT64_MAX, "checkpoint " + path));
        r.complete = t.at("complete").get<bool>();
        const size_t count = size_t(tools::json_integer_field(t, "votes", 0, INT64_MAX, "checkpoint " + path));
        if (count > (data.size() - 4 - at) / sizeof(LeafVote))
          bad("retro-fit tree " + std::to_string(c.retrofit.size()) + " lists more votes than the file holds");
        r.votes.resize(count);
        for (LeafVote& v : r.votes) {
          float x[4];
          std::memcpy(x, data.data() + at, sizeof x);
          at += sizeof x;
          v = {x[0], x[1], x[2], x[3]};
        }
        c.retrofit.push_back(std::move(r));
      }
    if (at != data.size() - 4) bad("trailing bytes after the node records");
  } catch (const nlohmann::json::exception& e) {
    bad(std::string("bad JSON header: ") + e.what());
  }
  for (size_t t = 0; t + 1 < c.trees.size(); ++t)
    if (!c.trees[t].complete) bad("tree " + std::to_string(t) + " is incomplete but a later tree was begun");
  for (size_t t = 0; t + 1 < c.retrofit.size(); ++t)
    if (!c.retrofit[t].complete) bad("retro-fit tree " + std::to_string(t) + " is incomplete but a later tree was begun");
  return c;
}

void check_checkpoint_matches(const TrainingCheckpoint& checkpoint, const std::string& options_json,
                              const std::string& data_digest, const std::string& path) {
  const nlohmann::json had = nlohmann::json::parse(checkpoint.options_json);
  const nlohmann::json now = nlohmann::json::parse(options_json);
  std::string diff;
  for (auto it = now.begin(); it != now.end(); ++it) {
    const std::string before = had.contains(it.key()) ? had[it.key()].dump() : "(absent)";
    if (before != it.value().dump())
      diff += "\n  " + it.key() + ": checkpoint " + before + ", this run " + it.value().dump();
  }
  for (auto it = had.begin(); it != had.end(); ++it)
    if (!now.contains(it.key())) diff += "\n  " + it.key() + ": checkpoint " + it.value().dump() + ", this run (absent)";
  if (!diff.empty())
    fail("cannot resume from " + path + ": it was written with other options:" + diff +
         "\nrun with the checkpoint's options, or without --resume to start over");
  if (checkpoint.data_digest != data_digest)
    fail("cannot resume from " + path + ": it was written for other training data (data digest " +
         checkpoint.data_digest + ", this run " + data_digest +
         "); use the same datasets, --pixels-per-image, --images-per-tree, --trees and --seed, or start without --resume");
}

}  // namespace dp::train
