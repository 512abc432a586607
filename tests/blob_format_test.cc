// forest_blob v3: round trip (compact leaves back to the dense contents), every refusal the loader
// promises (sparse-tree shape included), truncation at every section boundary, every single-bit flip,
// and the v1 and v2 upgrades (the same leaf for every pixel).
#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <random>
#include <set>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "runtime/fixed_point.h"
#include "runtime/kernels/forest_kernel.h"
#include "tools/common/error.h"
#include "tools/convert/blob_upgrade.h"
#include "tools/demo/fixtures.h"

using namespace dp;
using namespace dp::blob;

namespace {

// 8-byte aligned copy, as the loader requires.
struct AlignedBytes {
  std::vector<uint64_t> storage;
  size_t size;
  explicit AlignedBytes(const std::vector<uint8_t>& b) : storage((b.size() + 7) / 8 + 1), size(b.size()) {
    if (!b.empty()) std::memcpy(storage.data(), b.data(), b.size());
  }
  uint8_t* data() { return reinterpret_cast<uint8_t*>(storage.data()); }
};

BlobStatus load(const std::vector<uint8_t>& bytes, LoadedBlob* out = nullptr) {
  AlignedBytes a(bytes);
  LoadedBlob tmp;
  return load_blob(a.data(), a.size, out ? out : &tmp);
}

BlobHeader header_of(const std::vector<uint8_t>& b) {
  BlobHeader h;
  std::memcpy(&h, b.data(), sizeof h);
  return h;
}

// Recomputes both CRCs so a deliberate edit reaches the structural checks.
void reseal(std::vector<uint8_t>& b) {
  BlobHeader h = header_of(b);
  h.payload_crc32 = crc32(b.data() + h.header_bytes, b.size() - h.header_bytes);
  h.header_crc32 = 0;
  std::memcpy(b.data(), &h, sizeof h);
  h.header_crc32 = crc32(b.data(), h.header_bytes);
  std::memcpy(b.data(), &h, sizeof h);
}

SectionEntry section(const std::vector<uint8_t>& b, SectionKind kind) {
  BlobHeader h = header_of(b);
  for (uint32_t i = 0; i < h.section_count; ++i) {
    SectionEntry e;
    std::memcpy(&e, b.data() + sizeof(BlobHeader) + i * sizeof e, sizeof e);
    if (e.kind == uint32_t(kind)) return e;
  }
  return SectionEntry{};
}

template <typename T>
void edit(std::vector<uint8_t>& b, size_t offset, const T& value) {
  std::memcpy(b.data() + offset, &value, sizeof value);
}

std::vector<uint8_t> small_bpc() { return write_blob(tools::single_part_bpc(5, 3, 2, 40, 3, 2)); }
std::vector<uint8_t> small_ojr() { return write_blob(tools::single_vote_ojr(3, 10, -20, 30)); }

}  // namespace

TEST(BlobFormat, RoundTripBpc) {
  auto contents = tools::random_bpc_forest(7, 3, 6, 31, 200, 500);
  contents.config.joints[0].push_back_mm = 33;
  auto bytes = write_blob(contents);
  AlignedBytes a(bytes);
  LoadedBlob b;
  ASSERT_EQ(load_blob(a.data(), a.size, &b), BlobStatus::kOk);
  EXPECT_EQ(b.tree_count(), 3);
  EXPECT_EQ(b.depth(), 6);
  EXPECT_EQ(b.meta->part_count, 31);
  EXPECT_STREQ(b.meta->part_names[30], "part30");
  EXPECT_EQ(b.config->joints[0].push_back_mm, 33);
  // The derived tables equal the given ones node for node; every leaf node's record holds the
  // distribution of the record the contents gave it.
  std::vector<TreeNode> nodes(b.total_nodes);
  std::vector<uint32_t> left(b.total_nodes), record(b.total_nodes);
  expand_tree_tables(b, nodes.data(), left.data(), record.data());
  const BlobContents back = dense_contents(b);
  for (int t = 0; t < 3; ++t) {
    ASSERT_EQ(b.tree_node_count(t), contents.tree_nodes[t].size());
    for (size_t n = 0; n < contents.tree_nodes[t].size(); ++n) {
      const size_t i = b.tree_first[t] + n;
      EXPECT_EQ(nodes[i].du1, contents.tree_nodes[t][n].du1);
      EXPECT_EQ(nodes[i].threshold_mm, contents.tree_nodes[t][n].threshold_mm);
      EXPECT_EQ(left[i], contents.tree_left_child[t][n]);
      if (left[i] != n + 1) continue;
      const size_t given = contents.tree_leaf_index[t][n];
      EXPECT_TRUE(std::equal(back.bpc_leaves.begin() + record[i] * 31, back.bpc_leaves.begin() + record[i] * 31 + 31,
                             contents.bpc_leaves.begin() + given * 31))
          << "compact leaves must hold exactly the dense distributions";
    }
  }
  EXPECT_EQ(write_blob(back), bytes);
  EXPECT_LT(b.meta->entry_count, b.meta->leaf_count * 31u) << "zero probabilities are not stored";
  EXPECT_GT(b.meta->arena_bytes, 0u);
  EXPECT_EQ(b.meta->arena_bytes, required_arena_bytes(b, 640, 480));
}

