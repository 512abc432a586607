// forest_blob v2: round trip (compact leaves back to the dense contents), every refusal the loader
// promises, truncation at every section boundary, every single-bit flip, and the v1 upgrade.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
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
  for (int t = 0; t < 3; ++t)
    for (size_t n = 0; n < nodes_per_tree(6); ++n) {
      EXPECT_EQ(b.tree_nodes(t)[n].du1, contents.tree_nodes[t][n].du1);
      EXPECT_EQ(b.tree_nodes(t)[n].threshold_mm, contents.tree_nodes[t][n].threshold_mm);
    }
  for (size_t s = 0; s < leaves_per_tree(6); ++s) EXPECT_EQ(b.tree_leaf_index(2)[s], contents.tree_leaf_index[2][s]);
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
// A format-1 blob of `c` (dense leaves, five sections), written here independently of the current
// writer, as the v1 writer laid it out: BPC records padded to a multiple of 4 bytes.
std::vector<uint8_t> v1_blob(const BlobContents& c) {
  const bool bpc = c.method == Method::kBpc;
  const size_t parts = c.part_names.size(), per_leaf = c.joint_names.size() * size_t(c.votes_per_joint);
  const uint32_t stride = bpc ? uint32_t((2 * parts + 3) / 4 * 4) : uint32_t(per_leaf * sizeof(OjrVote));
  const uint32_t leaves = uint32_t(bpc ? c.bpc_leaves.size() / parts : c.ojr_leaves.size() / per_leaf);
  const size_t trees = c.tree_nodes.size();
  const size_t sizes[5] = {sizeof(ForestMeta), sizeof(RuntimeConfig), trees * nodes_per_tree(c.depth) * sizeof(TreeNode),
                           trees * leaves_per_tree(c.depth) * 4, size_t(leaves) * stride};
  const size_t header = sizeof(BlobHeader) + 5 * sizeof(SectionEntry);
  SectionEntry e[5]{};
  size_t at = (header + 63) / 64 * 64;
  for (int k = 0; k < 5; ++k) {
    e[k] = SectionEntry{uint32_t(k + 1), 0, at, sizes[k]};
    at = (at + sizes[k] + 63) / 64 * 64;
  }
  std::vector<uint8_t> out(e[4].offset + e[4].size, 0);
  ForestMeta m{};
  m.method = uint8_t(c.method);
  m.tree_count = uint8_t(trees);
  m.depth = uint8_t(c.depth);
  m.part_count = uint8_t(parts);
  m.joint_count = uint8_t(c.joint_names.size());
  m.votes_per_joint = uint8_t(c.votes_per_joint);
  m.reference_focal_px = c.reference_focal_px;
  m.leaf_count = leaves;
  m.entry_count = stride;  // v1: leaf_stride_bytes
  m.max_width = c.max_width;
  m.max_height = c.max_height;
  for (size_t i = 0; i < parts; ++i) std::memcpy(m.part_names[i], c.part_names[i].data(), c.part_names[i].size());
  for (size_t i = 0; i < c.joint_names.size(); ++i)
    std::memcpy(m.joint_names[i], c.joint_names[i].data(), c.joint_names[i].size());
  std::memcpy(out.data() + e[0].offset, &m, sizeof m);
  std::memcpy(out.data() + e[1].offset, &c.config, sizeof c.config);
  for (size_t t = 0; t < trees; ++t) {
    std::memcpy(out.data() + e[2].offset + t * nodes_per_tree(c.depth) * sizeof(TreeNode), c.tree_nodes[t].data(),
                nodes_per_tree(c.depth) * sizeof(TreeNode));
    std::memcpy(out.data() + e[3].offset + t * leaves_per_tree(c.depth) * 4, c.tree_leaf_index[t].data(),
                leaves_per_tree(c.depth) * 4);
  }
  for (uint32_t l = 0; l < leaves; ++l) {
    uint8_t* rec = out.data() + e[4].offset + size_t(l) * stride;
    if (bpc) std::memcpy(rec, &c.bpc_leaves[l * parts], parts * 2);
    else std::memcpy(rec, &c.ojr_leaves[l * per_leaf], per_leaf * sizeof(OjrVote));
  }
  BlobHeader h{};
  h.magic = kMagic;
  h.endian_tag = kEndianTag;
  h.version_major = 1;
  h.header_bytes = uint32_t(header);
  h.total_bytes = out.size();
  h.section_count = 5;
  std::memcpy(out.data(), &h, sizeof h);
  std::memcpy(out.data() + sizeof h, e, sizeof e);
  reseal(out);
  return out;
}
}  // namespace

TEST(BlobFormat, Version1IsRefusedByNameAndUpgradesLosslessly) {
  for (const BlobContents& c : {tools::random_bpc_forest(3, 2, 5, 31, 100, 300), tools::single_vote_ojr(16, 7, 8, -9)}) {
    const std::vector<uint8_t> old = v1_blob(c);
    EXPECT_EQ(load(old), BlobStatus::kVersionTooOld);
    EXPECT_NE(std::string(blob_status_message(BlobStatus::kVersionTooOld)).find("version 1 (dense leaves)"),
              std::string::npos);
    EXPECT_NE(std::string(blob_status_message(BlobStatus::kVersionTooOld)).find("--upgrade-blob"), std::string::npos);
    const std::vector<uint8_t> upgraded = write_blob(tools::read_v1_blob(old, "old.blob"));
    EXPECT_EQ(upgraded, write_blob(c)) << "the upgrade must equal writing the same contents directly";
    auto corrupt = old;
    corrupt.back() ^= 1;
    EXPECT_THROW(tools::read_v1_blob(corrupt, "old.blob"), tools::ToolError);
    EXPECT_THROW(tools::read_v1_blob(upgraded, "new.blob"), tools::ToolError) << "a v2 blob is not a v1 blob";
  }
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
  edit<uint16_t>(b, offsetof(BlobHeader, version_major), 3);
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
      {index + 4 * 3, u32(1), BlobStatus::kBadLeafIndex},
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

TEST(BlobFormat, LeafOffsetsAndSumsAreRefusedAcrossRecords) {
  // Two records of two parts each (tags 0, 3 and 1, 3); offsets [0, 2, 4].
  auto c = tools::single_part_bpc(5, 3, 2, 40);
  c.bpc_leaves = {16384, 0, 0, 16384, 0, 0, 8192, 0, 8192, 0};
  c.tree_leaf_index[0][1] = 1;
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
  c.tree_leaf_index[0][1] = 99;  // points past the leaf table
  EXPECT_THROW(write_blob(c), tools::ToolError);
  c = tools::single_part_bpc(5, 3, 2, 40);
  c.part_names[0] = std::string(30, 'a');
  EXPECT_THROW(write_blob(c), tools::ToolError);
}
