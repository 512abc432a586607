// depthpose's own .oni reader: the codecs on crafted payloads, the record walk on crafted and
// corrupted containers (each refusal names the file, the byte and the field), and frame-for-frame
// equality with OpenNI2's own player on models/demo.oni (which carries the integrity trailer), and
// the integrity trailer catching every changed payload byte and every damaged trailer.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>

#include "platform/oni_codec.h"
#include "platform/oni_container.h"
#include "platform/oni_file_source.h"
#include "platform/openni_source.h"
#include "tests/app_test_support.h"
#include "tests/cli_test_support.h"
#include "tools/common/error.h"

using namespace dp;
using namespace dp::platform;
using dp::apptest::TempDir;

namespace {

using apptest::error_of;

#define EXPECT_HAS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

// ---- codecs ----

struct Decoded {
  bool ok;
  std::vector<uint16_t> pixels;
  OniDecodeProblem problem;
};
Decoded decode(uint32_t codec, const std::vector<uint8_t>& payload, size_t pixels) {
  Decoded d{false, std::vector<uint16_t>(pixels, 0xDEAD), {}};
  d.ok = decode_oni_depth(codec, payload.data(), payload.size(), d.pixels.data(), pixels, &d.problem);
  return d;
}

}  // namespace

TEST(OniCodec, SixteenZDecodesEveryKindOfCode) {
  // 1000, then nibbles (h=5: −(5−6) → +1, l=8: −2), an escape after l=15 with a 7-bit delta
  // (0xC5: −(197−192) → −5), 0xFF with a full value 0x1234, a repeat (0xE2: 4 copies), a pair with
  // the odd-half padding (h=6: +0, l=13: nothing).
  const std::vector<uint8_t> p = {0xE8, 0x03, 0x58, 0x6F, 0xC5, 0xFF, 0x12, 0x34, 0xE2, 0x6D};
  const Decoded d = decode(kOniCodec16z, p, 11);
  ASSERT_TRUE(d.ok) << describe(d.problem, 0);
  const std::vector<uint16_t> want = {1000, 1001, 999, 999, 994, 0x1234, 0x1234, 0x1234, 0x1234, 0x1234, 0x1234};
  EXPECT_EQ(d.pixels, want);
}

TEST(OniCodec, SixteenZWithTableLooksUpEveryIndex) {
  // Table {0, 800, 65535}; indices 1, 2 (h=5: +1), 0 (escape full value 0), 0 (repeat ×2: 2 more).
  const std::vector<uint8_t> p = {3, 0, 0x00, 0x00, 0x20, 0x03, 0xFF, 0xFF, 0x01, 0x00,
                                  0x5F, 0x00, 0x00, 0xE1};
  const Decoded d = decode(kOniCodec16zTable, p, 5);
  ASSERT_TRUE(d.ok) << describe(d.problem, 0);
  EXPECT_EQ(d.pixels, (std::vector<uint16_t>{800, 65535, 0, 0, 0}));
}

TEST(OniCodec, UncompressedNeedsTheExactSize) {
  const std::vector<uint8_t> p = {1, 0, 2, 0, 3, 1};
  const Decoded d = decode(kOniCodecUncompressed, p, 3);
  ASSERT_TRUE(d.ok);
  EXPECT_EQ(d.pixels, (std::vector<uint16_t>{1, 2, 259}));
  const Decoded bad = decode(kOniCodecUncompressed, p, 4);
  ASSERT_FALSE(bad.ok);
  EXPECT_HAS(describe(bad.problem, 100), "uncompressed frame size in bytes at byte 100 (6 against 8)");
}

