#include "tools/convert/blob_upgrade.h"

#include <cstring>

#include "forest_blob/blob_loader.h"
#include "tools/common/error.h"

namespace dp::tools {

namespace {
constexpr uint32_t kV1SectionCount = 5;  // meta, config, nodes, leaf index, dense leaves
}  // namespace

blob::BlobContents read_v1_blob(const std::vector<uint8_t>& bytes, const std::string& what) {
  using namespace dp::blob;
  auto refuse = [&](const std::string& why) { fail(what + ": not a readable v1 blob: " + why); };
  if (bytes.size() < sizeof(BlobHeader)) refuse("shorter than a header");
  BlobHeader h;
  std::memcpy(&h, bytes.data(), sizeof h);
  if (h.magic != kMagic || h.endian_tag != kEndianTag) refuse("bad magic or endianness tag");
  if (h.version_major != 1)
    refuse("format version " + std::to_string(h.version_major) + "." + std::to_string(h.version_minor) + ", not 1.x");
  if (h.section_count != kV1SectionCount || h.header_bytes != sizeof(BlobHeader) + kV1SectionCount * sizeof(SectionEntry) ||
      h.total_bytes != bytes.size())
    refuse("header sizes disagree with the file (" + std::to_string(bytes.size()) + " bytes)");
  BlobHeader zeroed = h;
  zeroed.header_crc32 = 0;
  std::vector<uint8_t> head(bytes.begin(), bytes.begin() + h.header_bytes);
  std::memcpy(head.data(), &zeroed, sizeof zeroed);
  if (crc32(head.data(), head.size()) != h.header_crc32) refuse("header checksum mismatch");
  if (crc32(bytes.data() + h.header_bytes, bytes.size() - h.header_bytes) != h.payload_crc32)
    refuse("payload checksum mismatch");
  SectionEntry s[kV1SectionCount];
  std::memcpy(s, bytes.data() + sizeof h, sizeof s);
  const uint8_t* section[kV1SectionCount + 1] = {};
  uint64_t size[kV1SectionCount + 1] = {};
  for (const SectionEntry& e : s) {
    if (e.kind < 1 || e.kind > kV1SectionCount || section[e.kind]) refuse("section table lists an unknown or repeated kind");
    if (e.offset < h.header_bytes || e.offset > bytes.size() || e.size > bytes.size() - e.offset)
      refuse("a section lies outside the file");
    section[e.kind] = bytes.data() + e.offset;
    size[e.kind] = e.size;
  }
  if (size[1] != sizeof(ForestMeta) || size[2] != sizeof(RuntimeConfig)) refuse("meta or config section size");
  ForestMeta m;
  std::memcpy(&m, section[1], sizeof m);
  const uint32_t stride = m.entry_count;  // v1: leaf_stride_bytes
  const bool bpc = m.method == uint8_t(Method::kBpc);
  if ((!bpc && m.method != uint8_t(Method::kOjr)) || m.tree_count < 1 || m.tree_count > kMaxTrees || m.depth < 1 ||
      m.depth > kMaxDepth || m.part_count > kMaxParts || m.joint_count > kMaxJoints ||
      m.votes_per_joint > kMaxVotesPerLeafJoint)
    refuse("meta counts out of range");
  const uint32_t min_stride = bpc ? 2u * m.part_count : uint32_t(m.joint_count) * m.votes_per_joint * sizeof(OjrVote);
  if (stride < min_stride || stride % 2 != 0 || (bpc && m.part_count == 0) || (!bpc && min_stride == 0))
    refuse("leaf stride " + std::to_string(stride) + " does not fit the method and counts");
  const size_t nodes = blob::nodes_per_tree(m.depth), slots = blob::leaves_per_tree(m.depth);
  if (size[3] != m.tree_count * nodes * sizeof(TreeNode) || size[4] != m.tree_count * slots * sizeof(uint32_t) ||
      size[5] != uint64_t(m.leaf_count) * stride)
    refuse("a section's size disagrees with the meta");

  BlobContents c;
  c.method = Method(m.method);
  c.depth = m.depth;
  c.reference_focal_px = m.reference_focal_px;
  for (int i = 0; i < m.part_count; ++i) c.part_names.emplace_back(m.part_names[i], strnlen(m.part_names[i], kNameBytes));
  for (int i = 0; i < m.joint_count; ++i) c.joint_names.emplace_back(m.joint_names[i], strnlen(m.joint_names[i], kNameBytes));
  c.votes_per_joint = bpc ? 0 : m.votes_per_joint;
  for (int t = 0; t < m.tree_count; ++t) {
    std::vector<TreeNode> tn(nodes);
    std::memcpy(tn.data(), section[3] + t * nodes * sizeof(TreeNode), nodes * sizeof(TreeNode));
    std::vector<uint32_t> ti(slots);
    std::memcpy(ti.data(), section[4] + t * slots * sizeof(uint32_t), slots * sizeof(uint32_t));
    c.tree_nodes.push_back(std::move(tn));
    c.tree_leaf_index.push_back(std::move(ti));
  }
  for (uint32_t l = 0; l < m.leaf_count; ++l) {
    const uint8_t* record = section[5] + size_t(l) * stride;
    if (bpc) {
      const size_t at = c.bpc_leaves.size();
      c.bpc_leaves.resize(at + m.part_count);
      std::memcpy(&c.bpc_leaves[at], record, m.part_count * sizeof(uint16_t));
    } else {
      const size_t per_leaf = size_t(m.joint_count) * m.votes_per_joint, at = c.ojr_leaves.size();
      c.ojr_leaves.resize(at + per_leaf);
      std::memcpy(&c.ojr_leaves[at], record, per_leaf * sizeof(OjrVote));
    }
  }
  std::memcpy(&c.config, section[2], sizeof c.config);
  c.max_width = m.max_width;
  c.max_height = m.max_height;
  return c;
}

}  // namespace dp::tools
