// The loader bounds every field the runtime reads by what the runtime can honour: each RuntimeConfig
// field is walked to its limit (just inside accepted, just outside refused with the field and range
// named), and a blob whose pixel budget does not fit the runtime's int32 pixel counts is refused at
// load rather than crashing a frame later.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"
#include "runtime/depthpose.h"
#include "tools/common/blob_error.h"
#include "tools/common/error.h"
#include "tools/demo/fixtures.h"

using namespace dp;
using namespace dp::blob;

namespace {

struct Aligned {
  std::vector<uint64_t> storage;
  size_t size;
  explicit Aligned(const std::vector<uint8_t>& b) : storage(b.size() / 8 + 1), size(b.size()) {
    if (!b.empty()) std::memcpy(storage.data(), b.data(), b.size());
  }
  const uint8_t* data() const { return reinterpret_cast<const uint8_t*>(storage.data()); }
};

// A blob's bytes with its config section replaced and both CRCs recomputed, so the edit reaches
// the field checks.
std::vector<uint8_t> with_config(std::vector<uint8_t> b, const RuntimeConfig& c) {
  BlobHeader h;
  std::memcpy(&h, b.data(), sizeof h);
  for (uint32_t i = 0; i < h.section_count; ++i) {
    SectionEntry e;
    std::memcpy(&e, b.data() + sizeof h + i * sizeof e, sizeof e);
    if (e.kind == uint32_t(SectionKind::kConfig)) std::memcpy(b.data() + e.offset, &c, sizeof c);
  }
  h.payload_crc32 = crc32(b.data() + h.header_bytes, b.size() - h.header_bytes);
  h.header_crc32 = 0;
  std::memcpy(b.data(), &h, sizeof h);
  h.header_crc32 = crc32(b.data(), h.header_bytes);
  std::memcpy(b.data(), &h, sizeof h);
  return b;
}

struct FieldLimit {
  const char* field;        // as BlobProblem names it
  int64_t min, max;         // accepted range, inclusive
  int64_t type_min, type_max;  // what the field's type can hold (no "outside" value beyond these)
  std::function<void(RuntimeConfig&, int64_t)> set;
  BlobStatus refusal;
};

std::vector<FieldLimit> config_fields(int part_count) {
  const int64_t all_parts = (int64_t(1) << part_count) - 1;
  return {
      {"config.joints[j].part_mask", 1, all_parts, 0, 0xFFFFFFFFll,
       [](RuntimeConfig& c, int64_t v) { c.joints[1].part_mask = uint32_t(v); }, BlobStatus::kBadPartMask},
      {"config.joints[j].prob_threshold_q15", 0, kProbabilityOneQ15, 0, 65535,
       [](RuntimeConfig& c, int64_t v) { c.joints[1].prob_threshold_q15 = uint16_t(v); }, BlobStatus::kBadConfig},
      {"config.joints[j].push_back_mm", -kMaxPushBackMm, kMaxPushBackMm, -32768, 32767,
       [](RuntimeConfig& c, int64_t v) { c.joints[1].push_back_mm = int16_t(v); }, BlobStatus::kBadConfig},
      {"config.joints[j].bandwidth_mm", 1, kMaxBandwidthMm, 0, 65535,
       [](RuntimeConfig& c, int64_t v) { c.joints[1].bandwidth_mm = uint16_t(v); }, BlobStatus::kBadConfig},
      {"config.joints[j].vote_length_mm", 0, kMaxVoteLengthMm, 0, 65535,
       [](RuntimeConfig& c, int64_t v) { c.joints[1].vote_length_mm = uint16_t(v); }, BlobStatus::kBadConfig},
      {"config.far_mm", 1, kMaxFarMm, 0, 65535,
       [](RuntimeConfig& c, int64_t v) { c.near_mm = 0; c.far_mm = uint16_t(v); }, BlobStatus::kBadConfig},
      {"config.near_mm", 0, 7999, 0, 65535, [](RuntimeConfig& c, int64_t v) { c.near_mm = uint16_t(v); },
       BlobStatus::kBadConfig},
      {"config.max_votes_per_joint", 1, kMaxVotesCap, 0, 65535,
       [](RuntimeConfig& c, int64_t v) { c.max_votes_per_joint = uint16_t(v); }, BlobStatus::kBadConfig},
      {"config.max_starts_per_joint", 1, kMaxStartsCap, 0, 65535,
       [](RuntimeConfig& c, int64_t v) { c.max_starts_per_joint = uint16_t(v); }, BlobStatus::kBadConfig},
      {"config.mean_shift_iterations", 1, kMaxMeanShiftIterations, 0, 65535,
       [](RuntimeConfig& c, int64_t v) { c.mean_shift_iterations = uint16_t(v); }, BlobStatus::kBadConfig},
      {"config.max_proposals_per_joint", 1, kMaxProposalsCap, 0, 65535,
       [](RuntimeConfig& c, int64_t v) { c.max_proposals_per_joint = uint16_t(v); }, BlobStatus::kBadConfig},
      {"config.merge_tolerance_mm", 1, kMaxMergeToleranceMm, 0, 65535,
       [](RuntimeConfig& c, int64_t v) { c.merge_tolerance_mm = uint16_t(v); }, BlobStatus::kBadConfig},
      {"config.max_evaluated_pixels", 1, kMaxEvaluatedPixels, 0, 0xFFFFFFFFll,
       [](RuntimeConfig& c, int64_t v) { c.max_evaluated_pixels = uint32_t(v); }, BlobStatus::kBadConfig},
  };
}

}  // namespace