TEST(OniCodec, CorruptPayloadsAreRefusedAtTheirByte) {
  struct Case {
    uint32_t codec;
    std::vector<uint8_t> payload;
    size_t pixels;
    const char* field;
    size_t offset;
  };
  const Case cases[] = {
      {kOniCodec16z, {0xE8}, 2, "first value beyond the payload", 0},
      {kOniCodec16z, {0xE8, 0x03, 0x6F}, 3, "escape byte beyond the payload", 3},
      {kOniCodec16z, {0xE8, 0x03, 0xFF, 0x12}, 2, "second byte of a full value beyond the payload", 3},
      {kOniCodec16z, {0xE8, 0x03, 0x66, 0xD6}, 5, "high nibble 13", 3},
      {kOniCodec16z, {0xE8, 0x03, 0x6E}, 3, "low nibble 14", 2},
      {kOniCodec16z, {0xE8, 0x03, 0xE0}, 1, "repeat code", 2},
      {kOniCodec16z, {0xE8, 0x03, 0xF5}, 40, "repeat code", 2},
      {kOniCodec16z, {0xE8, 0x03, 0x66, 0x66}, 4, "more pixels than the frame holds", 3},
      {kOniCodec16z, {0xE8, 0x03, 0x66}, 4, "pixel count (frame ends early)", 3},
      {kOniCodec16zTable, {5}, 1, "table size beyond the payload", 0},
      {kOniCodec16zTable, {0, 0, 0, 0}, 1, "table size (0 entries)", 0},
      {kOniCodec16zTable, {3, 0, 1, 0}, 1, "table beyond the payload", 0},
      {kOniCodec16zTable, {1, 0, 7, 0, 1, 0}, 1, "table index", 4},
      {kOniCodec16zTable, {2, 0, 7, 0, 9, 0, 1, 0, 0x56}, 3, "table index", 8},
      {oni_fourcc('J', 'P', 'E', 'G'), {1, 2}, 1, "codec (NONE, 16zP or 16zT)", 0},
  };
  for (const Case& c : cases) {
    const Decoded d = decode(c.codec, c.payload, c.pixels);
    ASSERT_FALSE(d.ok) << c.field;
    EXPECT_HAS(d.problem.field, c.field);
    EXPECT_EQ(d.problem.offset, c.offset) << c.field;
  }
}

TEST(OniCodec, EveryTruncationOfADemoFrameIsRefused) {
  // The first frame of demo.oni cut at every length: never accepted, never read past its end
  // (ASan), always a named problem.
  const std::string demo = "models/demo.oni";
  ASSERT_TRUE(std::filesystem::exists(demo)) << demo << " is missing (make model builds it)";
  std::vector<OniFrameRecord> frames;
  const MappedOniFile file(demo, demo);
  const OniContainerSummary s = check_oni_bytes(file.data(), file.size(), demo, &frames);
  ASSERT_EQ(s.codec, kOniCodec16zTable);
  const size_t pixels = size_t(s.width) * size_t(s.height);
  std::vector<uint16_t> out(pixels);
  OniDecodeProblem problem;
  const OniFrameRecord& f = frames[0];
  ASSERT_TRUE(decode_oni_depth(s.codec, file.data() + f.payload_offset, f.payload_bytes, out.data(), pixels, &problem));
  for (size_t cut = 0; cut < f.payload_bytes; cut += (cut < 600 ? 1 : 97)) {
    std::vector<uint8_t> part(file.data() + f.payload_offset, file.data() + f.payload_offset + cut);
    EXPECT_FALSE(decode_oni_depth(s.codec, part.data(), part.size(), out.data(), pixels, &problem)) << cut;
    EXPECT_NE(std::string(problem.field), "") << cut;
  }
  // The same frame declared one row smaller or larger does not decode either.
  EXPECT_FALSE(decode_oni_depth(s.codec, file.data() + f.payload_offset, f.payload_bytes, out.data(),
                                pixels - size_t(s.width), &problem));
  std::vector<uint16_t> bigger(pixels + size_t(s.width));
  EXPECT_FALSE(decode_oni_depth(s.codec, file.data() + f.payload_offset, f.payload_bytes, bigger.data(),
                                pixels + size_t(s.width), &problem));
  EXPECT_HAS(problem.field, "pixel count");
}

// ---- containers ----