TEST(BlobFormat, RoundTripOjrAndDeterministic) {
  auto a = small_ojr(), b = small_ojr();
  EXPECT_EQ(a, b) << "identical input must give byte-identical blobs";
  LoadedBlob view;
  ASSERT_EQ(load(a, &view), BlobStatus::kOk);
  // `view` points into a temporary copy inside load(); check values through a fresh load instead.
  AlignedBytes bytes(a);
  ASSERT_EQ(load_blob(bytes.data(), bytes.size, &view), BlobStatus::kOk);
  EXPECT_EQ(view.method(), Method::kOjr);
  ASSERT_EQ(view.leaf_size(0), 3u);
  EXPECT_EQ(view.ojr_votes()[view.leaf_first(0) + 2].dz_mm, 30);
  EXPECT_EQ(view.ojr_votes()[view.leaf_first(0) + 1].dy_mm, -20);
  EXPECT_EQ(view.entry_tags[view.leaf_first(0) + 2], 2);
}

TEST(BlobFormat, OjrVotesOfWeightZeroAreNotStoredAndCastingOrderKeepsTheirLanes) {
  auto c = tools::single_vote_ojr(4, 10, -20, 30);
  c.votes_per_joint = 2;
  c.ojr_leaves.clear();
  // Lanes j·2 + k: only lanes 1, 4 and 7 carry votes.
  for (int l = 0; l < 8; ++l)
    c.ojr_leaves.push_back(OjrVote{int16_t(l), 0, 0, uint16_t(l == 1 || l == 4 || l == 7 ? 5 + l : 0)});
  const auto bytes = write_blob(c);
  AlignedBytes a(bytes);
  LoadedBlob b;
  ASSERT_EQ(load_blob(a.data(), a.size, &b), BlobStatus::kOk);
  ASSERT_EQ(b.meta->entry_count, 3u);
  EXPECT_EQ(b.entry_tags[0], 1);
  EXPECT_EQ(b.entry_tags[1], 4);
  EXPECT_EQ(b.entry_tags[2], 7);
  EXPECT_EQ(b.ojr_votes()[1].dx_mm, 4);
  EXPECT_EQ(b.ojr_votes()[2].weight, 12);
  const BlobContents back = dense_contents(b);
  ASSERT_EQ(back.ojr_leaves.size(), c.ojr_leaves.size());
  for (size_t i = 0; i < c.ojr_leaves.size(); ++i) {
    EXPECT_EQ(back.ojr_leaves[i].weight, c.ojr_leaves[i].weight) << "lane " << i;
    EXPECT_EQ(back.ojr_leaves[i].dx_mm, c.ojr_leaves[i].weight ? c.ojr_leaves[i].dx_mm : 0) << "lane " << i;
  }
  EXPECT_EQ(write_blob(dense_contents(b)), bytes);
}

