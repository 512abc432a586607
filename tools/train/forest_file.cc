#include "tools/train/forest_file.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <ostream>
#include <sstream>

#include "runtime/fixed_point.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/common/json_fields.h"

namespace dp::train {
using nlohmann::json;
using tools::fail;
using tools::json_integer_field;

namespace {

constexpr size_t kNodeRecordBytes = 20;
constexpr size_t kFixedHeaderBytes = 16;

class Writer {
 public:
  void bytes(const void* p, size_t n) {
    const uint8_t* b = static_cast<const uint8_t*>(p);
    out.insert(out.end(), b, b + n);
  }
  void u16(uint16_t v) { for (int i = 0; i < 2; ++i) out.push_back(uint8_t(v >> (8 * i))); }
  void u32(uint32_t v) { for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i))); }
  void i16(int16_t v) { u16(static_cast<uint16_t>(v)); }
  void f32(float v) {
    uint32_t u;
    std::memcpy(&u, &v, 4);
    u32(u);
  }
  std::vector<uint8_t> out;
};

class Reader {
 public:
  Reader(const uint8_t* data, size_t size, const std::string& what)
      : data_(data), size_(size), what_(what) {}
  void need(size_t n, const char* field) {
    if (n > size_ - pos_) fail(what_ + ": truncated (reading " + field + " at byte " + std::to_string(pos_) + ")");
  }
  uint16_t u16(const char* field) {
    need(2, field);
    uint16_t v = uint16_t(data_[pos_] | (data_[pos_ + 1] << 8));
    pos_ += 2;
    return v;
  }
  uint32_t u32(const char* field) {
    need(4, field);
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(data_[pos_ + i]) << (8 * i);
    pos_ += 4;
    return v;
  }
  int16_t i16(const char* field) { return static_cast<int16_t>(u16(field)); }
  float f32(const char* field) {
    uint32_t u = u32(field);
    float v;
    std::memcpy(&v, &u, 4);
    return v;
  }
  const uint8_t* take(size_t n, const char* field) {
    need(n, field);
    const uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }
  size_t remaining() const { return size_ - pos_; }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
  std::string what_;
};

json parse_json_field(const std::string& text, const char* name) {
  try {
    return json::parse(text);
  } catch (const json::exception&) {
    fail(std::string("TrainedForest::") + name + " is not valid JSON");
  }
}

}  // namespace

int heap_level(uint32_t heap_index) {
  int level = 0;
  uint64_t n = uint64_t(heap_index) + 1;
  while (n > 1) {
    n >>= 1;
    ++level;
  }
  return level;
}

uint32_t padded_leaf_slot(uint32_t heap_index, int depth) {
  uint64_t n = heap_index;
  for (int level = heap_level(heap_index); level < depth; ++level) n = 2 * n + 1;
  return static_cast<uint32_t>(n - ((uint64_t(1) << depth) - 1));
}

int TrainedTree::max_leaf_level() const {
  int m = 0;
  for (const TrainedNode& n : nodes)
    if (n.is_leaf()) m = std::max(m, heap_level(n.heap_index));
  return m;
}

