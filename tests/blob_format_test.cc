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
  for (int t = 0; t < 3; ++t) {
    ASSERT_EQ(b.tree_node_count(t), contents.tree_nodes[t].size());
    for (size_t n = 0; n < contents.tree_nodes[t].size(); ++n) {
      EXPECT_EQ(b.tree_nodes(t)[n].du1, contents.tree_nodes[t][n].du1);
      EXPECT_EQ(b.tree_nodes(t)[n].threshold_mm, contents.tree_nodes[t][n].threshold_mm);
      EXPECT_EQ(b.tree_left_child(t)[n], contents.tree_left_child[t][n]);
      EXPECT_EQ(b.tree_leaf_index(t)[n], contents.tree_leaf_index[t][n]);
    }
  }
  const BlobContents back = dense_contents(b);
  EXPECT_EQ(back.bpc_leaves, contents.bpc_leaves) << "compact leaves must hold exactly the dense distributions";
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

// A format-1 (dense leaves, five sections) or format-2 (compact leaves, seven sections) blob of `f`,
// written here independently of the current writer, as those writers laid it out: v1 BPC records
// padded to a multiple of 4 bytes; v2's compact leaf sections are byte for byte the current ones.
std::vector<uint8_t> legacy_blob(const HeapForest& f, int version) {
  const BlobContents& c = f.leaves;
  const bool bpc = c.method == Method::kBpc;
  const size_t parts = c.part_names.size(), per_leaf = c.joint_names.size() * size_t(c.votes_per_joint);
  const uint32_t stride = bpc ? uint32_t((2 * parts + 3) / 4 * 4) : uint32_t(per_leaf * sizeof(OjrVote));
  const uint32_t leaves = uint32_t(bpc ? c.bpc_leaves.size() / parts : c.ojr_leaves.size() / per_leaf);
  const size_t trees = f.nodes.size(), heap = nodes_per_heap(f.depth), slots = leaves_per_tree(f.depth);
  const std::vector<uint8_t> current = write_blob(sparse_contents(f));
  const SectionKind compact[3] = {SectionKind::kLeafOffsets, SectionKind::kLeafEntries, SectionKind::kEntryTags};
  const int kinds = version == 1 ? 5 : 7;
  std::vector<size_t> sizes = {kLegacyMetaBytes, sizeof(RuntimeConfig), trees * heap * sizeof(TreeNode), trees * slots * 4};
  if (version == 1)
    sizes.push_back(size_t(leaves) * stride);
  else
    for (SectionKind k : compact) sizes.push_back(section(current, k).size);
  const size_t header = sizeof(BlobHeader) + kinds * sizeof(SectionEntry);
  std::vector<SectionEntry> e(static_cast<size_t>(kinds), SectionEntry{});
  size_t at = (header + 63) / 64 * 64;
  for (int k = 0; k < kinds; ++k) {
    e[k] = SectionEntry{uint32_t(k + 1), 0, at, sizes[k]};
    at = (at + sizes[k] + 63) / 64 * 64;
  }
  std::vector<uint8_t> out(e.back().offset + e.back().size, 0);
  ForestMeta m{};
  std::memcpy(&m, current.data() + section(current, SectionKind::kMeta).offset, sizeof m);
  m.arena_bytes = 0;
  if (version == 1) m.entry_count = stride;  // v1: leaf_stride_bytes
  std::memcpy(out.data() + e[0].offset, &m, kLegacyMetaBytes);
  std::memcpy(out.data() + e[1].offset, &c.config, sizeof c.config);
  for (size_t t = 0; t < trees; ++t) {
    std::memcpy(out.data() + e[2].offset + t * heap * sizeof(TreeNode), f.nodes[t].data(), heap * sizeof(TreeNode));
    std::memcpy(out.data() + e[3].offset + t * slots * 4, f.slots[t].data(), slots * 4);
  }
  if (version == 1) {
    for (uint32_t l = 0; l < leaves; ++l) {
      uint8_t* rec = out.data() + e[4].offset + size_t(l) * stride;
      if (bpc) std::memcpy(rec, &c.bpc_leaves[l * parts], parts * 2);
      else std::memcpy(rec, &c.ojr_leaves[l * per_leaf], per_leaf * sizeof(OjrVote));
    }
  } else {
    for (int k = 0; k < 3; ++k) {
      const SectionEntry s = section(current, compact[k]);
      std::memcpy(out.data() + e[4 + k].offset, current.data() + s.offset, s.size);
    }
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

TEST(BlobFormat, Versions1And2AreRefusedByNameAndUpgradeLosslessly) {
  const HeapForest f = random_heap_forest(3, 2, 6);
  const std::vector<uint8_t> expected = write_blob(sparse_contents(f));
  for (int version : {1, 2}) {
    const std::vector<uint8_t> old = legacy_blob(f, version);
    EXPECT_EQ(load(old), BlobStatus::kVersionTooOld) << "version " << version;
    const std::string message = blob_status_message(BlobStatus::kVersionTooOld);
    EXPECT_NE(message.find("versions 1 (dense leaves) and 2 (complete heap-order trees)"), std::string::npos);
    EXPECT_NE(message.find("depthpose convert --upgrade-blob OLD.blob --out NEW.blob"), std::string::npos);
    int read_version = 0;
    const std::vector<uint8_t> upgraded = write_blob(tools::read_old_blob(old, "old.blob", &read_version));
    EXPECT_EQ(read_version, version);
    EXPECT_EQ(upgraded, expected) << "version " << version << ": the upgrade must equal writing the same forest directly";
    auto corrupt = old;
    corrupt.back() ^= 1;
    EXPECT_THROW(tools::read_old_blob(corrupt, "old.blob"), tools::ToolError);
  }
  EXPECT_THROW(tools::read_old_blob(expected, "new.blob"), tools::ToolError) << "a v3 blob is not an old blob";
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
                                         b.tree_nodes(t), nullptr, b.tree_left_child(t), b.tree_leaf_index(t),
                                         b.depth(), b.tree_node_count(t), out.data(), nullptr, nullptr};
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
      const uint32_t want = f.slots[size_t(t)][n - nodes_per_heap(f.depth)];
      EXPECT_EQ(out[i], want) << "tree " << t << " pixel " << i;
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
  edit<uint16_t>(b, offsetof(BlobHeader, version_major), 4);
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
  edit<uint64_t>(b, table + 3 * entry + 8, section(good, SectionKind::kNodes).offset);  // index over nodes
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
  const size_t nodes = section(good, SectionKind::kNodes).offset;
  const size_t index = section(good, SectionKind::kLeafIndex).offset;
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
      {meta + offsetof(ForestMeta, entry_count), u32(6), BlobStatus::kBadEntryCount},  // > 1 leaf · 5 parts
      {meta + offsetof(ForestMeta, max_width), u32(0), BlobStatus::kBadFrameSize},
      {meta + offsetof(ForestMeta, max_abs_offset_pxm), u32(5000), BlobStatus::kOffsetTooLarge},
      {meta + offsetof(ForestMeta, reserved2), u32(1), BlobStatus::kReservedNotZero},
      {meta + offsetof(ForestMeta, part_names) + 2, u8(0x01), BlobStatus::kBadName},
      {meta + offsetof(ForestMeta, joint_names) + 5 * kNameBytes, u8('x'), BlobStatus::kBadName},
      {nodes + offsetof(TreeNode, dv2), u16(uint16_t(int16_t(-5))), BlobStatus::kOffsetTooLarge},
      {index + 4, u32(1), BlobStatus::kBadLeafIndex},  // tree 1's leaf node: record 1 of 1
      {meta + offsetof(ForestMeta, node_count) + 4 * 2, u32(1), BlobStatus::kBadNodeCount},  // a third tree's count
      {meta + offsetof(ForestMeta, node_count), u32(0), BlobStatus::kBadNodeCount},
      {meta + offsetof(ForestMeta, node_count), u32(16), BlobStatus::kBadNodeCount},  // depth 3 holds ≤ 15
      {entries, u16(0), BlobStatus::kBadLeafDistribution},  // a stored probability of 0
      {entries, u16(40000), BlobStatus::kBadLeafDistribution},
      {offsets, u32(1), BlobStatus::kBadLeafOffsets},
      {offsets + 4, u32(0), BlobStatus::kBadLeafOffsets},  // must end at entry_count (1)
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
BlobContents chain_tree() {
  BlobContents c = tools::single_part_bpc(5, 3, 2, 40, 3, 1);
  const TreeNode leaf{0, 0, 0, 0, kPadThreshold};
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
  const size_t left = section(good, SectionKind::kLeftChild).offset;
  const size_t index = section(good, SectionKind::kLeafIndex).offset;
  auto node_at = [&](uint32_t m) { return nodes + (m - 1) * sizeof(TreeNode); };
  auto left_at = [&](uint32_t m) { return left + (m - 1) * 4; };
  auto index_at = [&](uint32_t m) { return index + (m - 1) * 4; };
  struct Case {
    const char* what;
    std::function<void(std::vector<uint8_t>&)> edit;
    BlobStatus want;
  };
  const std::vector<Case> cases = {
      {"left child past the tree (its right child would be node 8)", [&](auto& b) { edit<uint32_t>(b, left_at(4), 7); },
       BlobStatus::kBadChildIndex},
      {"left child 0", [&](auto& b) { edit<uint32_t>(b, left_at(2), 0); }, BlobStatus::kBadChildIndex},
      {"a cycle: node 4's child is the root", [&](auto& b) { edit<uint32_t>(b, left_at(4), 1); },
       BlobStatus::kChildBeforeParent},
      {"a cycle: node 2's child is node 2's parent", [&](auto& b) { edit<uint32_t>(b, left_at(2), 1); },
       BlobStatus::kChildBeforeParent},
      {"children out of breadth-first order", [&](auto& b) { edit<uint32_t>(b, left_at(2), 5); },
       BlobStatus::kNotBreadthFirst},
      {"a split node at level depth", [&](auto& b) { edit<uint8_t>(b, meta + offsetof(ForestMeta, depth), 2); },
       BlobStatus::kTreeTooDeep},
      {"nodes 6 and 7 unreached (node 4 made a leaf)",
       [&](auto& b) {
         edit<uint32_t>(b, left_at(4), 4);
         edit(b, node_at(4), TreeNode{0, 0, 0, 0, kPadThreshold});
       },
       BlobStatus::kUnreachedNode},
      {"a leaf node's record past the table", [&](auto& b) { edit<uint32_t>(b, index_at(6), 1); },
       BlobStatus::kBadLeafIndex},
      {"a split node with a record", [&](auto& b) { edit<uint32_t>(b, index_at(2), 1); }, BlobStatus::kBadLeafIndex},
      {"a leaf node without the pad threshold", [&](auto& b) { edit<int16_t>(b, node_at(5) + 8, 100); },
       BlobStatus::kBadLeafNode},
      {"a leaf node with an offset", [&](auto& b) { edit<int16_t>(b, node_at(3), 3); }, BlobStatus::kBadLeafNode},
      {"a split node turned leaf without its pad threshold", [&](auto& b) { edit<uint32_t>(b, left_at(4), 4); },
       BlobStatus::kBadLeafNode},
  };
  for (const Case& c : cases) {
    auto b = good;
    c.edit(b);
    reseal(b);
    EXPECT_EQ(load(b), c.want) << c.what << ": got " << blob_status_message(load(b));
  }
  // The writer refuses the same shapes before writing.
  BlobContents bad = chain_tree();
  bad.tree_left_child[0][3] = 1;
  EXPECT_THROW(write_blob(bad), tools::ToolError);
}

TEST(BlobFormat, LeafOffsetsAndSumsAreRefusedAcrossRecords) {
  // Two records of two parts each (tags 0, 3 and 1, 3); offsets [0, 2, 4].
  auto c = tools::single_part_bpc(5, 3, 2, 40);
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
  for (SectionKind k : {SectionKind::kMeta, SectionKind::kConfig, SectionKind::kNodes, SectionKind::kLeafIndex,
                        SectionKind::kLeafOffsets, SectionKind::kLeafEntries, SectionKind::kEntryTags,
                        SectionKind::kLeftChild}) {
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
