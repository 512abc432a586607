#include "forest_blob/blob_writer.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "forest_blob/blob_loader.h"
#include "runtime/depthpose.h"
#include "tools/common/error.h"
#include "tools/common/file_io.h"

namespace dp::blob {
using dp::tools::fail;

RuntimeConfig default_runtime_config(int joint_count) {
  RuntimeConfig c{};
  for (int j = 0; j < joint_count && j < kMaxJoints; ++j) {
    c.joints[j].part_mask = 0;
    c.joints[j].prob_threshold_q15 = 3277;  // 0.10
    c.joints[j].push_back_mm = 40;          // the paper's mean learned push-back
    c.joints[j].bandwidth_mm = 65;
    c.joints[j].vote_length_mm = 400;
  }
  c.near_mm = 300;
  c.far_mm = 8000;
  c.max_votes_per_joint = 200;
  c.max_starts_per_joint = 24;
  c.mean_shift_iterations = 12;
  c.max_proposals_per_joint = 4;
  c.merge_tolerance_mm = 30;
  c.max_evaluated_pixels = 20000;
  c.cycle_budget = 0;
  return c;
}

namespace {
void put_name(char (&dst)[kNameBytes], const std::string& name, const char* what) {
  if (name.size() >= size_t(kNameBytes)) fail(std::string(what) + " name '" + name + "' is longer than 23 bytes");
  for (char ch : name)
    if (ch < 0x20 || ch > 0x7E) fail(std::string(what) + " name '" + name + "' is not printable ASCII");
  std::memset(dst, 0, kNameBytes);
  std::memcpy(dst, name.data(), name.size());
}
size_t align_up(size_t v) { return (v + kSectionAlignment - 1) / kSectionAlignment * kSectionAlignment; }
}  // namespace

namespace {
// Tree t of `in` as v4 stores it: checks that the sparse tables are breadth first (the k-th split node's
// children are 2k, 2k + 1; a leaf node is its own left child, has the pad threshold and zero offsets,
// and a record < records), then appends its split flags, split nodes and, per leaf node in node order,
// the record it reads (v4 numbers records by leaf node: a record two leaf nodes share is stored
// twice, one no leaf node reads is dropped).
void append_v4_tree(const BlobContents& in, int t, size_t records, std::vector<uint8_t>* flags,
                    std::vector<TreeNode>* splits, std::vector<uint32_t>* leaf_records) {
  const auto& nodes = in.tree_nodes[size_t(t)];
  const auto& left = in.tree_left_child[size_t(t)];
  const auto& index = in.tree_leaf_index[size_t(t)];
  const size_t n = nodes.size();
  const std::string tree = "tree " + std::to_string(t);
  if (n % 2 == 0) fail(tree + " has an even node count (" + std::to_string(n) + "): not a full binary tree");
  const size_t first_flag = flags->size();
  flags->resize(first_flag + split_flag_bytes_of(uint32_t(n)), 0);
  uint32_t next_child = 2;
  for (uint32_t m = 1; m <= n; ++m) {
    const TreeNode& nd = nodes[m - 1];
    if (left[m - 1] == m) {
      if (nd.threshold_mm != kPadThreshold || nd.du1 != 0 || nd.dv1 != 0 || nd.du2 != 0 || nd.dv2 != 0)
        fail(tree + ": leaf node " + std::to_string(m) + " lacks the pad threshold or has nonzero probe offsets");
      if (index[m - 1] >= records)
        fail(tree + ": leaf node " + std::to_string(m) + " reads record " + std::to_string(index[m - 1]) + " of " +
             std::to_string(records));
      leaf_records->push_back(index[m - 1]);
      continue;
    }
    if (left[m - 1] != next_child || next_child + 1 > n)
      fail(tree + ": split node " + std::to_string(m) + " has left child " + std::to_string(left[m - 1]) +
           ", breadth-first order needs " + std::to_string(next_child) + " within " + std::to_string(n) + " nodes");
    next_child += 2;
    (*flags)[first_flag + (m - 1) / 8] |= uint8_t(1u << ((m - 1) % 8));
    splits->push_back(nd);
  }
  if (next_child - 1 != n) fail(tree + ": " + std::to_string(n - (next_child - 1)) + " nodes are no split node's child");
}
}  // namespace

std::vector<uint8_t> write_blob(const BlobContents& in) {
  const bool bpc = in.method == Method::kBpc;
  const int trees = int(in.tree_nodes.size());
  if (trees < 1 || trees > kMaxTrees) fail("blob needs 1.." + std::to_string(kMaxTrees) + " trees, got " + std::to_string(trees));
  if (in.depth < 1 || in.depth > kMaxDepth) fail("tree depth " + std::to_string(in.depth) + " outside 1..20");
  if (int(in.tree_leaf_index.size()) != trees || int(in.tree_left_child.size()) != trees)
    fail("leaf index or child tables do not match the tree count");
  if (in.part_names.size() > size_t(kMaxParts)) fail("too many parts");
  if (in.joint_names.size() > size_t(kMaxJoints)) fail("too many joints");

  ForestMeta meta{};
  meta.method = uint8_t(in.method);
  meta.tree_count = uint8_t(trees);
  meta.depth = uint8_t(in.depth);
  meta.part_count = uint8_t(in.part_names.size());
  meta.joint_count = uint8_t(in.joint_names.size());
  meta.votes_per_joint = uint8_t(bpc ? 0 : in.votes_per_joint);
  meta.reference_focal_px = in.reference_focal_px;
  for (size_t i = 0; i < in.part_names.size(); ++i) put_name(meta.part_names[i], in.part_names[i], "part");
  for (size_t i = 0; i < in.joint_names.size(); ++i) put_name(meta.joint_names[i], in.joint_names[i], "joint");
  size_t per_leaf = 0;
  if (bpc) {
    per_leaf = in.part_names.size();
    if (per_leaf == 0 || in.bpc_leaves.size() % per_leaf != 0) fail("BPC leaf table size is not a multiple of the part count");
  } else {
    per_leaf = in.joint_names.size() * size_t(in.votes_per_joint);
    if (per_leaf == 0 || in.ojr_leaves.size() % per_leaf != 0) fail("OJR vote table size is not a multiple of joints × K");
  }
  const size_t records = (bpc ? in.bpc_leaves.size() : in.ojr_leaves.size()) / per_leaf;

  // Trees: split flags and split nodes; the record each leaf node reads, in leaf-node order.
  std::vector<uint8_t> flags;
  std::vector<TreeNode> splits;
  std::vector<uint32_t> leaf_records;
  uint32_t max_off = 0;
  for (int t = 0; t < trees; ++t) {
    const size_t n = in.tree_nodes[size_t(t)].size();
    if (n < 1 || n > max_nodes_per_tree(in.depth)) fail("tree " + std::to_string(t) + " has " + std::to_string(n) +
                                                         " nodes; depth " + std::to_string(in.depth) + " allows 1.." +
                                                         std::to_string(max_nodes_per_tree(in.depth)));
    if (in.tree_leaf_index[size_t(t)].size() != n || in.tree_left_child[size_t(t)].size() != n)
      fail("tree " + std::to_string(t) + ": leaf index or child table length differs from its node count");
    meta.node_count[t] = uint32_t(n);
    append_v4_tree(in, t, records, &flags, &splits, &leaf_records);
  }
  for (const TreeNode& nd : splits)
    for (int16_t d : {nd.du1, nd.dv1, nd.du2, nd.dv2}) max_off = std::max<uint32_t>(max_off, uint32_t(std::abs(int(d))));
  meta.max_abs_offset_pxm = max_off;

  // Compact leaves, one record per leaf node: the record's nonzero entries, tagged by part / lane.
  std::vector<uint32_t> leaf_offsets{0};
  std::vector<uint8_t> entry_bytes, tags;
  for (uint32_t r : leaf_records) {
    for (size_t i = 0; i < per_leaf; ++i) {
      const size_t at = size_t(r) * per_leaf + i;
      if (bpc && in.bpc_leaves[at] != 0) {
        const uint16_t q = in.bpc_leaves[at];
        entry_bytes.insert(entry_bytes.end(), reinterpret_cast<const uint8_t*>(&q), reinterpret_cast<const uint8_t*>(&q) + 2);
        tags.push_back(uint8_t(i));
      } else if (!bpc && in.ojr_leaves[at].weight != 0) {
        const OjrVote& v = in.ojr_leaves[at];
        entry_bytes.insert(entry_bytes.end(), reinterpret_cast<const uint8_t*>(&v), reinterpret_cast<const uint8_t*>(&v) + sizeof v);
        tags.push_back(uint8_t(i));
      }
    }
    leaf_offsets.push_back(uint32_t(tags.size()));
  }
  meta.leaf_count = uint32_t(leaf_records.size());
  meta.entry_count = uint32_t(tags.size());
  meta.max_width = in.max_width;
  meta.max_height = in.max_height;

  // Sections in kind order: meta, config, split nodes, split flags, leaf offsets, leaf entries, entry tags.
  const uint32_t section_count = kSectionKinds;
  const size_t header_bytes = sizeof(BlobHeader) + section_count * sizeof(SectionEntry);
  SectionEntry entries[kSectionKinds]{};
  const size_t sizes[kSectionKinds] = {sizeof(ForestMeta), sizeof(RuntimeConfig), splits.size() * sizeof(TreeNode),
                                       flags.size(), leaf_offsets.size() * sizeof(uint32_t), entry_bytes.size(),
                                       tags.size()};
  size_t at = align_up(header_bytes);
  for (uint32_t i = 0; i < section_count; ++i) {
    entries[i].kind = i + 1;
    entries[i].offset = at;
    entries[i].size = sizes[i];
    at = align_up(at + sizes[i]);
  }
  const size_t total = entries[kSectionKinds - 1].offset + entries[kSectionKinds - 1].size;  // the last section's end
  std::vector<uint8_t> out(total, 0);

  RuntimeConfig config = in.config;
  // Arena size for the declared maximum frame: computed from a provisional view of the blob.
  std::memcpy(out.data() + entries[1].offset, &config, sizeof config);
  if (!splits.empty()) std::memcpy(out.data() + entries[2].offset, splits.data(), splits.size() * sizeof(TreeNode));
  std::memcpy(out.data() + entries[3].offset, flags.data(), flags.size());
  std::memcpy(out.data() + entries[4].offset, leaf_offsets.data(), leaf_offsets.size() * sizeof(uint32_t));
  if (!entry_bytes.empty()) std::memcpy(out.data() + entries[5].offset, entry_bytes.data(), entry_bytes.size());
  if (!tags.empty()) std::memcpy(out.data() + entries[6].offset, tags.data(), tags.size());

  auto finish = [&]() {
    std::memcpy(out.data() + entries[0].offset, &meta, sizeof meta);
    BlobHeader h{};
    h.magic = kMagic;
    h.endian_tag = kEndianTag;
    h.version_major = kVersionMajor;
    h.version_minor = kVersionMinor;
    h.header_bytes = uint32_t(header_bytes);
    h.total_bytes = total;
    h.section_count = section_count;
    h.payload_crc32 = crc32(out.data() + header_bytes, total - header_bytes);
    std::memcpy(out.data(), &h, sizeof h);
    std::memcpy(out.data() + sizeof h, entries, sizeof entries);
    h.header_crc32 = crc32(out.data(), header_bytes);
    std::memcpy(out.data(), &h, sizeof h);
  };
  finish();
  LoadedBlob view;
  BlobStatus s = load_blob(out.data(), out.size(), &view);
  if (s != BlobStatus::kOk) fail(std::string("refusing to write an invalid blob: ") + blob_status_message(s));
  meta.arena_bytes = required_arena_bytes(view, int32_t(in.max_width), int32_t(in.max_height));
  finish();
  s = load_blob(out.data(), out.size(), &view);
  if (s != BlobStatus::kOk) fail(std::string("refusing to write an invalid blob: ") + blob_status_message(s));
  return out;
}

void append_heap_tree(BlobContents* c, const std::vector<TreeNode>& heap_nodes, const std::vector<uint32_t>& slot_leaf_index) {
  const int depth = c->depth;
  if (depth < 1 || depth > kMaxDepth) fail("tree depth " + std::to_string(depth) + " outside 1..20");
  const size_t first_slot = nodes_per_heap(depth);
  if (heap_nodes.size() != first_slot || slot_leaf_index.size() != leaves_per_tree(depth))
    fail("a heap-order tree of depth " + std::to_string(depth) + " needs " + std::to_string(first_slot) + " nodes and " +
         std::to_string(leaves_per_tree(depth)) + " leaf slots");
  std::vector<TreeNode> nodes;
  std::vector<uint32_t> leaf_index, left_child;
  // Breadth-first over the heap: a queue of heap positions (≥ first_slot: a leaf slot) in the order
  // their sparse indices are given, so the k-th split node's children get indices 2k, 2k + 1.
  std::vector<uint64_t> queue{0};
  for (size_t q = 0; q < queue.size(); ++q) {
    const uint64_t h = queue[q];
    const uint32_t m = uint32_t(q + 1);
    if (h < first_slot && heap_nodes[h].threshold_mm != kPadThreshold) {
      nodes.push_back(heap_nodes[h]);
      leaf_index.push_back(0);
      left_child.push_back(uint32_t(queue.size() + 1));
      queue.push_back(2 * h + 1);
      queue.push_back(2 * h + 2);
      continue;
    }
    uint64_t slot = h;  // always left from a pad node: its leftmost slot
    while (slot < first_slot) slot = 2 * slot + 1;
    nodes.push_back(kLeafNode);
    leaf_index.push_back(slot_leaf_index[slot - first_slot]);
    left_child.push_back(m);
  }
  c->tree_nodes.push_back(std::move(nodes));
  c->tree_leaf_index.push_back(std::move(leaf_index));
  c->tree_left_child.push_back(std::move(left_child));
}

void add_dense_leaves(const ForestMeta& m, const uint32_t* offsets, const uint8_t* entries, const uint8_t* tags,
                      BlobContents* c) {
  const bool bpc = m.method == uint8_t(Method::kBpc);
  const size_t per_leaf = size_t(max_entries_per_leaf(m));
  if (bpc)
    c->bpc_leaves.assign(size_t(m.leaf_count) * per_leaf, 0);
  else
    c->ojr_leaves.assign(size_t(m.leaf_count) * per_leaf, OjrVote{0, 0, 0, 0});
  for (uint32_t l = 0; l < m.leaf_count; ++l)
    for (uint32_t e = offsets[l]; e < offsets[l + 1]; ++e) {
      const size_t at = size_t(l) * per_leaf + tags[e];
      if (bpc)
        std::memcpy(&c->bpc_leaves[at], entries + size_t(e) * sizeof(uint16_t), sizeof(uint16_t));
      else
        std::memcpy(&c->ojr_leaves[at], entries + size_t(e) * sizeof(OjrVote), sizeof(OjrVote));
    }
}

BlobContents dense_contents(const LoadedBlob& b) {
  const ForestMeta& m = *b.meta;
  BlobContents c;
  c.method = b.method();
  c.depth = m.depth;
  c.reference_focal_px = m.reference_focal_px;
  for (int i = 0; i < m.part_count; ++i) c.part_names.emplace_back(m.part_names[i], strnlen(m.part_names[i], kNameBytes));
  for (int i = 0; i < m.joint_count; ++i) c.joint_names.emplace_back(m.joint_names[i], strnlen(m.joint_names[i], kNameBytes));
  c.votes_per_joint = c.method == Method::kOjr ? m.votes_per_joint : 0;
  for (int t = 0; t < b.tree_count(); ++t) {
    std::vector<TreeNode> nodes;
    std::vector<uint32_t> leaf_index, left_child;
    for_each_tree_node(b, t, [&](uint32_t, const TreeNode& node, uint32_t left, uint32_t record) {
      nodes.push_back(node);
      left_child.push_back(left);
      leaf_index.push_back(record);
    });
    c.tree_nodes.push_back(std::move(nodes));
    c.tree_leaf_index.push_back(std::move(leaf_index));
    c.tree_left_child.push_back(std::move(left_child));
  }
  add_dense_leaves(m, b.leaf_offsets, b.leaf_entries, b.entry_tags, &c);
  c.config = *b.config;
  c.max_width = m.max_width;
  c.max_height = m.max_height;
  return c;
}

void save_blob_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  tools::write_file_atomic(path, bytes.data(), bytes.size());
}

std::vector<uint8_t> read_blob_file(const std::string& path) { return tools::read_file_bytes(path, "blob"); }

}  // namespace dp::blob