TEST(ReliabilityBlobLimits, EveryConfigFieldWalkedToItsLimit) {
  // 5 parts, 3 joints; far_mm stays 8000 while near_mm is walked (near_mm is 0 while far_mm is).
  const std::vector<uint8_t> good = write_blob(tools::single_part_bpc(5, 3, 3, 40));
  Aligned a(good);
  LoadedBlob b;
  ASSERT_EQ(load_blob(a.data(), a.size, &b), BlobStatus::kOk);
  const RuntimeConfig base = *b.config;
  ASSERT_EQ(base.near_mm, 300);
  ASSERT_EQ(base.far_mm, 8000);
  for (const FieldLimit& f : config_fields(b.meta->part_count)) {
    SCOPED_TRACE(f.field);
    for (int64_t inside : {f.min, f.max}) {
      RuntimeConfig c = base;
      f.set(c, inside);
      BlobProblem p;
      EXPECT_EQ(validate_config(*b.meta, c, &p), BlobStatus::kOk) << "value " << inside << " must be accepted";
      // Through the whole loader too: the value survives a load.
      const std::vector<uint8_t> edited = with_config(good, c);
      Aligned e(edited);
      LoadedBlob out;
      EXPECT_EQ(load_blob(e.data(), e.size, &out), BlobStatus::kOk) << "value " << inside;
    }
    for (int64_t outside : {f.min - 1, f.max + 1}) {
      if (outside < f.type_min || outside > f.type_max) continue;  // the type cannot hold it
      RuntimeConfig c = base;
      f.set(c, outside);
      BlobProblem p;
      EXPECT_EQ(validate_config(*b.meta, c, &p), f.refusal) << "value " << outside << " must be refused";
      ASSERT_NE(p.field, nullptr);
      EXPECT_STREQ(p.field, f.field);
      EXPECT_EQ(p.value, outside);
      EXPECT_EQ(p.min, f.min);
      EXPECT_EQ(p.max, f.max);
      const std::vector<uint8_t> edited = with_config(good, c);
      Aligned e(edited);
      LoadedBlob out;
      BlobProblem lp;
      EXPECT_EQ(load_blob(e.data(), e.size, &out, &lp), f.refusal) << "value " << outside;
      ASSERT_NE(lp.field, nullptr);
      EXPECT_STREQ(lp.field, f.field);
    }
  }
}

TEST(ReliabilityBlobLimits, PixelBudgetBeyondInt32RefusedAtLoadNamingFieldAndLimit) {
  const std::vector<uint8_t> good = write_blob(tools::single_part_bpc(5, 3, 3, 40));
  Aligned a(good);
  LoadedBlob b;
  ASSERT_EQ(load_blob(a.data(), a.size, &b), BlobStatus::kOk);
  for (uint32_t budget : {0x80000000u, 0xFFFFFFFFu, kMaxEvaluatedPixels + 1}) {
    RuntimeConfig c = *b.config;
    c.max_evaluated_pixels = budget;
    const std::vector<uint8_t> edited = with_config(good, c);
    Aligned e(edited);
    LoadedBlob out;
    BlobProblem p;
    const BlobStatus s = load_blob(e.data(), e.size, &out, &p);
    ASSERT_EQ(s, BlobStatus::kBadConfig) << budget;
    const std::string m = tools::blob_error_message(s, p);
    EXPECT_NE(m.find("config.max_evaluated_pixels"), std::string::npos) << m;
    EXPECT_NE(m.find(std::to_string(kMaxEvaluatedPixels)), std::string::npos) << m;
    EXPECT_NE(m.find(std::to_string(budget)), std::string::npos) << m;
    try {
      tools::load_blob_or_fail(edited, "model.blob");
      ADD_FAILURE() << "load_blob_or_fail accepted budget " << budget;
    } catch (const tools::ToolError& err) {
      EXPECT_NE(std::string(err.what()).find("model.blob"), std::string::npos) << err.what();
    }
  }
}