namespace {
// A forest in v1/v2's tree layout: complete heap-order trees (blob_format.h nodes_per_heap), some
// subtrees padded (threshold kPadThreshold), each leaf slot its record; `leaves` its dense BPC leaves.
struct HeapForest {
  int depth = 0;
  std::vector<std::vector<TreeNode>> nodes;
  std::vector<std::vector<uint32_t>> slots;
  BlobContents leaves;  // names, leaves, config (its trees unused)
};

HeapForest random_heap_forest(uint64_t seed, int trees, int depth) {
  HeapForest f;
  f.depth = depth;
  f.leaves = tools::random_bpc_forest(seed, 1, 2, 31, 100, 300);  // 4 records of 31 parts
  f.leaves.tree_nodes.clear();
  f.leaves.tree_leaf_index.clear();
  f.leaves.tree_left_child.clear();
  f.leaves.depth = depth;
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> offset(-150, 150), threshold(-400, 400), tenth(0, 9), record(0, 3);
  for (int t = 0; t < trees; ++t) {
    std::vector<TreeNode> nodes(nodes_per_heap(depth));
    for (size_t h = 0; h < nodes.size(); ++h) {
      const bool parent_padded = h > 0 && nodes[(h - 1) / 2].threshold_mm == kPadThreshold;
      if (parent_padded || (h > 0 && tenth(rng) == 0)) {  // a pad node: its whole subtree goes left
        nodes[h] = TreeNode{0, 0, 0, 0, kPadThreshold};
        continue;
      }
      nodes[h] = TreeNode{int16_t(offset(rng)), int16_t(offset(rng)), int16_t(offset(rng)), int16_t(offset(rng)),
                          int16_t(threshold(rng))};
    }
    std::vector<uint32_t> slots(leaves_per_tree(depth));
    for (uint32_t& s : slots) s = uint32_t(record(rng));
    f.nodes.push_back(std::move(nodes));
    f.slots.push_back(std::move(slots));
  }
  return f;
}

// The same forest in the current format (the upgrade's expected result).
BlobContents sparse_contents(const HeapForest& f) {
  BlobContents c = f.leaves;
  for (size_t t = 0; t < f.nodes.size(); ++t) append_heap_tree(&c, f.nodes[t], f.slots[t]);
  return c;
}

// A format-1 (dense leaves, five sections), format-2 (compact leaves, seven sections) or format-3
// (sparse breadth-first nodes with leaf-index and left-child sections, eight) blob of `f`, written
// here independently of the current writer, as those writers laid it out: v1 BPC records padded to a
// multiple of 4 bytes; v2 and v3 compact leaves in the forest's own record order (records shared by
// slots stored once).
std::vector<uint8_t> legacy_blob(const HeapForest& f, int version) {
  const BlobContents& c = f.leaves;
  const bool bpc = c.method == Method::kBpc;
  const size_t parts = c.part_names.size(), per_leaf = c.joint_names.size() * size_t(c.votes_per_joint);
  const uint32_t stride = bpc ? uint32_t((2 * parts + 3) / 4 * 4) : uint32_t(per_leaf * sizeof(OjrVote));
  const uint32_t leaves = uint32_t(bpc ? c.bpc_leaves.size() / parts : c.ojr_leaves.size() / per_leaf);
  const size_t width = bpc ? parts : per_leaf;
  const size_t trees = f.nodes.size(), heap = nodes_per_heap(f.depth), slots = leaves_per_tree(f.depth);
  const BlobContents sparse = sparse_contents(f);  // v3's trees (append_heap_tree: sparse breadth first)
  std::vector<uint32_t> offsets{0};
  std::vector<uint8_t> entries, tags;
  for (uint32_t l = 0; l < leaves; ++l) {
    for (size_t i = 0; i < width; ++i) {
      const size_t at = size_t(l) * width + i;
      if (bpc && c.bpc_leaves[at] != 0) {
        entries.push_back(uint8_t(c.bpc_leaves[at]));
        entries.push_back(uint8_t(c.bpc_leaves[at] >> 8));
        tags.push_back(uint8_t(i));
      } else if (!bpc && c.ojr_leaves[at].weight != 0) {
        const uint8_t* v = reinterpret_cast<const uint8_t*>(&c.ojr_leaves[at]);
        entries.insert(entries.end(), v, v + sizeof(OjrVote));
        tags.push_back(uint8_t(i));
      }
    }
    offsets.push_back(uint32_t(tags.size()));
  }
  size_t v3_nodes = 0;
  for (const auto& t : sparse.tree_nodes) v3_nodes += t.size();
  const int kinds = version == 1 ? 5 : version == 2 ? 7 : 8;
  std::vector<size_t> sizes = {version == 3 ? sizeof(ForestMeta) : kLegacyMetaBytes, sizeof(RuntimeConfig)};
  if (version == 3) {
    sizes.push_back(v3_nodes * sizeof(TreeNode));
    sizes.push_back(v3_nodes * 4);
  } else {
    sizes.push_back(trees * heap * sizeof(TreeNode));
    sizes.push_back(trees * slots * 4);
  }
  if (version == 1) {
    sizes.push_back(size_t(leaves) * stride);
  } else {
    sizes.push_back(offsets.size() * 4);
    sizes.push_back(entries.size());
    sizes.push_back(tags.size());
  }
  if (version == 3) sizes.push_back(v3_nodes * 4);
  const size_t header = sizeof(BlobHeader) + kinds * sizeof(SectionEntry);
  std::vector<SectionEntry> e(static_cast<size_t>(kinds), SectionEntry{});
  size_t at = (header + 63) / 64 * 64;
  for (int k = 0; k < kinds; ++k) {
    e[k] = SectionEntry{uint32_t(k + 1), 0, at, sizes[k]};
    at = (at + sizes[k] + 63) / 64 * 64;
  }
  std::vector<uint8_t> out(e.back().offset + e.back().size, 0);
  ForestMeta m{};
  const std::vector<uint8_t> current = write_blob(sparse);
  std::memcpy(&m, current.data() + section(current, SectionKind::kMeta).offset, sizeof m);
  m.arena_bytes = 0;
  m.leaf_count = leaves;
  m.entry_count = version == 1 ? stride : uint32_t(tags.size());  // v1: leaf_stride_bytes
  for (size_t t = 0; t < trees; ++t) m.node_count[t] = version == 3 ? uint32_t(sparse.tree_nodes[t].size()) : 0;
  std::memcpy(out.data() + e[0].offset, &m, sizes[0]);
  std::memcpy(out.data() + e[1].offset, &c.config, sizeof c.config);
  if (version == 3) {
    size_t n = 0;
    for (size_t t = 0; t < trees; ++t) {
      const size_t count = sparse.tree_nodes[t].size();
      std::memcpy(out.data() + e[2].offset + n * sizeof(TreeNode), sparse.tree_nodes[t].data(), count * sizeof(TreeNode));
      std::memcpy(out.data() + e[3].offset + n * 4, sparse.tree_leaf_index[t].data(), count * 4);
      std::memcpy(out.data() + e[7].offset + n * 4, sparse.tree_left_child[t].data(), count * 4);
      n += count;
    }
  } else {
    for (size_t t = 0; t < trees; ++t) {
      std::memcpy(out.data() + e[2].offset + t * heap * sizeof(TreeNode), f.nodes[t].data(), heap * sizeof(TreeNode));
      std::memcpy(out.data() + e[3].offset + t * slots * 4, f.slots[t].data(), slots * 4);
    }
  }
  if (version == 1) {
    for (uint32_t l = 0; l < leaves; ++l) {
      uint8_t* rec = out.data() + e[4].offset + size_t(l) * stride;
      if (bpc) std::memcpy(rec, &c.bpc_leaves[l * parts], parts * 2);
      else std::memcpy(rec, &c.ojr_leaves[l * per_leaf], per_leaf * sizeof(OjrVote));
    }
  } else {
    std::memcpy(out.data() + e[4].offset, offsets.data(), offsets.size() * 4);
    if (!entries.empty()) std::memcpy(out.data() + e[5].offset, entries.data(), entries.size());
    if (!tags.empty()) std::memcpy(out.data() + e[6].offset, tags.data(), tags.size());
  }
  BlobHeader h{};
  h.magic = kMagic;
  h.endian_tag = kEndianTag;
  h.version_major = uint16_t(version);
  h.header_bytes = uint32_t(header);
  h.total_bytes = out.size();
  h.section_count = uint32_t(kinds);
  std::memcpy(out.data(), &h, sizeof h);
  std::memcpy(out.data() + sizeof h, e.data(), e.size() * sizeof(SectionEntry));
  reseal(out);
  return out;
}
}  // namespace

