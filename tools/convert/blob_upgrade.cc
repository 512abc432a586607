#include "tools/convert/blob_upgrade.h"

#include <cstring>

#include "forest_blob/blob_loader.h"
#include "tools/common/error.h"

namespace dp::tools {

namespace {
// Section kinds of the old formats (blob_upgrade.h): v1 meta, config, nodes, leaf index, dense
// leaves; v2 the same four, then leaf offsets, leaf entries, entry tags; v3 those seven, then left
// children.
constexpr uint32_t kV1SectionCount = 5;
constexpr uint32_t kV2SectionCount = 7;
constexpr uint32_t kV3SectionCount = 8;
constexpr uint32_t kMaxOldSections = kV3SectionCount;
}  // namespace

blob::BlobContents read_old_blob(const std::vector<uint8_t>& bytes, const std::string& what, int* version) {
  using namespace dp::blob;
  auto refuse = [&](const std::string& why) { fail(what + ": not a readable v1, v2 or v3 blob: " + why); };
  if (bytes.size() < sizeof(BlobHeader)) refuse("shorter than a header");
  BlobHeader h;
  std::memcpy(&h, bytes.data(), sizeof h);
  if (h.magic != kMagic || h.endian_tag != kEndianTag) refuse("bad magic or endianness tag");
  if (h.version_major < 1 || h.version_major > 3)
    refuse("format version " + std::to_string(h.version_major) + "." + std::to_string(h.version_minor) +
           ", not 1.x, 2.x or 3.x");
  const bool v3 = h.version_major == 3;
  const bool v2 = h.version_major >= 2;  // v2's compact leaves (v3 has them too)
  if (version) *version = h.version_major;
  const uint32_t kinds = v3 ? kV3SectionCount : v2 ? kV2SectionCount : kV1SectionCount;
  if (h.section_count != kinds || h.header_bytes != sizeof(BlobHeader) + kinds * sizeof(SectionEntry) ||
      h.total_bytes != bytes.size())
    refuse("header sizes disagree with the file (" + std::to_string(bytes.size()) + " bytes)");
  BlobHeader zeroed = h;
  zeroed.header_crc32 = 0;
  std::vector<uint8_t> head(bytes.begin(), bytes.begin() + h.header_bytes);
  std::memcpy(head.data(), &zeroed, sizeof zeroed);
  if (crc32(head.data(), head.size()) != h.header_crc32) refuse("header checksum mismatch");
  if (crc32(bytes.data() + h.header_bytes, bytes.size() - h.header_bytes) != h.payload_crc32)
    refuse("payload checksum mismatch");
  SectionEntry s[kMaxOldSections];
  std::memcpy(s, bytes.data() + sizeof h, kinds * sizeof(SectionEntry));
  const uint8_t* section[kMaxOldSections + 1] = {};
  uint64_t size[kMaxOldSections + 1] = {};
  for (uint32_t i = 0; i < kinds; ++i) {
    const SectionEntry& e = s[i];
    if (e.kind < 1 || e.kind > kinds || section[e.kind]) refuse("section table lists an unknown or repeated kind");
    if (e.offset < h.header_bytes || e.offset > bytes.size() || e.size > bytes.size() - e.offset)
      refuse("a section lies outside the file");
    section[e.kind] = bytes.data() + e.offset;
    size[e.kind] = e.size;
  }
  if (size[1] != (v3 ? sizeof(ForestMeta) : kLegacyMetaBytes) || size[2] != sizeof(RuntimeConfig))
    refuse("meta or config section size");
  ForestMeta m{};  // v1, v2: node_count stays 0 (they had none)
  std::memcpy(&m, section[1], size[1]);
  const bool bpc = m.method == uint8_t(Method::kBpc);
  if ((!bpc && m.method != uint8_t(Method::kOjr)) || m.tree_count < 1 || m.tree_count > kMaxTrees || m.depth < 1 ||
      m.depth > kMaxDepth || m.part_count > kMaxParts || m.joint_count > kMaxJoints ||
      m.votes_per_joint > kMaxVotesPerLeafJoint || (bpc && m.part_count == 0) ||
      (!bpc && m.joint_count * m.votes_per_joint == 0))
    refuse("meta counts out of range");
  const size_t nodes = nodes_per_heap(m.depth), slots = leaves_per_tree(m.depth);
  size_t v3_nodes = 0;  // v3: Σ node_count
  for (int t = 0; v3 && t < m.tree_count; ++t) {
    if (m.node_count[t] < 1 || m.node_count[t] > max_nodes_per_tree(m.depth)) refuse("a tree's node count is out of range");
    v3_nodes += m.node_count[t];
  }
  if (v3 ? size[3] != v3_nodes * sizeof(TreeNode) || size[4] != v3_nodes * sizeof(uint32_t) ||
               size[8] != v3_nodes * sizeof(uint32_t)
         : size[3] != m.tree_count * nodes * sizeof(TreeNode) || size[4] != m.tree_count * slots * sizeof(uint32_t))
    refuse("a tree section's size disagrees with the meta");

  BlobContents c;
  c.method = Method(m.method);
  c.depth = m.depth;
  c.reference_focal_px = m.reference_focal_px;
  for (int i = 0; i < m.part_count; ++i) c.part_names.emplace_back(m.part_names[i], strnlen(m.part_names[i], kNameBytes));
  for (int i = 0; i < m.joint_count; ++i) c.joint_names.emplace_back(m.joint_names[i], strnlen(m.joint_names[i], kNameBytes));
  c.votes_per_joint = bpc ? 0 : m.votes_per_joint;
  for (int t = 0, first = 0; v3 && t < m.tree_count; first += int(m.node_count[t]), ++t) {
    // Sparse already: copied as stored; write_blob checks the order and the records.
    const size_t n = m.node_count[t];
    std::vector<TreeNode> tn(n);
    std::vector<uint32_t> index(n), left(n);
    std::memcpy(tn.data(), section[3] + size_t(first) * sizeof(TreeNode), n * sizeof(TreeNode));
    std::memcpy(index.data(), section[4] + size_t(first) * sizeof(uint32_t), n * sizeof(uint32_t));
    std::memcpy(left.data(), section[8] + size_t(first) * sizeof(uint32_t), n * sizeof(uint32_t));
    c.tree_nodes.push_back(std::move(tn));
    c.tree_leaf_index.push_back(std::move(index));
    c.tree_left_child.push_back(std::move(left));
  }
  for (int t = 0; !v3 && t < m.tree_count; ++t) {
    std::vector<TreeNode> tn(nodes);
    std::memcpy(tn.data(), section[3] + t * nodes * sizeof(TreeNode), nodes * sizeof(TreeNode));
    std::vector<uint32_t> ti(slots);
    std::memcpy(ti.data(), section[4] + t * slots * sizeof(uint32_t), slots * sizeof(uint32_t));
    append_heap_tree(&c, tn, ti);
  }
  if (v2) {
    // Compact leaves: checked here as far as reading them needs; write_blob's load checks the rest.
    if (size[5] != (uint64_t(m.leaf_count) + 1) * sizeof(uint32_t) ||
        size[6] != uint64_t(m.entry_count) * leaf_entry_bytes(m) || size[7] != m.entry_count)
      refuse("a leaf section's size disagrees with the meta");
    std::vector<uint32_t> offsets(size_t(m.leaf_count) + 1);
    std::memcpy(offsets.data(), section[5], offsets.size() * sizeof(uint32_t));
    if (offsets[0] != 0 || offsets[m.leaf_count] != m.entry_count) refuse("leaf offsets do not span the entries");
    for (uint32_t l = 0; l < m.leaf_count; ++l)
      if (offsets[l + 1] < offsets[l]) refuse("leaf offsets decrease");
    for (uint32_t e = 0; e < m.entry_count; ++e)
      if (section[7][e] >= max_entries_per_leaf(m)) refuse("a leaf entry's tag is out of range");
    add_dense_leaves(m, offsets.data(), section[6], section[7], &c);
  } else {
    const uint32_t stride = m.entry_count;  // v1: leaf_stride_bytes
    const uint32_t min_stride = bpc ? 2u * m.part_count : uint32_t(m.joint_count) * m.votes_per_joint * sizeof(OjrVote);
    if (stride < min_stride || stride % 2 != 0)
      refuse("leaf stride " + std::to_string(stride) + " does not fit the method and counts");
    if (size[5] != uint64_t(m.leaf_count) * stride) refuse("the leaf section's size disagrees with the meta");
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
  }
  std::memcpy(&c.config, section[2], sizeof c.config);
  c.max_width = m.max_width;
  c.max_height = m.max_height;
  return c;
}

}  // namespace dp::tools