void link_and_validate(TrainedForest& forest, const std::string& what) {
  if (forest.method != "bpc" && forest.method != "ojr")
    fail(what + ": method '" + forest.method + "' is neither bpc nor ojr");
  if (!(forest.reference_focal_px > 0) || !std::isfinite(forest.reference_focal_px))
    fail(what + ": reference focal length must be positive");
  if (forest.depth < 1 || forest.depth > kMaxForestDepth)
    fail(what + ": depth " + std::to_string(forest.depth) + " outside 1.." + std::to_string(kMaxForestDepth));
  if (forest.has_votes && (forest.votes_per_joint < 1 || forest.votes_per_joint > 64))
    fail(what + ": votes_per_joint must be 1..64 when the forest has votes");
  if (!forest.has_votes) forest.votes_per_joint = 0;
  if (forest.has_part_distributions && forest.part_names.empty())
    fail(what + ": part distributions without part names");
  if (forest.has_votes && forest.joint_names.empty()) fail(what + ": votes without joint names");
  if (forest.trees.empty()) fail(what + ": no trees");
  const size_t parts = forest.part_names.size();
  const size_t vote_row = forest.joint_names.size() * size_t(forest.votes_per_joint);
  for (size_t t = 0; t < forest.trees.size(); ++t) {
    TrainedTree& tree = forest.trees[t];
    const std::string where = what + ": tree " + std::to_string(t);
    if (tree.nodes.empty() || tree.nodes[0].heap_index != 0) fail(where + ": no root node");
    std::vector<uint8_t> leaf_used(tree.leaf_count(), 0);
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
      TrainedNode& n = tree.nodes[i];
      if (i > 0 && n.heap_index <= tree.nodes[i - 1].heap_index)
        fail(where + ": node heap indices not strictly increasing at node " + std::to_string(i));
      if (heap_level(n.heap_index) > forest.depth)
        fail(where + ": node " + std::to_string(n.heap_index) + " is deeper than depth " + std::to_string(forest.depth));
      if (i > 0) {
        const uint32_t parent = (n.heap_index - 1) / 2;
        auto it = std::lower_bound(tree.nodes.begin(), tree.nodes.begin() + i, parent,
                                   [](const TrainedNode& a, uint32_t h) { return a.heap_index < h; });
        if (it == tree.nodes.begin() + i || it->heap_index != parent || it->is_leaf())
          fail(where + ": node " + std::to_string(n.heap_index) + " has no split parent");
      }
      n.left = n.right = -1;
      if (n.is_leaf()) {
        if (size_t(n.leaf) >= tree.leaf_count() || leaf_used[n.leaf])
          fail(where + ": node " + std::to_string(n.heap_index) + " has a bad or repeated leaf index");
        leaf_used[n.leaf] = 1;
      } else {
        if (!std::isfinite(n.threshold_mm) || n.threshold_mm != std::floor(n.threshold_mm) ||
            n.threshold_mm < -32768.0f || n.threshold_mm > 32767.0f)
          fail(where + ": node " + std::to_string(n.heap_index) + " threshold is not a whole int16 value");
        if (heap_level(n.heap_index) >= forest.depth)
          fail(where + ": split node " + std::to_string(n.heap_index) + " at the maximum depth");
      }
    }
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
      TrainedNode& n = tree.nodes[i];
      if (n.is_leaf()) continue;
      for (int side = 0; side < 2; ++side) {
        const uint32_t child = 2 * n.heap_index + 1 + side;
        auto it = std::lower_bound(tree.nodes.begin() + i + 1, tree.nodes.end(), child,
                                   [](const TrainedNode& a, uint32_t h) { return a.heap_index < h; });
        if (it == tree.nodes.end() || it->heap_index != child)
          fail(where + ": split node " + std::to_string(n.heap_index) + " lacks child " + std::to_string(child));
        (side ? n.right : n.left) = static_cast<int32_t>(it - tree.nodes.begin());
      }
    }
    for (size_t l = 0; l < leaf_used.size(); ++l)
      if (!leaf_used[l]) fail(where + ": leaf record " + std::to_string(l) + " is not used by any node");
    if (forest.has_part_distributions) {
      if (tree.part_probabilities.size() != tree.leaf_count() * parts)
        fail(where + ": part distribution table has the wrong size");
      for (float p : tree.part_probabilities)
        if (!(p >= 0 && p <= 1.0001f)) fail(where + ": part probability outside [0,1]");
    } else if (!tree.part_probabilities.empty()) {
      fail(where + ": part distributions present but has_part_distributions is false");
    }
    if (forest.has_votes) {
      if (tree.votes.size() != tree.leaf_count() * vote_row) fail(where + ": vote table has the wrong size");
      for (const LeafVote& v : tree.votes)
        if (!std::isfinite(v.dx) || !std::isfinite(v.dy) || !std::isfinite(v.dz) || !(v.weight >= 0))
          fail(where + ": vote with a non-finite offset or negative weight");
    } else if (!tree.votes.empty()) {
      fail(where + ": votes present but has_votes is false");
    }
  }
}

std::vector<uint8_t> serialize_forest(const TrainedForest& forest) {
  json h;
  h["method"] = forest.method;
  h["reference_focal_px"] = forest.reference_focal_px;
  h["depth"] = forest.depth;
  h["parts"] = forest.part_names;
  h["joints"] = forest.joint_names;
  h["votes_per_joint"] = forest.votes_per_joint;
  h["has_part_distributions"] = forest.has_part_distributions;
  h["has_votes"] = forest.has_votes;
  h["tree_count"] = forest.trees.size();
  h["training"] = parse_json_field(forest.training_json, "training_json");
  h["datasets"] = parse_json_field(forest.datasets_json, "datasets_json");
  h["timings"] = parse_json_field(forest.timings_json, "timings_json");
  const std::string header = h.dump();

  Writer w;
  w.bytes(kForestMagic, 4);
  w.u32(kForestEndianTag);
  w.u16(kForestVersionMajor);
  w.u16(kForestVersionMinor);
  w.u32(static_cast<uint32_t>(header.size()));
  w.bytes(header.data(), header.size());
  for (const TrainedTree& tree : forest.trees) {
    w.u32(static_cast<uint32_t>(tree.nodes.size()));
    w.u32(static_cast<uint32_t>(tree.leaf_count()));
    for (const TrainedNode& n : tree.nodes) {
      w.u32(n.heap_index);
      w.i16(n.du1);
      w.i16(n.dv1);
      w.i16(n.du2);
      w.i16(n.dv2);
      w.f32(n.threshold_mm);
      w.u32(n.is_leaf() ? static_cast<uint32_t>(n.leaf) : kSplitMarker);
    }
    for (uint32_t c : tree.leaf_pixel_counts) w.u32(c);
    if (forest.has_part_distributions)
      for (float p : tree.part_probabilities) w.f32(p);
    if (forest.has_votes)
      for (const LeafVote& v : tree.votes) {
        w.f32(v.dx);
        w.f32(v.dy);
        w.f32(v.dz);
        w.f32(v.weight);
      }
  }
  const uint32_t crc = static_cast<uint32_t>(crc32(0L, w.out.data(), static_cast<uInt>(w.out.size())));
  w.u32(crc);
  return std::move(w.out);
}

