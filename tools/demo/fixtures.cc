#include "tools/demo/fixtures.h"

#include <cmath>
#include <random>
#include <string>

namespace dp::tools {

CameraIntrinsics kinect_intrinsics(int width, int height) {
  const float f = 525.0f * float(width) / 640.0f;
  return CameraIntrinsics{f, f, (float(width) - 1.0f) * 0.5f, (float(height) - 1.0f) * 0.5f};
}

SyntheticFrame make_disc_frame(int width, int height, float cu, float cv, float radius, uint16_t depth) {
  SyntheticFrame f;
  f.width = width;
  f.height = height;
  f.intrinsics = kinect_intrinsics(width, height);
  f.depth_mm.assign(size_t(width) * height, 0);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u)
      if ((u - cu) * (u - cu) + (v - cv) * (v - cv) <= radius * radius) f.depth_mm[size_t(v) * width + u] = depth;
  return f;
}

SyntheticFrame make_plane_frame(int width, int height, float z0, float gu, float gv) {
  SyntheticFrame f;
  f.width = width;
  f.height = height;
  f.intrinsics = kinect_intrinsics(width, height);
  f.depth_mm.resize(size_t(width) * height);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u)
      f.depth_mm[size_t(v) * width + u] =
          uint16_t(std::lround(z0 + gu * (u - f.intrinsics.cx) + gv * (v - f.intrinsics.cy)));
  return f;
}

static std::vector<std::string> numbered(const char* stem, int n) {
  std::vector<std::string> out;
  for (int i = 0; i < n; ++i) out.push_back(std::string(stem) + std::to_string(i));
  return out;
}

blob::BlobContents single_part_bpc(int part_count, int part, int joint_count, int16_t push_back_mm, int depth,
                                   int trees) {
  blob::BlobContents c;
  c.method = blob::Method::kBpc;
  c.depth = depth;
  c.part_names = numbered("part", part_count);
  c.joint_names = numbered("joint", joint_count);
  for (int t = 0; t < trees; ++t) {  // a single leaf node: every pixel reaches record 0
    c.tree_nodes.push_back({blob::TreeNode{0, 0, 0, 0, blob::kPadThreshold}});
    c.tree_leaf_index.push_back({0u});
    c.tree_left_child.push_back({1u});
  }
  c.bpc_leaves.assign(size_t(part_count), 0);
  c.bpc_leaves[size_t(part)] = 32768;
  c.config = blob::default_runtime_config(joint_count);
  for (int j = 0; j < joint_count; ++j) {
    c.config.joints[j].part_mask = 1u << part;
    c.config.joints[j].push_back_mm = push_back_mm;
  }
  return c;
}

blob::BlobContents single_vote_ojr(int joint_count, int16_t dx, int16_t dy, int16_t dz) {
  blob::BlobContents c;
  c.method = blob::Method::kOjr;
  c.depth = 1;
  c.votes_per_joint = 1;
  c.joint_names = numbered("joint", joint_count);
  c.tree_nodes.push_back({blob::TreeNode{0, 0, 0, 0, blob::kPadThreshold}});  // one leaf node
  c.tree_leaf_index.push_back({0u});
  c.tree_left_child.push_back({1u});
  for (int j = 0; j < joint_count; ++j) c.ojr_leaves.push_back(blob::OjrVote{dx, dy, dz, 1});
  c.config = blob::default_runtime_config(joint_count);
  for (int j = 0; j < joint_count; ++j) c.config.joints[j].vote_length_mm = 0;  // no limit
  return c;
}

// The empty BPC forest the random fixtures fill: one joint, part_count numbered parts.
static blob::BlobContents random_forest_frame(int depth, int part_count) {
  blob::BlobContents c;
  c.method = blob::Method::kBpc;
  c.depth = depth;
  c.part_names = numbered("part", part_count);
  c.joint_names = numbered("joint", 1);
  return c;
}