namespace {

// Writes a small .oni the way OpenNI2 2.2 lays it out: header, node added (type 13), properties,
// new-data records, seek table, end.
struct OniBuilder {
  std::vector<uint8_t> bytes;
  void u32(uint32_t v) { for (int k = 0; k < 4; ++k) bytes.push_back(uint8_t(v >> (8 * k))); }
  void u64(uint64_t v) { for (int k = 0; k < 8; ++k) bytes.push_back(uint8_t(v >> (8 * k))); }
  void name(const std::string& n) {
    u32(uint32_t(n.size() + 1));
    bytes.insert(bytes.end(), n.begin(), n.end());
    bytes.push_back(0);
  }
  size_t header_at = 0;
  size_t record(uint32_t type, uint32_t node, const std::vector<uint8_t>& fields, const std::vector<uint8_t>& payload) {
    const size_t at = bytes.size();
    u32(0x0052494E);
    u32(type);
    u32(node);
    u32(uint32_t(28 + fields.size()));
    u32(uint32_t(payload.size()));
    u64(0);
    bytes.insert(bytes.end(), fields.begin(), fields.end());
    bytes.insert(bytes.end(), payload.begin(), payload.end());
    return at;
  }
  static std::vector<uint8_t> take(OniBuilder& b) { return std::move(b.bytes); }
};

struct Made {
  std::vector<uint8_t> bytes;
  std::vector<size_t> frame_records;  // offset of each new-data record
  size_t mode_at = 0;                 // xnMapOutputMode's width field
};

// A recording of `frames` (each width·height pixels) in `codec` (NONE or 16zP, written by the
// simplest valid code: a full value per pixel).
Made make_oni(int width, int height, uint32_t codec, const std::vector<std::vector<uint16_t>>& frames,
              int pixel_format = kOniPixelFormatDepth1mm) {
  OniBuilder b;
  const char magic[] = "NI10";
  b.bytes.insert(b.bytes.end(), magic, magic + 4);
  b.bytes.insert(b.bytes.end(), {1, 0, 0, 0, 0, 0, 0, 0});
  b.u64(uint64_t(frames.size()) * 33333);
  b.u32(1);
  Made m;
  auto fields = [](const std::function<void(OniBuilder&)>& fill) {
    OniBuilder f;
    fill(f);
    return OniBuilder::take(f);
  };
  b.record(13, 1, fields([&](OniBuilder& f) {
             f.name("Depth");
             f.u32(2);
             f.u32(codec);
             f.u32(uint32_t(frames.size()));
             f.u64(0);
             f.u64(0);
             f.u64(0);
           }),
           {});
  const size_t mode = b.record(6, 1, fields([&](OniBuilder& f) {
                                 f.name("xnMapOutputMode");
                                 f.u32(12);
                                 f.u32(uint32_t(width));
                                 f.u32(uint32_t(height));
                                 f.u32(30);
                               }),
                               {});
  m.mode_at = mode + 28 + 4 + 16 + 4;
  b.record(3, 1, fields([&](OniBuilder& f) {
             f.name("oniPixelFormat");
             f.u32(8);
             f.u64(uint64_t(pixel_format));
           }),
           {});
  uint32_t id = 1;
  for (const auto& frame : frames) {
    std::vector<uint8_t> payload;
    if (codec == kOniCodecUncompressed) {
      for (uint16_t v : frame) payload.insert(payload.end(), {uint8_t(v), uint8_t(v >> 8)});
    } else {
      payload = {uint8_t(frame[0]), uint8_t(frame[0] >> 8)};
      for (size_t k = 1; k < frame.size(); ++k) payload.insert(payload.end(), {0xFF, uint8_t(frame[k] >> 8), uint8_t(frame[k])});
    }
    m.frame_records.push_back(b.record(10, 1, fields([&](OniBuilder& f) {
                                         f.u64(uint64_t(id - 1) * 33333);
                                         f.u32(id);
                                       }),
                                       payload));
    ++id;
  }
  b.record(11, 0, {}, {});
  m.bytes = OniBuilder::take(b);
  return m;
}

void write_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

std::vector<std::vector<uint16_t>> ramp_frames(int count, int width, int height, uint16_t scale = 1) {
  std::vector<std::vector<uint16_t>> frames;
  for (int i = 0; i < count; ++i) {
    std::vector<uint16_t> f(size_t(width) * size_t(height));
    for (size_t p = 0; p < f.size(); ++p) f[p] = uint16_t((800 + 13 * p + 101 * size_t(i)) * scale % 30000);
    frames.push_back(f);
  }
  return frames;
}

}  // namespace

TEST(OniReader, CraftedRecordingsPlayAndRewindInEveryCodec) {
  TempDir t;
  const auto frames = ramp_frames(3, 7, 5);
  for (uint32_t codec : {kOniCodecUncompressed, kOniCodec16z}) {
    const std::string path = t / (oni_codec_name(codec) + ".oni");
    write_file(path, make_oni(7, 5, codec, frames).bytes);
    auto s = open_oni_source(path);
    ASSERT_EQ(s->width(), 7);
    ASSERT_EQ(s->height(), 5);
    ASSERT_EQ(s->frame_count(), 3);
    std::vector<uint16_t> depth(35);
    FrameInfo info;
    for (int round = 0; round < 2; ++round) {
      for (int i = 0; i < 3; ++i) {
        ASSERT_EQ(s->next(depth.data(), &info), NextStatus::kFrame);
        EXPECT_EQ(depth, frames[size_t(i)]) << oni_codec_name(codec) << " frame " << i;
        EXPECT_EQ(info.timestamp_us, uint64_t(i) * 33333);
      }
      EXPECT_EQ(s->next(depth.data(), &info), NextStatus::kEnd);
      ASSERT_TRUE(s->rewind());
    }
    EXPECT_EQ(s->stats().frames, 6);
  }
}