TEST(ReliabilityBlobLimits, LargestPixelBudgetRunsAFrameWithOneForegroundPixel) {
  // The budget at its limit: a frame with exactly one foreground pixel evaluates exactly that
  // pixel (a budget cast to a negative int32 made the runtime evaluate a stale depth-0 pixel).
  blob::BlobContents contents = tools::single_part_bpc(5, 3, 3, 40);
  contents.config.max_evaluated_pixels = kMaxEvaluatedPixels;
  const std::vector<uint8_t> bytes = write_blob(contents);
  Aligned a(bytes);
  LoadedBlob view;
  ASSERT_EQ(load_blob(a.data(), a.size, &view), BlobStatus::kOk);
  const int w = 64, h = 48;
  const size_t arena_bytes = (required_arena_bytes(view, w, h) + 63) / 64 * 64;
  std::unique_ptr<uint8_t, decltype(&std::free)> arena(static_cast<uint8_t*>(std::aligned_alloc(64, arena_bytes)),
                                                        &std::free);
  Pipeline pipeline;
  ASSERT_EQ(pipeline.init(view, w, h, arena.get(), arena_bytes), Status::kOk);
  std::vector<uint16_t> depth(size_t(w) * h, 0);
  depth[size_t(20) * w + 30] = 2000;
  const DepthFrame f{depth.data(), w, h, w, tools::kinect_intrinsics(w, h), nullptr};
  FrameResult r;
  ASSERT_EQ(pipeline.process(f, &r), Status::kOk);
  EXPECT_EQ(r.foreground_pixels, 1);
  EXPECT_EQ(r.evaluated_pixels, 1);
}

TEST(ReliabilityBlobLimits, EmptyBlobSaysItIsEmpty) {
  LoadedBlob out;
  EXPECT_EQ(load_blob(nullptr, 0, &out), BlobStatus::kEmpty);
  const uint64_t word = 0;
  EXPECT_EQ(load_blob(&word, 0, &out), BlobStatus::kEmpty);
  EXPECT_STREQ(blob_status_message(BlobStatus::kEmpty), "blob is empty (0 bytes)");
  try {
    tools::load_blob_or_fail({}, "empty.blob");
    ADD_FAILURE() << "an empty blob was accepted";
  } catch (const tools::ToolError& e) {
    EXPECT_EQ(std::string(e.what()), "empty.blob: not a usable blob: blob is empty (0 bytes)");
  }
}

TEST(ReliabilityBlobLimits, MetaFieldRefusalNamesTheField) {
  std::vector<uint8_t> bytes = write_blob(tools::single_part_bpc(5, 3, 3, 40));
  BlobHeader h;
  std::memcpy(&h, bytes.data(), sizeof h);
  for (uint32_t i = 0; i < h.section_count; ++i) {
    SectionEntry e;
    std::memcpy(&e, bytes.data() + sizeof h + i * sizeof e, sizeof e);
    if (e.kind == uint32_t(SectionKind::kMeta)) bytes[e.offset + offsetof(ForestMeta, depth)] = kMaxDepth + 1;
  }
  h.payload_crc32 = crc32(bytes.data() + h.header_bytes, bytes.size() - h.header_bytes);
  h.header_crc32 = 0;
  std::memcpy(bytes.data(), &h, sizeof h);
  h.header_crc32 = crc32(bytes.data(), h.header_bytes);
  std::memcpy(bytes.data(), &h, sizeof h);
  Aligned a(bytes);
  LoadedBlob out;
  BlobProblem p;
  const BlobStatus s = load_blob(a.data(), a.size, &out, &p);
  ASSERT_EQ(s, BlobStatus::kBadDepth);
  EXPECT_EQ(tools::blob_error_message(s, p), "meta.depth = 21 is outside 1..20 (tree depth out of range)");
}