TEST(BlobFormat, Versions1To3AreRefusedByNameAndUpgradeLosslessly) {
  const HeapForest f = random_heap_forest(3, 2, 6);
  const std::vector<uint8_t> expected = write_blob(sparse_contents(f));
  for (int version : {1, 2, 3}) {
    const std::vector<uint8_t> old = legacy_blob(f, version);
    EXPECT_EQ(load(old), BlobStatus::kVersionTooOld) << "version " << version;
    const std::string message = blob_status_message(BlobStatus::kVersionTooOld);
    EXPECT_NE(message.find("versions 1 (dense leaves), 2 (complete heap-order trees) and 3"), std::string::npos);
    EXPECT_NE(message.find("depthpose convert --upgrade-blob OLD.blob --out NEW.blob"), std::string::npos);
    int read_version = 0;
    const std::vector<uint8_t> upgraded = write_blob(tools::read_old_blob(old, "old.blob", &read_version));
    EXPECT_EQ(read_version, version);
    EXPECT_EQ(upgraded, expected) << "version " << version << ": the upgrade must equal writing the same forest directly";
    auto corrupt = old;
    corrupt.back() ^= 1;
    EXPECT_THROW(tools::read_old_blob(corrupt, "old.blob"), tools::ToolError);
  }
  // A v3 tree out of breadth-first order is refused by the upgrade, naming the tree.
  auto v3 = legacy_blob(f, 3);
  const SectionEntry left = section(v3, SectionKind(8));  // v3's left-child section
  edit<uint32_t>(v3, left.offset, 3);  // the root's left child: 3 instead of 2
  reseal(v3);
  try {
    write_blob(tools::read_old_blob(v3, "old.blob"));
    ADD_FAILURE() << "an out-of-order v3 tree was upgraded";
  } catch (const tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("tree 0: split node 1 has left child 3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(tools::read_old_blob(expected, "new.blob"), tools::ToolError) << "a v4 blob is not an old blob";
}

TEST(BlobFormat, UpgradedTreesReachTheSameLeafForEveryPixel) {
  // v2's traversal (heap order: children 2n+1, 2n+2, then the leaf slot) against the v3 reference
  // kernel on the upgraded blob, for random pixels, depths and probe offsets; pad subtrees included.
  const HeapForest f = random_heap_forest(9, 3, 8);
  const std::vector<uint8_t> bytes = write_blob(tools::read_old_blob(legacy_blob(f, 2), "old.blob"));
  AlignedBytes a(bytes);
  LoadedBlob b;
  ASSERT_EQ(load_blob(a.data(), a.size, &b), BlobStatus::kOk);
  EXPECT_LT(b.total_nodes, 3 * max_nodes_per_tree(8)) << "pad subtrees are dropped";
  std::vector<TreeNode> nodes(b.total_nodes);
  std::vector<uint32_t> left(b.total_nodes), record(b.total_nodes);
  expand_tree_tables(b, nodes.data(), left.data(), record.data());
  const BlobContents back = dense_contents(b);
  const int w = 64, h = 48;
  std::mt19937_64 rng(10);
  std::uniform_int_distribution<int> depth(500, 3000), hole(0, 9);
  std::vector<uint16_t> depth_mm(size_t(w) * h), probe(kernels::padded_probe_elements(w, h));
  kernels::fill_probe_border(probe.data(), w, h);
  std::vector<EvaluatedPixel> pixels;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const uint16_t z = hole(rng) == 0 ? 0 : uint16_t(depth(rng));
      depth_mm[size_t(v) * w + u] = z;
      probe[size_t(v + 1) * (w + 2) + u + 1] = kernels::probe_element(z);
      if (z) pixels.push_back(EvaluatedPixel{uint16_t(u), uint16_t(v), z, 0});
    }
  const int32_t focal = focal_factor_mm(500.0f, b.meta->reference_focal_px);
  auto depth_at = [&](int32_t u, int32_t v) -> int32_t {
    if (u < 0 || v < 0 || u >= w || v >= h) return kBackgroundDepthMm;
    const uint16_t z = depth_mm[size_t(v) * w + u];
    return z == 0 ? kBackgroundDepthMm : z;
  };
  std::set<uint32_t> reached;
  for (int t = 0; t < 3; ++t) {
    std::vector<uint32_t> out(pixels.size());
    const kernels::ForestKernelArgs args{probe.data(), w + 2, w, h, focal, pixels.data(), int32_t(pixels.size()),
                                         nodes.data() + b.tree_first[t], nullptr, left.data() + b.tree_first[t],
                                         record.data() + b.tree_first[t], b.depth(), b.tree_node_count(t), out.data(),
                                         nullptr, nullptr};
    kernels::forest_kernel(KernelIsa::kScalar)(args);
    for (size_t i = 0; i < pixels.size(); ++i) {
      const EvaluatedPixel p = pixels[i];
      const int32_t s = scale_q13(focal, p.z_mm);
      size_t n = 0;
      for (int level = 0; level < f.depth; ++level) {
        const TreeNode& nd = f.nodes[size_t(t)][n];
        const int32_t d1 = depth_at(p.u + probe_offset_px(nd.du1, s), p.v + probe_offset_px(nd.dv1, s));
        const int32_t d2 = depth_at(p.u + probe_offset_px(nd.du2, s), p.v + probe_offset_px(nd.dv2, s));
        n = 2 * n + 1 + (d1 - d2 > nd.threshold_mm ? 1 : 0);
      }
      // v4 numbers records by leaf node: the record reached holds the slot's record's distribution.
      const uint32_t want = f.slots[size_t(t)][n - nodes_per_heap(f.depth)];
      ASSERT_LT(out[i], b.meta->leaf_count);
      EXPECT_TRUE(std::equal(back.bpc_leaves.begin() + out[i] * 31, back.bpc_leaves.begin() + out[i] * 31 + 31,
                             f.leaves.bpc_leaves.begin() + want * 31))
          << "tree " << t << " pixel " << i;
      reached.insert(uint32_t(t) * 4 + want);
    }
  }
  EXPECT_GE(reached.size(), 9u) << "the pixels must reach many leaves for the comparison to mean much";
}

TEST(BlobFormat, HeaderRefusals) {
  const auto good = small_bpc();
  ASSERT_EQ(load(good), BlobStatus::kOk);
  LoadedBlob out;
  EXPECT_EQ(load_blob(nullptr, 10, &out), BlobStatus::kNullInput);
  {
    AlignedBytes a(good);
    EXPECT_EQ(load_blob(a.data() + 4, a.size - 4, &out), BlobStatus::kBadAlignment);
  }
  EXPECT_EQ(load(std::vector<uint8_t>(good.begin(), good.begin() + 20)), BlobStatus::kTooSmall);
  auto b = good;
  edit<uint32_t>(b, 0, 0x12345678);
  EXPECT_EQ(load(b), BlobStatus::kBadMagic);
  b = good;
  edit<uint32_t>(b, offsetof(BlobHeader, endian_tag), 0x04030201u);
  EXPECT_EQ(load(b), BlobStatus::kWrongEndianness);
  b = good;
  edit<uint32_t>(b, offsetof(BlobHeader, endian_tag), 0x11111111u);
  EXPECT_EQ(load(b), BlobStatus::kBadEndianTag);
  b = good;
  edit<uint16_t>(b, offsetof(BlobHeader, version_major), 0);
  EXPECT_EQ(load(b), BlobStatus::kVersionTooOld);
  b = good;
  edit<uint16_t>(b, offsetof(BlobHeader, version_major), 1);
  EXPECT_EQ(load(b), BlobStatus::kVersionTooOld);
  b = good;
  edit<uint16_t>(b, offsetof(BlobHeader, version_major), 2);
  EXPECT_EQ(load(b), BlobStatus::kVersionTooOld);
  b = good;
  edit<uint16_t>(b, offsetof(BlobHeader, version_major), 3);
  EXPECT_EQ(load(b), BlobStatus::kVersionTooOld);
  b = good;
  edit<uint16_t>(b, offsetof(BlobHeader, version_major), 5);
  EXPECT_EQ(load(b), BlobStatus::kVersionTooNew);
  b = good;
  edit<uint16_t>(b, offsetof(BlobHeader, version_minor), 7);  // newer minor of our major: accepted
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kOk);
  b = good;
  edit<uint32_t>(b, offsetof(BlobHeader, section_count), 0);
  EXPECT_EQ(load(b), BlobStatus::kBadSectionCount);
  b = good;
  edit<uint32_t>(b, offsetof(BlobHeader, section_count), 99);
  EXPECT_EQ(load(b), BlobStatus::kBadSectionCount);
  b = good;
  edit<uint32_t>(b, offsetof(BlobHeader, header_bytes), 100);
  EXPECT_EQ(load(b), BlobStatus::kBadHeaderSize);
  b = good;
  b.push_back(0);
  EXPECT_EQ(load(b), BlobStatus::kTrailingBytes);
  b = good;
  edit<uint32_t>(b, offsetof(BlobHeader, flags), 1);
  EXPECT_EQ(load(b), BlobStatus::kHeaderChecksum);
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kReservedNotZero);
  b = good;
  b[b.size() - 1] ^= 0x40;
  EXPECT_EQ(load(b), BlobStatus::kPayloadChecksum);
}