TEST(OniReader, HundredMicrometreDepthBecomesMillimetres) {
  TempDir t;
  const auto frames = ramp_frames(1, 4, 2, 10);
  write_file(t / "um.oni", make_oni(4, 2, kOniCodec16z, frames, kOniPixelFormatDepth100um).bytes);
  auto s = open_oni_source(t / "um.oni");
  std::vector<uint16_t> depth(8);
  FrameInfo info;
  ASSERT_EQ(s->next(depth.data(), &info), NextStatus::kFrame);
  for (size_t p = 0; p < 8; ++p) EXPECT_EQ(depth[p], (frames[0][p] + 5) / 10);
}

TEST(OniReader, CorruptRecordsAreRefusedNamingFileByteAndField) {
  TempDir t;
  const Made good = make_oni(6, 4, kOniCodecUncompressed, ramp_frames(2, 6, 4));
  struct Case {
    std::string what;
    std::function<void(std::vector<uint8_t>&)> corrupt;
    std::string field;
    size_t at;
  };
  auto put32 = [](std::vector<uint8_t>& b, size_t at, uint32_t v) { std::memcpy(&b[at], &v, 4); };
  const size_t f1 = good.frame_records[1];
  const std::vector<Case> cases = {
      {"payload beyond the file", [&](auto& b) { put32(b, f1 + 16, 1u << 30); }, "record payload size 1073741824 beyond the file", f1 + 16},
      {"frame of another size", [&](auto& b) { put32(b, good.mode_at, 5); }, "depth frame payload of 48 bytes for a 5x4 NONE frame (exactly 40)", good.frame_records[0] + 16},
      {"width 0", [&](auto& b) { put32(b, good.mode_at, 0); }, "depth resolution 0x4", good.mode_at},
      {"codec", [&](auto& b) { put32(b, 24 + 28 + 4 + 6 + 4, oni_fourcc('J', 'P', 'E', 'G')); }, "depth codec 'JPEG'", 24 + 28 + 4 + 6 + 4},
      {"frame count above the limit", [&](auto& b) { put32(b, 24 + 28 + 4 + 6 + 8, uint32_t(kMaxOniFrames + 1)); }, "depth frame count 4000001 above the limit 4000000", 24 + 28 + 4 + 6 + 8},
      {"more frames than declared", [&](auto& b) { put32(b, 24 + 28 + 4 + 6 + 8, 1); }, "more frames than node 1 declares (1)", f1},
      {"record magic", [&](auto& b) { b[f1] = 'X'; }, "record magic is not \"NIR\"", f1},
      {"record type", [&](auto& b) { put32(b, f1 + 4, 99); }, "unknown record type 99", f1 + 4},
      {"fields size", [&](auto& b) { put32(b, f1 + 12, 27); }, "record fields size 27 beyond the file", f1 + 12},
      {"frame without timestamp", [&](auto& b) { put32(b, f1 + 12, 28); }, "frame record without timestamp and frame id", f1 + 28},
      {"pixel format", [&](auto& b) {
         const size_t at = good.mode_at + 12 + 28 + 4 + 15 + 4;  // oniPixelFormat's value
         put32(b, at, 102);
       }, "depth pixel format 102", good.mode_at + 12 + 28 + 4 + 15 + 4},
  };
  for (const Case& c : cases) {
    std::vector<uint8_t> b = good.bytes;
    c.corrupt(b);
    const std::string path = t / "bad.oni";
    write_file(path, b);
    const std::string m = error_of([&] { open_oni_source(path); });
    EXPECT_HAS(m, "oni:" + path + ": not a readable OpenNI2 recording");
    EXPECT_HAS(m, c.field);
    EXPECT_HAS(m, " at byte " + std::to_string(c.at) + ")");
  }
  // Truncated anywhere: refused with the label named, never a crash (an exact-size copy, so ASan
  // sees any read past the end); once through a file too.
  for (size_t cut = 0; cut < good.bytes.size(); ++cut) {
    const std::vector<uint8_t> part(good.bytes.begin(), good.bytes.begin() + std::ptrdiff_t(cut));
    const std::string m = error_of([&] { check_oni_bytes(part.data(), part.size(), "oni:cut.oni"); });
    EXPECT_HAS(m, "oni:cut.oni: not a readable OpenNI2 recording (truncated or corrupt: ");
  }
  const std::string path = t / "cut.oni";
  write_file(path, std::vector<uint8_t>(good.bytes.begin(), good.bytes.end() - 28));
  EXPECT_HAS(error_of([&] { open_oni_source(path); }), "oni:" + path + ": not a readable OpenNI2 recording (truncated or corrupt: no end record (the file ends after 2 depth frames) at byte " + std::to_string(good.bytes.size() - 28) + ")");
}