// A random split node: offsets within ±max_offset (half of them unary), threshold within ±thresh_range.
template <class Uniform>
blob::TreeNode random_split_node(Uniform& uni, int max_offset, int thresh_range) {
  blob::TreeNode n;
  n.du1 = int16_t(uni(-max_offset, max_offset));
  n.dv1 = int16_t(uni(-max_offset, max_offset));
  const bool unary = uni(0, 1) == 0;
  n.du2 = unary ? 0 : int16_t(uni(-max_offset, max_offset));
  n.dv2 = unary ? 0 : int16_t(uni(-max_offset, max_offset));
  n.threshold_mm = int16_t(uni(-thresh_range, thresh_range));
  return n;
}

blob::BlobContents random_bpc_forest(uint64_t seed, int trees, int depth, int part_count, int max_offset,
                                     int thresh_range) {
  std::mt19937_64 rng(seed);
  auto uni = [&](int lo, int hi) { return int(std::uniform_int_distribution<int>(lo, hi)(rng)); };
  blob::BlobContents c = random_forest_frame(depth, part_count);
  const uint32_t leaves = uint32_t(std::min<size_t>(4096, blob::leaves_per_tree(depth)));
  for (int t = 0; t < trees; ++t) {
    std::vector<blob::TreeNode> nodes(blob::nodes_per_heap(depth));
    for (auto& n : nodes) n = random_split_node(uni, max_offset, thresh_range);
    std::vector<uint32_t> index(blob::leaves_per_tree(depth));
    for (auto& i : index) i = uint32_t(uni(0, int(leaves) - 1));
    blob::append_heap_tree(&c, nodes, index);
  }
  for (uint32_t l = 0; l < leaves; ++l) {
    std::vector<uint32_t> raw(static_cast<size_t>(part_count));
    uint64_t sum = 0;
    for (auto& r : raw) sum += (r = uint32_t(uni(0, 1000)));
    for (int p = 0; p < part_count; ++p) c.bpc_leaves.push_back(uint16_t(sum ? raw[p] * 32768ull / sum : 0));
  }
  c.config = blob::default_runtime_config(1);
  c.config.joints[0].part_mask = 1u;
  return c;
}

blob::BlobContents random_sparse_bpc_forest(uint64_t seed, int trees, int depth, int part_count, int max_offset,
                                            int thresh_range, int split_per_mille, uint32_t max_nodes_per_tree) {
  std::mt19937_64 rng(seed);
  auto uni = [&](int lo, int hi) { return int(std::uniform_int_distribution<int>(lo, hi)(rng)); };
  blob::BlobContents c = random_forest_frame(depth, part_count);
  uint32_t records = 0;
  for (int t = 0; t < trees; ++t) {
    std::vector<blob::TreeNode> nodes;
    std::vector<uint32_t> index, left;
    // Breadth-first: node m's level in `levels`; the children of the k-th split are 2k, 2k + 1.
    std::vector<uint8_t> levels{0};
    uint32_t splits = 0;
    for (size_t q = 0; q < levels.size(); ++q) {
      const int level = levels[q];
      const bool leftmost = q == 0 || levels[q - 1] != level;
      const bool split = level < depth && levels.size() + 2 <= max_nodes_per_tree &&
                         (leftmost || uni(0, 999) < split_per_mille);
      if (!split) {
        nodes.push_back(blob::TreeNode{0, 0, 0, 0, blob::kPadThreshold});
        index.push_back(records++);
        left.push_back(uint32_t(q + 1));
        continue;
      }
      nodes.push_back(random_split_node(uni, max_offset, thresh_range));
      index.push_back(0);
      left.push_back(2 * ++splits);
      levels.push_back(uint8_t(level + 1));
      levels.push_back(uint8_t(level + 1));
    }
    c.tree_nodes.push_back(std::move(nodes));
    c.tree_leaf_index.push_back(std::move(index));
    c.tree_left_child.push_back(std::move(left));
  }
  for (uint32_t l = 0; l < records; ++l) {
    const int part = uni(0, part_count - 1);
    for (int p = 0; p < part_count; ++p) c.bpc_leaves.push_back(p == part ? 32768 : 0);
  }
  c.config = blob::default_runtime_config(1);
  c.config.joints[0].part_mask = 1;
  return c;
}

}  // namespace dp::tools