TEST(BlobFormat, SectionTableRefusals) {
  const auto good = small_bpc();
  const size_t table = sizeof(BlobHeader);
  const size_t entry = sizeof(SectionEntry);
  auto b = good;
  edit<uint32_t>(b, table + 0 * entry, 9);  // unknown kind
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kUnknownSection);
  b = good;
  edit<uint32_t>(b, table + 1 * entry, 1);  // config entry claims to be meta again
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kSectionDuplicate);
  b = good;
  edit<uint64_t>(b, table + 2 * entry + 8, section(good, SectionKind::kNodes).offset + 2);
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kSectionMisaligned);
  b = good;
  edit<uint64_t>(b, table + 4 * entry + 16, uint64_t(1) << 40);
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kSectionOutOfBounds);
  b = good;
  edit<uint64_t>(b, table + 2 * entry + 8, 0);  // nodes placed over the header
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kSectionOutOfBounds);
  b = good;
  edit<uint64_t>(b, table + 4 * entry + 8, section(good, SectionKind::kSplitFlags).offset);  // offsets over the flags
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kSectionOverlap);
  b = good;
  edit<uint64_t>(b, table + 1 * entry + 16, sizeof(RuntimeConfig) - 8);
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kBadSectionSize);
  // A blob whose header names only four sections: the fifth is missing.
  b = good;
  edit<uint32_t>(b, offsetof(BlobHeader, section_count), 4);
  edit<uint32_t>(b, offsetof(BlobHeader, header_bytes), uint32_t(sizeof(BlobHeader) + 4 * entry));
  {
    BlobHeader h = header_of(b);
    h.header_crc32 = 0;
    std::memcpy(b.data(), &h, sizeof h);
    h.payload_crc32 = crc32(b.data() + h.header_bytes, b.size() - h.header_bytes);
    std::memcpy(b.data(), &h, sizeof h);
    h.header_crc32 = crc32(b.data(), h.header_bytes);
    std::memcpy(b.data(), &h, sizeof h);
  }
  EXPECT_EQ(load(b), BlobStatus::kSectionMissing);
}

