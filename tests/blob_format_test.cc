// forest_blob v1: round trip, every refusal the loader promises, truncation at every section
// boundary and every single-bit flip.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "tools/common/error.h"
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
  EXPECT_EQ(b.bpc_leaf(5)[7], contents.bpc_leaves[5 * 31 + 7]);
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
  EXPECT_EQ(view.ojr_leaf(0)[2].dz_mm, 30);
  EXPECT_EQ(view.ojr_leaf(0)[1].dy_mm, -20);
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
  edit<uint16_t>(b, offsetof(BlobHeader, version_major), 2);
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
  const size_t leaves = section(good, SectionKind::kLeaves).offset;
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
      {meta + offsetof(ForestMeta, leaf_stride_bytes), u32(6), BlobStatus::kBadLeafStride},
      {meta + offsetof(ForestMeta, max_width), u32(0), BlobStatus::kBadFrameSize},
      {meta + offsetof(ForestMeta, max_abs_offset_pxm), u32(5000), BlobStatus::kOffsetTooLarge},
      {meta + offsetof(ForestMeta, reserved2), u32(1), BlobStatus::kReservedNotZero},
      {meta + offsetof(ForestMeta, part_names) + 2, u8(0x01), BlobStatus::kBadName},
      {meta + offsetof(ForestMeta, joint_names) + 5 * kNameBytes, u8('x'), BlobStatus::kBadName},
      {nodes + offsetof(TreeNode, dv2), u16(uint16_t(int16_t(-5))), BlobStatus::kOffsetTooLarge},
      {index + 4 * 3, u32(1), BlobStatus::kBadLeafIndex},
      {leaves, u16(1), BlobStatus::kBadLeafDistribution},
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
  const size_t vote = section(o, SectionKind::kLeaves).offset;
  edit<int16_t>(o, vote + offsetof(OjrVote, dy_mm), 2500);
  reseal(o);
  EXPECT_EQ(load(o), BlobStatus::kBadVote);
}

TEST(BlobFormat, TruncationAtEverySectionBoundaryIsRefused) {
  const auto good = small_bpc();
  std::vector<size_t> cuts = {0, 1, sizeof(BlobHeader) - 1, sizeof(BlobHeader), header_of(good).header_bytes};
  for (SectionKind k : {SectionKind::kMeta, SectionKind::kConfig, SectionKind::kNodes, SectionKind::kLeafIndex,
                        SectionKind::kLeaves}) {
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