TrainedForest parse_forest(const uint8_t* data, size_t size, const std::string& what) {
  if (size < kFixedHeaderBytes + 4) fail(what + ": truncated (only " + std::to_string(size) + " bytes)");
  if (std::memcmp(data, kForestMagic, 4) != 0) fail(what + ": not a trained-forest file (bad magic)");
  Reader r(data, size - 4, what);
  r.take(4, "magic");
  if (r.u32("endian tag") != kForestEndianTag) fail(what + ": wrong endianness tag");
  const uint16_t major = r.u16("version");
  const uint16_t minor = r.u16("version");
  if (major != kForestVersionMajor)
    fail(what + ": trained-forest version " + std::to_string(major) + "." + std::to_string(minor) +
         (major > kForestVersionMajor ? " is newer than" : " is older than") + " this build reads (" +
         std::to_string(kForestVersionMajor) + ".x)");
  uint32_t stored_crc = 0;
  for (int i = 0; i < 4; ++i) stored_crc |= uint32_t(data[size - 4 + i]) << (8 * i);
  const uint32_t crc = static_cast<uint32_t>(crc32(0L, data, static_cast<uInt>(size - 4)));
  if (crc != stored_crc) fail(what + ": CRC mismatch (file corrupt or truncated)");

  const uint32_t header_bytes = r.u32("header size");
  const uint8_t* header_text = r.take(header_bytes, "header JSON");
  TrainedForest f;
  size_t tree_count = 0;
  try {
    json h = json::parse(header_text, header_text + header_bytes);
    f.method = h.at("method").get<std::string>();
    f.reference_focal_px = h.at("reference_focal_px").get<float>();
    f.depth = int(json_integer_field(h, "depth", 0, 64, what));
    f.part_names = h.at("parts").get<std::vector<std::string>>();
    f.joint_names = h.at("joints").get<std::vector<std::string>>();
    f.votes_per_joint = int(json_integer_field(h, "votes_per_joint", 0, 64, what));
    f.has_part_distributions = h.at("has_part_distributions").get<bool>();
    f.has_votes = h.at("has_votes").get<bool>();
    tree_count = size_t(json_integer_field(h, "tree_count", 1, 64, what));
    f.training_json = h.value("training", json::object()).dump();
    f.datasets_json = h.value("datasets", json::array()).dump();
    f.timings_json = h.value("timings", json::object()).dump();
  } catch (const json::exception& e) {
    fail(what + ": bad header JSON: " + e.what());
  }
  if (tree_count < 1 || tree_count > 64) fail(what + ": implausible tree count " + std::to_string(tree_count));
  if (f.votes_per_joint < 0 || f.votes_per_joint > 64) fail(what + ": implausible votes_per_joint");
  const size_t parts = f.has_part_distributions ? f.part_names.size() : 0;
  const size_t vote_row = f.has_votes ? f.joint_names.size() * size_t(f.votes_per_joint) : 0;
  for (size_t t = 0; t < tree_count; ++t) {
    TrainedTree tree;
    const uint32_t node_count = r.u32("node count");
    const uint32_t leaf_count = r.u32("leaf count");
    if (uint64_t(node_count) * kNodeRecordBytes > r.remaining() || leaf_count > node_count)
      fail(what + ": tree " + std::to_string(t) + ": node/leaf counts exceed the file (truncated or corrupt)");
    const uint64_t leaf_bytes = uint64_t(leaf_count) * (4 + 4 * parts + 16 * vote_row);
    if (uint64_t(node_count) * kNodeRecordBytes + leaf_bytes > r.remaining())
      fail(what + ": tree " + std::to_string(t) + ": leaf tables exceed the file (truncated or corrupt)");
    tree.nodes.resize(node_count);
    for (TrainedNode& n : tree.nodes) {
      n.heap_index = r.u32("node");
      n.du1 = r.i16("node");
      n.dv1 = r.i16("node");
      n.du2 = r.i16("node");
      n.dv2 = r.i16("node");
      n.threshold_mm = r.f32("node");
      const uint32_t leaf = r.u32("node");
      if (leaf != kSplitMarker && leaf >= leaf_count)
        fail(what + ": tree " + std::to_string(t) + ": leaf index out of range");
      n.leaf = leaf == kSplitMarker ? -1 : static_cast<int32_t>(leaf);
    }
    tree.leaf_pixel_counts.resize(leaf_count);
    for (uint32_t& c : tree.leaf_pixel_counts) c = r.u32("leaf pixel count");
    tree.part_probabilities.resize(leaf_count * parts);
    for (float& p : tree.part_probabilities) p = r.f32("part distribution");
    tree.votes.resize(leaf_count * vote_row);
    for (LeafVote& v : tree.votes) {
      v.dx = r.f32("vote");
      v.dy = r.f32("vote");
      v.dz = r.f32("vote");
      v.weight = r.f32("vote");
    }
    f.trees.push_back(std::move(tree));
  }
  if (r.remaining() != 0) fail(what + ": " + std::to_string(r.remaining()) + " unexpected bytes after the last tree");
  link_and_validate(f, what);
  return f;
}