TEST(BlobFormat, ContentRefusals) {
  const auto good = small_bpc();
  const size_t meta = section(good, SectionKind::kMeta).offset;
  const size_t config = section(good, SectionKind::kConfig).offset;
  const size_t flags = section(good, SectionKind::kSplitFlags).offset;
  const size_t offsets = section(good, SectionKind::kLeafOffsets).offset;
  const size_t entries = section(good, SectionKind::kLeafEntries).offset;
  const size_t tags = section(good, SectionKind::kEntryTags).offset;
  struct Case {
    size_t offset;
    std::vector<uint8_t> bytes;
    BlobStatus want;
  };
  auto u8 = [](uint8_t v) { return std::vector<uint8_t>{v}; };
  auto u16 = [](uint16_t v) { return std::vector<uint8_t>{uint8_t(v), uint8_t(v >> 8)}; };
  auto u32 = [](uint32_t v) {
    return std::vector<uint8_t>{uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)};
  };
  float bad_focal = -1.0f;
  uint32_t bad_focal_bits;
  std::memcpy(&bad_focal_bits, &bad_focal, 4);
  const std::vector<Case> cases = {
      {meta + offsetof(ForestMeta, method), u8(7), BlobStatus::kBadMethod},
      {meta + offsetof(ForestMeta, tree_count), u8(0), BlobStatus::kBadTreeCount},
      {meta + offsetof(ForestMeta, tree_count), u8(9), BlobStatus::kBadTreeCount},
      {meta + offsetof(ForestMeta, depth), u8(0), BlobStatus::kBadDepth},
      {meta + offsetof(ForestMeta, depth), u8(21), BlobStatus::kBadDepth},
      {meta + offsetof(ForestMeta, part_count), u8(33), BlobStatus::kBadPartCount},
      {meta + offsetof(ForestMeta, joint_count), u8(17), BlobStatus::kBadJointCount},
      {meta + offsetof(ForestMeta, votes_per_joint), u8(1), BlobStatus::kBadVotesPerJoint},
      {meta + offsetof(ForestMeta, reference_focal_px), u32(bad_focal_bits), BlobStatus::kBadFocalLength},
      {meta + offsetof(ForestMeta, leaf_count), u32(0), BlobStatus::kBadLeafCount},
      {meta + offsetof(ForestMeta, leaf_count), u32(3), BlobStatus::kBadLeafCount},  // two trees of one leaf node
      {meta + offsetof(ForestMeta, entry_count), u32(11), BlobStatus::kBadEntryCount},  // > 2 leaves · 5 parts
      {meta + offsetof(ForestMeta, max_width), u32(0), BlobStatus::kBadFrameSize},
      {meta + offsetof(ForestMeta, max_abs_offset_pxm), u32(5000), BlobStatus::kOffsetTooLarge},
      {meta + offsetof(ForestMeta, reserved2), u32(1), BlobStatus::kReservedNotZero},
      {meta + offsetof(ForestMeta, part_names) + 2, u8(0x01), BlobStatus::kBadName},
      {meta + offsetof(ForestMeta, joint_names) + 5 * kNameBytes, u8('x'), BlobStatus::kBadName},
      {flags, u8(1), BlobStatus::kBadChildIndex},  // tree 0's only node a split: its children lie outside
      {flags + 1, u8(2), BlobStatus::kReservedNotZero},  // tree 1's flag byte: a bit past its one node
      {meta + offsetof(ForestMeta, node_count) + 4 * 2, u32(1), BlobStatus::kBadNodeCount},  // a third tree's count
      {meta + offsetof(ForestMeta, node_count), u32(0), BlobStatus::kBadNodeCount},
      {meta + offsetof(ForestMeta, node_count), u32(2), BlobStatus::kBadNodeCount},   // even: not a full binary tree
      {meta + offsetof(ForestMeta, node_count), u32(17), BlobStatus::kBadNodeCount},  // depth 3 holds ≤ 15
      {entries, u16(0), BlobStatus::kBadLeafDistribution},  // a stored probability of 0
      {entries, u16(40000), BlobStatus::kBadLeafDistribution},
      {offsets, u32(1), BlobStatus::kBadLeafOffsets},
      {offsets + 8, u32(1), BlobStatus::kBadLeafOffsets},  // must end at entry_count (2)
      {tags, u8(5), BlobStatus::kBadEntryTag},             // part 5 of a 5-part forest
      {config + offsetof(RuntimeConfig, joints) + 0, u32(1u << 6), BlobStatus::kBadPartMask},
      {config + offsetof(RuntimeConfig, joints) + 0, u32(0), BlobStatus::kBadPartMask},
      {config + offsetof(RuntimeConfig, joints) + offsetof(JointConfig, bandwidth_mm), u16(0), BlobStatus::kBadConfig},
      {config + offsetof(RuntimeConfig, max_votes_per_joint), u16(0), BlobStatus::kBadConfig},
      {config + offsetof(RuntimeConfig, max_votes_per_joint), u16(5000), BlobStatus::kBadConfig},
      {config + offsetof(RuntimeConfig, mean_shift_iterations), u16(0), BlobStatus::kBadConfig},
      {config + offsetof(RuntimeConfig, max_proposals_per_joint), u16(9), BlobStatus::kBadConfig},
      {config + offsetof(RuntimeConfig, near_mm), u16(9000), BlobStatus::kBadConfig},
  };
  for (const Case& c : cases) {
    auto b = good;
    std::memcpy(b.data() + c.offset, c.bytes.data(), c.bytes.size());
    reseal(b);
    EXPECT_EQ(load(b), c.want) << "edit at offset " << c.offset << " expected " << blob_status_message(c.want)
                               << ", got " << blob_status_message(load(b));
  }
  auto o = small_ojr();
  const size_t vote = section(o, SectionKind::kLeafEntries).offset;
  edit<int16_t>(o, vote + offsetof(OjrVote, dy_mm), 2500);
  reseal(o);
  EXPECT_EQ(load(o), BlobStatus::kBadVote);
  o = small_ojr();
  edit<uint16_t>(o, vote + offsetof(OjrVote, weight), 0);
  reseal(o);
  EXPECT_EQ(load(o), BlobStatus::kBadVote);
  // Tags: a lane past joints·K, and two votes of one record with the same lane.
  const size_t lane = section(o, SectionKind::kEntryTags).offset;
  o = small_ojr();
  edit<uint8_t>(o, lane + 2, 3);
  reseal(o);
  EXPECT_EQ(load(o), BlobStatus::kBadEntryTag);
  o = small_ojr();
  edit<uint8_t>(o, lane + 1, 0);
  reseal(o);
  EXPECT_EQ(load(o), BlobStatus::kBadEntryTag);
}