TEST(OniReader, AFrameThatDoesNotDecodeIsSkippedWithItsByte) {
  TempDir t;
  const auto frames = ramp_frames(3, 5, 3);
  Made m = make_oni(5, 3, kOniCodec16z, frames);
  // Frame 1's second code becomes 0xD6 (a high nibble never written).
  const size_t bad_byte = m.frame_records[1] + 28 + 12 + 2 + 3;
  m.bytes[bad_byte] = 0xD6;
  const std::string path = t / "flip.oni";
  write_file(path, m.bytes);
  auto s = open_oni_source(path);
  std::vector<uint16_t> depth(15);
  FrameInfo info;
  ASSERT_EQ(s->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(info.index, 0);
  ASSERT_EQ(s->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(info.index, 2);
  EXPECT_EQ(depth, frames[2]);
  EXPECT_EQ(s->stats().corrupt_frames, 1);
  EXPECT_HAS(s->last_warning(), "oni:" + path + ": frame 1 is corrupt (16zP delta code (high nibble 13 is never written) at byte " +
                                    std::to_string(bad_byte));
}

// ---- integrity trailer ----

namespace {

// `m` with depthpose's integrity trailer appended after its end record (as `record` writes it).
std::vector<uint8_t> with_trailer(const Made& m) {
  std::vector<OniFrameRecord> frames;
  check_oni_bytes(m.bytes.data(), m.bytes.size(), "made.oni", &frames);
  std::vector<uint8_t> out = m.bytes;
  const std::vector<uint8_t> trailer = oni_integrity_trailer(m.bytes.data(), frames);
  out.insert(out.end(), trailer.begin(), trailer.end());
  return out;
}

// Every frame the source delivers (index → depth), and the source's stats and last warning.
struct Played {
  std::map<int64_t, std::vector<uint16_t>> frames;
  int64_t corrupt = 0;
  std::string warning;
};
Played play(const std::string& path) {
  auto s = open_oni_source(path);
  Played p;
  std::vector<uint16_t> depth(size_t(s->width()) * size_t(s->height()));
  FrameInfo info;
  while (s->next(depth.data(), &info) == NextStatus::kFrame) p.frames[info.index] = depth;
  p.corrupt = s->stats().corrupt_frames;
  p.warning = s->last_warning();
  return p;
}

}  // namespace

TEST(OniIntegrity, TrailerLayoutIsTheDocumentedOne) {
  const Made m = make_oni(5, 3, kOniCodec16z, ramp_frames(3, 5, 3));
  const std::vector<uint8_t> b = with_trailer(m);
  ASSERT_EQ(b.size(), m.bytes.size() + 20 + 4 * 3 + 12);
  const uint8_t* t = b.data() + m.bytes.size();
  EXPECT_EQ(std::memcmp(t, "DPONICRC", 8), 0);
  uint32_t version, count, length, crc;
  std::memcpy(&version, t + 8, 4);
  std::memcpy(&count, t + 12, 4);
  std::memcpy(&crc, t + 28, 4);
  std::memcpy(&length, t + 32, 4);
  EXPECT_EQ(version, 1u);
  EXPECT_EQ(count, 3u);
  EXPECT_EQ(length, 32u);
  EXPECT_EQ(std::memcmp(t + 36, "DPONIEND", 8), 0);
  EXPECT_EQ(crc, uint32_t(::crc32(0L, t, 28)));  // IEEE CRC-32, as zlib computes it
  for (uint32_t i = 0; i < 3; ++i) {
    uint32_t frame_crc;
    std::memcpy(&frame_crc, t + 16 + 4 * i, 4);
    const size_t payload = m.frame_records[i] + 28 + 12;
    const size_t bytes = 2 + 3 * 14;  // make_oni's 16zP: a full value, then 14 three-byte codes
    EXPECT_EQ(frame_crc, uint32_t(::crc32(0L, b.data() + payload, uInt(bytes)))) << "frame " << i;
  }
  const OniContainerSummary s = check_oni_bytes(b.data(), b.size(), "t.oni");
  EXPECT_TRUE(s.integrity_trailer);
  EXPECT_EQ(s.trailer_offset, m.bytes.size());
  EXPECT_FALSE(check_oni_bytes(m.bytes.data(), m.bytes.size(), "t.oni").integrity_trailer);
}

TEST(OniIntegrity, EverySingleByteFlipInEveryPayloadIsCaught) {
  TempDir t;
  const auto frames = ramp_frames(3, 5, 3);
  const Made m = make_oni(5, 3, kOniCodec16z, frames);
  const std::vector<uint8_t> good = with_trailer(m);
  const std::string path = t / "flip.oni";
  int64_t flips = 0, silently_wrong_without_trailer = 0;
  for (size_t f = 0; f < frames.size(); ++f) {
    const size_t payload = m.frame_records[f] + 28 + 12, bytes = 2 + 3 * 14;
    for (size_t k = payload; k < payload + bytes; ++k)
      for (uint8_t mask : {uint8_t(0x01), uint8_t(0xFF)}) {
        std::vector<uint8_t> b = good;
        b[k] ^= mask;
        write_file(path, b);
        const Played p = play(path);
        ++flips;
        ASSERT_EQ(p.corrupt, 1) << "byte " << k << " ^ " << int(mask);
        EXPECT_EQ(p.frames.count(int64_t(f)), 0u) << "byte " << k;
        for (size_t other = 0; other < frames.size(); ++other) {
          if (other != f) {
            EXPECT_EQ(p.frames.at(int64_t(other)), frames[other]) << "byte " << k;
          }
        }
        EXPECT_HAS(p.warning, "oni:" + path + ": frame " + std::to_string(f) + " is corrupt (");
        // A flip the codec cannot see is named by the trailer entry and the payload's bytes.
        if (p.warning.find("payload CRC-32") != std::string::npos) {
          EXPECT_HAS(p.warning, "differs from the integrity trailer's 0x");
        }
        EXPECT_HAS(p.warning, std::to_string(payload) + ".." + std::to_string(payload + bytes - 1) + " changed");
        // The same flip without the trailer: does the codec alone notice it?
        std::vector<uint16_t> decoded(frames[f].size());
        OniDecodeProblem problem;
        if (decode_oni_depth(kOniCodec16z, b.data() + payload, bytes, decoded.data(), decoded.size(), &problem) &&
            decoded != frames[f])
          ++silently_wrong_without_trailer;
      }
  }
  EXPECT_EQ(flips, 3 * 44 * 2);
  // Without the trailer 138 of these 264 flips still decode (they change a depth value): the
  // trailer is what catches them.
  EXPECT_GT(silently_wrong_without_trailer, flips / 3) << silently_wrong_without_trailer;
}

TEST(OniIntegrity, TrailerCorruptionsAndTruncationsAreRefusedNamingTheField) {
  TempDir t;
  const Made m = make_oni(5, 3, kOniCodec16z, ramp_frames(3, 5, 3));
  const std::vector<uint8_t> good = with_trailer(m);
  const size_t at = m.bytes.size(), footer = good.size() - 12;
  const std::string path = t / "bad.oni";
  const std::string refused = "oni:" + path + ": not a readable OpenNI2 recording (corrupt integrity trailer: ";
  auto error_for = [&](const std::vector<uint8_t>& b) {
    write_file(path, b);
    return error_of([&] { open_oni_source(path); });
  };
  auto put32 = [](std::vector<uint8_t>& b, size_t where, uint32_t v) { std::memcpy(&b[where], &v, 4); };
  // A trailer with a valid CRC over changed fields.
  auto resealed = [&](const std::function<void(std::vector<uint8_t>&)>& change) {
    std::vector<uint8_t> b = good;
    change(b);
    const size_t crc_at = footer - 4;
    put32(b, crc_at, uint32_t(::crc32(0L, b.data() + at, uInt(crc_at - at))));
    return b;
  };
  {
    std::vector<uint8_t> b = good;
    b[at + 16] ^= 0x10;  // frame 0's CRC entry
    EXPECT_HAS(error_for(b), refused + "trailer CRC-32 0x");
    EXPECT_HAS(error_for(b), " at byte " + std::to_string(footer - 4) + ")");
  }
  EXPECT_HAS(error_for(resealed([&](auto& b) { put32(b, at + 8, 2); })),
             refused + "format version 2 (this build reads 1) at byte " + std::to_string(at + 8) + ")");
  EXPECT_HAS(error_for(resealed([&](auto& b) { put32(b, at + 12, 2); })),
             refused + "frame count 2 disagrees with the trailer length 32 at byte " + std::to_string(at + 12) + ")");
  {
    // A trailer written for two of the three frames: its count disagrees with the file's frames.
    std::vector<OniFrameRecord> frames;
    check_oni_bytes(m.bytes.data(), m.bytes.size(), "made.oni", &frames);
    frames.pop_back();
    std::vector<uint8_t> b = m.bytes;
    const std::vector<uint8_t> trailer = oni_integrity_trailer(m.bytes.data(), frames);
    b.insert(b.end(), trailer.begin(), trailer.end());
    EXPECT_HAS(error_for(b), refused + "frame count 2 but the file holds 3 depth frames at byte " +
                                 std::to_string(at + 12) + ")");
  }
  {
    std::vector<uint8_t> b = good;
    put32(b, footer, 36);
    EXPECT_HAS(error_for(b), refused + "trailer length 36 in the footer disagrees with the 32 bytes between the end "
                                       "record and the footer at byte " + std::to_string(footer) + ")");
  }
  {
    std::vector<uint8_t> b = good;
    b[at] = 'X';
    EXPECT_HAS(error_for(b), refused + "magic is not \"DPONICRC\" at byte " + std::to_string(at) + ")");
  }
  // Every single-byte change of the trailer or footer, and every truncation inside them: refused.
  for (size_t k = at; k < good.size(); ++k) {
    std::vector<uint8_t> b = good;
    b[k] ^= 0x04;
    const std::vector<uint8_t> exact(b);
    EXPECT_HAS(error_of([&] { check_oni_bytes(exact.data(), exact.size(), "oni:x.oni"); }),
               "oni:x.oni: not a readable OpenNI2 recording (")
        << "byte " << k;
  }
  for (size_t cut = at + 1; cut < good.size(); ++cut) {
    const std::vector<uint8_t> part(good.begin(), good.begin() + std::ptrdiff_t(cut));
    const std::string e = error_of([&] { check_oni_bytes(part.data(), part.size(), "oni:x.oni"); });
    EXPECT_HAS(e, "oni:x.oni: not a readable OpenNI2 recording (corrupt integrity trailer: ") << "cut " << cut;
    EXPECT_HAS(e, "footer \"DPONIEND\" missing (the trailer is truncated: the file ends " +
                      std::to_string(cut - at) + " bytes after the end record) at byte " + std::to_string(cut) + ")");
  }
  // Cut back to the end record, the file is one without a trailer: it plays, unverified.
  write_file(path, m.bytes);
  EXPECT_EQ(play(path).frames.size(), 3u);
}

TEST(OniIntegrity, InfoSaysWhetherPayloadsAreVerifiedAndNamesAChangedFrame) {
  TempDir t;
  const Made m = make_oni(5, 3, kOniCodec16z, ramp_frames(3, 5, 3));
  const std::vector<uint8_t> good = with_trailer(m);
  auto printed_by_info = [&](const std::string& path) {
    testing::internal::CaptureStdout();
    const int rc = testsupport::run_cli({"info", path});
    const std::string out = testing::internal::GetCapturedStdout();
    EXPECT_EQ(rc, 0) << out;
    return out;
  };
  const std::string trailed = t / "trailed.oni", bare = t / "bare.oni", changed = t / "changed.oni";
  write_file(trailed, good);
  write_file(bare, m.bytes);
  EXPECT_HAS(printed_by_info(trailed), "integrity trailer: every depth payload matches its CRC-32 (3 frames)");
  EXPECT_HAS(printed_by_info(bare), "no integrity trailer (recorded by another tool): payload corruption that still "
                                    "decodes cannot be detected");
  std::vector<uint8_t> b = good;
  b[m.frame_records[2] + 28 + 12 + 3] ^= 0x01;  // a byte of frame 2's second full value
  write_file(changed, b);
  const std::string e = error_of([&] { testsupport::run_cli({"info", changed}); });
  EXPECT_HAS(e, "oni:" + changed + ": frame 2 is corrupt (payload CRC-32 0x");
  EXPECT_HAS(e, "(1 of 3 frames corrupt)");
}

// ---- equality with OpenNI2's player ----

// CRC-32 (zlib) over the 45 frames of models/demo.oni as OpenNI2 2.2's player delivers them
// (320x240 uint16 little endian, frame after frame), computed once through
// open_openni_oni_source; both readers must reproduce it.
constexpr uint32_t kDemoFramesCrc32 = 0xc8edd0e5u;

TEST(OniReader, DemoFramesEqualOpenNi2PlayerFrameForFrame) {
  const std::string demo = "models/demo.oni";
  ASSERT_TRUE(std::filesystem::exists(demo)) << demo << " is missing (make model builds it)";
  // demo.oni carries depthpose's integrity trailer after OpenNI2's end record: OpenNI2's player
  // must still read it frame for frame, and ours checks every payload against it.
  EXPECT_TRUE(check_oni_container(demo).integrity_trailer) << demo << " has no integrity trailer (make model)";
  auto ours = open_oni_source(demo);
  auto theirs = open_openni_oni_source(demo);
  ASSERT_EQ(ours->width(), theirs->width());
  ASSERT_EQ(ours->height(), theirs->height());
  ASSERT_EQ(ours->frame_count(), theirs->frame_count());
  EXPECT_EQ(ours->frame_count(), 45);
  const CameraIntrinsics a = ours->intrinsics(), b = theirs->intrinsics();
  EXPECT_EQ(a.fx, b.fx);
  EXPECT_EQ(a.fy, b.fy);
  EXPECT_EQ(a.cx, b.cx);
  EXPECT_EQ(a.cy, b.cy);
  const size_t pixels = size_t(ours->width()) * size_t(ours->height());
  std::vector<uint16_t> mine(pixels), openni(pixels);
  FrameInfo mi, oi;
  uLong crc_ours = ::crc32(0L, Z_NULL, 0), crc_openni = crc_ours;
  for (int64_t i = 0; i < ours->frame_count(); ++i) {
    ASSERT_EQ(ours->next(mine.data(), &mi), NextStatus::kFrame) << "frame " << i << ": " << ours->last_warning();
    ASSERT_EQ(theirs->next(openni.data(), &oi), NextStatus::kFrame) << "frame " << i;
    EXPECT_EQ(mi.index, oi.index);
    EXPECT_EQ(mi.timestamp_us, oi.timestamp_us) << "frame " << i;
    ASSERT_TRUE(mine == openni) << "frame " << i << " differs from OpenNI2's";
    crc_ours = ::crc32(crc_ours, reinterpret_cast<const Bytef*>(mine.data()), uInt(pixels * 2));
    crc_openni = ::crc32(crc_openni, reinterpret_cast<const Bytef*>(openni.data()), uInt(pixels * 2));
  }
  EXPECT_EQ(ours->next(mine.data(), &mi), NextStatus::kEnd);
  EXPECT_EQ(theirs->next(openni.data(), &oi), NextStatus::kEnd);
  EXPECT_EQ(crc_openni, kDemoFramesCrc32) << std::hex << "OpenNI2's frames: 0x" << crc_openni;
  EXPECT_EQ(crc_ours, kDemoFramesCrc32) << std::hex << "our frames: 0x" << crc_ours;
}

TEST(OniReader, SubsampledSourceKeepsEveryKthPixelAndTheFieldOfView) {
  const std::string demo = "models/demo.oni";
  ASSERT_TRUE(std::filesystem::exists(demo)) << demo << " is missing (make model builds it)";
  auto full = open_oni_source(demo);
  auto small = subsample_source(open_oni_source(demo), 4);
  ASSERT_EQ(small->width(), full->width() / 4);
  ASSERT_EQ(small->height(), full->height() / 4);
  EXPECT_FLOAT_EQ(small->intrinsics().fx, full->intrinsics().fx / 4);
  EXPECT_FLOAT_EQ(small->intrinsics().cy, full->intrinsics().cy / 4);
  std::vector<uint16_t> a(size_t(full->width()) * size_t(full->height())), b(size_t(small->width()) * size_t(small->height()));
  FrameInfo ia, ib;
  for (int round = 0; round < 2; ++round) {
    for (int i = 0; i < 3; ++i) {
      ASSERT_EQ(full->next(a.data(), &ia), NextStatus::kFrame);
      ASSERT_EQ(small->next(b.data(), &ib), NextStatus::kFrame);
      EXPECT_EQ(ia.timestamp_us, ib.timestamp_us);
      for (int y = 0; y < small->height(); ++y)
        for (int x = 0; x < small->width(); ++x)
          ASSERT_EQ(b[size_t(y) * small->width() + x], a[size_t(4 * y) * full->width() + size_t(4 * x)]) << x << "," << y;
    }
    ASSERT_TRUE(full->rewind());
    ASSERT_TRUE(small->rewind());
  }
  EXPECT_EQ(small->stats().frames, 6);
  EXPECT_HAS(error_of([&] { subsample_source(open_oni_source(demo), 17); }), "subsample factor 17 outside 1..16");
  EXPECT_HAS(error_of([&] { subsample_source(open_oni_source(demo), 0); }), "subsample factor 0 outside 1..16");
}