void write_forest(const std::string& path, const TrainedForest& forest) {
  const std::vector<uint8_t> bytes = serialize_forest(forest);
  tools::write_file_atomic(path, bytes.data(), bytes.size());  // temporary file removed on failure
}

TrainedForest read_forest(const std::string& path) {
  const std::vector<uint8_t> bytes = tools::read_file_bytes(path, "trained forest");
  return parse_forest(bytes.data(), bytes.size(), path);
}

void describe_forest(const TrainedForest& forest, std::ostream& out) {
  out << "trained forest: method " << forest.method << ", " << forest.trees.size() << " tree(s), depth ≤ "
      << forest.depth << ", reference focal " << forest.reference_focal_px << " px\n";
  out << "  parts: " << forest.part_names.size() << ", joints: " << forest.joint_names.size();
  if (forest.has_part_distributions) out << ", part distributions";
  if (forest.has_votes) out << ", " << forest.votes_per_joint << " vote(s) per leaf and joint";
  out << "\n";
  for (size_t t = 0; t < forest.trees.size(); ++t) {
    const TrainedTree& tree = forest.trees[t];
    double level_sum = 0, pixels = 0;
    int max_abs_offset = 0;
    for (const TrainedNode& n : tree.nodes) {
      if (n.is_leaf()) {
        level_sum += heap_level(n.heap_index) * double(tree.leaf_pixel_counts[n.leaf]);
        pixels += tree.leaf_pixel_counts[n.leaf];
      } else {
        for (int v : {n.du1, n.dv1, n.du2, n.dv2}) max_abs_offset = std::max(max_abs_offset, std::abs(v));
      }
    }
    out << "  tree " << t << ": " << tree.nodes.size() << " nodes, " << tree.leaf_count() << " leaves, deepest leaf level "
        << tree.max_leaf_level() << ", mean pixel leaf level " << std::fixed << std::setprecision(2)
        << (pixels > 0 ? level_sum / pixels : 0.0) << std::defaultfloat << ", training pixels " << uint64_t(pixels)
        << ", max |offset| " << max_abs_offset << " px·m\n";
  }
  out << "  training: " << forest.training_json << "\n";
  out << "  datasets: " << forest.datasets_json << "\n";
  out << "  timings (s): " << forest.timings_json << "\n";
}

std::vector<uint16_t> make_probe_image(const uint16_t* depth, const uint8_t* parts_or_null, int width,
                                       int height) {
  std::vector<uint16_t> probe(size_t(width) * height);
  for (size_t i = 0; i < probe.size(); ++i) {
    const uint16_t z = depth[i];
    const bool foreground = z > 0 && z < kBackgroundDepthMm && (!parts_or_null || parts_or_null[i] != 255);
    probe[i] = foreground ? z : kBackgroundDepthMm;
  }
  return probe;
}

int leaf_node_for_pixel(const TrainedTree& tree, const uint16_t* probe_image, int width, int height, int u,
                        int v, int32_t focal_factor) {
  const int32_t z = probe_image[size_t(v) * width + u];
  int pos = 0;
  while (!tree.nodes[pos].is_leaf()) {
    const TrainedNode& n = tree.nodes[pos];
    const int32_t feature =
        depth_feature(probe_image, width, height, u, v, z, focal_factor, n.du1, n.dv1, n.du2, n.dv2);
    pos = feature > static_cast<int32_t>(n.threshold_mm) ? n.right : n.left;
  }
  return pos;
}

}  // namespace dp::train