namespace {
// One depth-3 tree, unbalanced, in breadth-first order (levels 0; 1 1; 2 2; 3 3):
//   1 split (children 2, 3)   2 split (4, 5)   3 leaf   4 split (6, 7)   5 leaf   6 leaf   7 leaf
// Split flags 0b0000'1011; leaf nodes 3, 5, 6, 7 read records 0..3 (all of part 3).
BlobContents chain_tree() {
  BlobContents c = tools::single_part_bpc(5, 3, 2, 40, 3, 1);
  const TreeNode leaf = kLeafNode;
  c.tree_nodes[0] = {TreeNode{10, 0, 0, 0, 5}, TreeNode{0, 10, 0, 0, 6}, leaf, TreeNode{-10, 0, 0, 0, 7}, leaf, leaf, leaf};
  c.tree_left_child[0] = {2, 4, 3, 6, 5, 6, 7};
  c.tree_leaf_index[0] = {0, 0, 0, 0, 0, 0, 0};
  return c;
}
}  // namespace

TEST(BlobFormat, SparseTreeRefusals) {
  const auto good = write_blob(chain_tree());
  ASSERT_EQ(load(good), BlobStatus::kOk);
  const size_t meta = section(good, SectionKind::kMeta).offset;
  const size_t nodes = section(good, SectionKind::kNodes).offset;
  const size_t flags = section(good, SectionKind::kSplitFlags).offset;
  ASSERT_EQ(section(good, SectionKind::kNodes).size, 3 * sizeof(TreeNode)) << "only the split nodes are stored";
  ASSERT_EQ(section(good, SectionKind::kSplitFlags).size, 1u);
  ASSERT_EQ(good[flags], 0x0B);
  struct Case {
    const char* what;
    std::function<void(std::vector<uint8_t>&)> edit;
    BlobStatus want;
  };
  const std::vector<Case> cases = {
      {"node 5 a split: its children would be nodes 8 and 9", [&](auto& b) { edit<uint8_t>(b, flags, 0x1B); },
       BlobStatus::kBadChildIndex},
      {"a split node at level depth", [&](auto& b) { edit<uint8_t>(b, meta + offsetof(ForestMeta, depth), 2); },
       BlobStatus::kTreeTooDeep},
      {"nodes 6 and 7 unreached (node 4 made a leaf)", [&](auto& b) { edit<uint8_t>(b, flags, 0x03); },
       BlobStatus::kUnreachedNode},
      {"the root a leaf", [&](auto& b) { edit<uint8_t>(b, flags, 0x0A); }, BlobStatus::kUnreachedNode},
      {"a flag bit past the node count", [&](auto& b) { edit<uint8_t>(b, flags, 0x8B); }, BlobStatus::kReservedNotZero},
      {"a split node's probe offset beyond the meta's maximum",
       [&](auto& b) { edit<int16_t>(b, nodes + sizeof(TreeNode) + offsetof(TreeNode, dv1), 11); },
       BlobStatus::kOffsetTooLarge},
      {"node count 5 (the split nodes' section holds 3)",
       [&](auto& b) {
         edit<uint32_t>(b, meta + offsetof(ForestMeta, node_count), 5);
         edit<uint32_t>(b, meta + offsetof(ForestMeta, leaf_count), 3);
       },
       BlobStatus::kBadSectionSize},
  };
  for (const Case& c : cases) {
    auto b = good;
    c.edit(b);
    reseal(b);
    EXPECT_EQ(load(b), c.want) << c.what << ": got " << blob_status_message(load(b));
  }
  // The writer refuses what v4 cannot store before writing, naming the tree and node.
  for (auto change : std::vector<std::function<void(BlobContents&)>>{
           [](BlobContents& c) { c.tree_left_child[0][3] = 1; },          // a cycle
           [](BlobContents& c) { c.tree_left_child[0][1] = 5; },          // children out of breadth-first order
           [](BlobContents& c) { c.tree_nodes[0][4].threshold_mm = 9; },  // a leaf node without the pad threshold
           [](BlobContents& c) { c.tree_leaf_index[0][6] = 1; },          // a record the table lacks
           [](BlobContents& c) {                                          // nodes 6, 7 unreached
             c.tree_left_child[0][3] = 4;
             c.tree_nodes[0][3] = kLeafNode;
           }}) {
    BlobContents bad = chain_tree();
    change(bad);
    EXPECT_THROW(write_blob(bad), tools::ToolError);
  }
}

// v4 numbers leaf records by leaf node: a record two leaf nodes read is stored once per node, a
// record no leaf node reads is dropped, and each stored record holds the distribution given.
TEST(BlobFormat, WriterNumbersRecordsByLeafNode) {
  BlobContents c = chain_tree();
  c.bpc_leaves.assign(5 * 3, 0);  // records 0, 1, 2 of 5 parts: part 0, part 1, part 2 (record 1 unread)
  for (int r = 0; r < 3; ++r) c.bpc_leaves[size_t(r) * 5 + size_t(r)] = 32768;
  c.tree_leaf_index[0] = {0, 0, 2, 0, 0, 2, 0};  // leaf nodes 3, 5, 6, 7 read records 2, 0, 2, 0
  const std::vector<uint8_t> bytes = write_blob(c);
  AlignedBytes a(bytes);
  LoadedBlob b;
  ASSERT_EQ(load_blob(a.data(), a.size, &b), BlobStatus::kOk);
  ASSERT_EQ(b.meta->leaf_count, 4u);
  const uint8_t part_of_leaf[4] = {2, 0, 2, 0};
  for (uint32_t r = 0; r < 4; ++r) {
    ASSERT_EQ(b.leaf_size(r), 1u);
    EXPECT_EQ(b.entry_tags[b.leaf_first(r)], part_of_leaf[r]) << "record " << r;
  }
  std::vector<uint32_t> left(b.total_nodes), record(b.total_nodes);
  expand_tree_tables(b, nullptr, left.data(), record.data());
  EXPECT_EQ(left, (std::vector<uint32_t>{2, 4, 3, 6, 5, 6, 7}));
  EXPECT_EQ(record, (std::vector<uint32_t>{0, 0, 0, 0, 1, 2, 3}));
}

TEST(BlobFormat, LeafOffsetsAndSumsAreRefusedAcrossRecords) {
  // One split node, two leaf nodes: two records of two parts each (tags 0, 3 and 1, 3); offsets [0, 2, 4].
  auto c = tools::single_part_bpc(5, 3, 2, 40);
  c.tree_nodes[0] = {TreeNode{10, 0, 0, 0, 5}, kLeafNode, kLeafNode};
  c.tree_left_child[0] = {2, 2, 3};
  c.tree_leaf_index[0] = {0, 0, 1};
  c.bpc_leaves = {16384, 0, 0, 16384, 0, 0, 8192, 0, 8192, 0};
  const auto good = write_blob(c);
  ASSERT_EQ(load(good), BlobStatus::kOk);
  const size_t offsets = section(good, SectionKind::kLeafOffsets).offset;
  const size_t entries = section(good, SectionKind::kLeafEntries).offset;
  const size_t tags = section(good, SectionKind::kEntryTags).offset;
  auto b = good;
  edit<uint32_t>(b, offsets + 4, 3);  // [0, 3, 4]: the first record takes the second's first entry (tag 1 after 3)
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kBadEntryTag);
  b = good;
  edit<uint32_t>(b, offsets + 4, 5);  // [0, 5, 4]: decreasing
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kBadLeafOffsets);
  b = good;
  edit<uint16_t>(b, entries + 2, 20000);  // 16384 + 20000 > 32768
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kBadLeafDistribution);
  b = good;
  edit<uint8_t>(b, tags + 3, 1);  // second record: tags 1, 1
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kBadEntryTag);
  b = good;
  edit<uint8_t>(b, tags + 1, 0);  // first record: tags 0, 0
  reseal(b);
  EXPECT_EQ(load(b), BlobStatus::kBadEntryTag);
}

TEST(BlobFormat, TruncationAtEverySectionBoundaryIsRefused) {
  const auto good = small_bpc();
  std::vector<size_t> cuts = {0, 1, sizeof(BlobHeader) - 1, sizeof(BlobHeader), header_of(good).header_bytes};
  for (SectionKind k : {SectionKind::kMeta, SectionKind::kConfig, SectionKind::kNodes, SectionKind::kSplitFlags,
                        SectionKind::kLeafOffsets, SectionKind::kLeafEntries, SectionKind::kEntryTags}) {
    const SectionEntry e = section(good, k);
    cuts.push_back(e.offset);
    cuts.push_back(e.offset + e.size / 2);
    cuts.push_back(e.offset + e.size - 1);
  }
  for (size_t cut : cuts) {
    ASSERT_LT(cut, good.size());
    const BlobStatus s = load(std::vector<uint8_t>(good.begin(), good.begin() + cut));
    EXPECT_TRUE(s == BlobStatus::kTooSmall || s == BlobStatus::kTruncated || (cut == 0 && s == BlobStatus::kEmpty))
        << "cut at " << cut << ": " << blob_status_message(s);
  }
}

TEST(BlobFormat, EverySingleBitFlipIsRefused) {
  const auto good = small_ojr();
  size_t refused = 0;
  for (size_t byte = 0; byte < good.size(); ++byte)
    for (int bit = 0; bit < 8; ++bit) {
      auto b = good;
      b[byte] ^= uint8_t(1u << bit);
      if (load(b) != BlobStatus::kOk) ++refused;
      else ADD_FAILURE() << "flip of bit " << bit << " of byte " << byte << " was accepted";
    }
  EXPECT_EQ(refused, good.size() * 8);
}

TEST(BlobFormat, WriterRefusesInvalidContents) {
  auto c = tools::single_part_bpc(5, 3, 2, 40);
  c.depth = 21;
  EXPECT_THROW(write_blob(c), tools::ToolError);
  c = tools::single_part_bpc(5, 3, 2, 40);
  c.tree_leaf_index[0][0] = 99;  // points past the leaf table
  EXPECT_THROW(write_blob(c), tools::ToolError);
  c = tools::single_part_bpc(5, 3, 2, 40);
  c.tree_left_child[0].push_back(2);  // lengths differ from the node count
  EXPECT_THROW(write_blob(c), tools::ToolError);
  c = tools::single_part_bpc(5, 3, 2, 40);
  c.part_names[0] = std::string(30, 'a');
  EXPECT_THROW(write_blob(c), tools::ToolError);
}
