// Depth frame codecs of OpenNI .oni recordings, decoded by depthpose itself (no OpenNI2 code).
//
// A codec is named by a FourCC stored little endian in the node-added record:
//   "NONE"  uncompressed: width·height little-endian uint16 values, nothing else
//   "16zP"  16z: a delta code over the row-major uint16 values (below)
//   "16zT"  16z with an embedded table: u16 entry count N, N u16 values (ascending, the distinct
//           depths of the frame), then a 16z stream of indices into that table; the frame is
//           table[index] per pixel. What OpenNI2 2.2's recorder writes for depth (models/demo.oni).
// The 16z stream (format facts of OpenNI's XnStreamCompression, re-implemented here):
//   u16 first value (little endian); then codes, each updating a running uint16 value v
//   (arithmetic modulo 2^16) and emitting it:
//     byte 0x00..0xDF   two nibbles h, l. h ∈ 0..12: v −= h − 6, emit. Then l ∈ 0..12: v −= l − 6,
//                       emit; l = 13: nothing (padding of an odd half byte); l = 15: an escape
//                       follows in the next byte(s); l = 14 and h = 13 are never written.
//     byte 0xE1..0xEF   repeat: emit v 2·(byte − 0xE0) times (0xE0 and 0xF0..0xFE are never written)
//     byte 0xFF         an escape follows
//   escape: byte c ≥ 0x80: v −= c − 192, emit; else v = (c << 8) | next byte, emit.
// Every code must lie inside the payload, the frame must decode to exactly width·height values,
// and (16zT) every index must lie inside the table and the table inside the payload: anything
// else is refused with the payload byte and the field at fault. Values are never checked: any
// uint16 is a valid depth.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

namespace dp::platform {

constexpr uint32_t oni_fourcc(char a, char b, char c, char d) {
  return uint32_t(uint8_t(a)) | uint32_t(uint8_t(b)) << 8 | uint32_t(uint8_t(c)) << 16 | uint32_t(uint8_t(d)) << 24;
}
constexpr uint32_t kOniCodecUncompressed = oni_fourcc('N', 'O', 'N', 'E');
constexpr uint32_t kOniCodec16z = oni_fourcc('1', '6', 'z', 'P');
constexpr uint32_t kOniCodec16zTable = oni_fourcc('1', '6', 'z', 'T');

// True for the three codecs above.
bool oni_codec_supported(uint32_t codec);
// The FourCC as text ("16zT"), non-printable bytes as \xNN, for messages.
std::string oni_codec_name(uint32_t codec);

// The largest payload a frame of `pixels` pixels can take in `codec`: 16z writes at most 3 bytes
// per value (0xFF, then a full value), 16zT adds its table (≤ 65536 entries); NONE is exact.
uint64_t max_oni_payload_bytes(uint32_t codec, uint64_t pixels);

// Why a payload was refused: `offset` is the payload byte at fault (0-based, from the payload's
// first byte), `field` a static description ("escape byte", "table index" ...).
struct OniDecodeProblem {
  size_t offset = 0;
  const char* field = "";
  uint64_t value = 0;     // the offending value (index, pixel count ...), for the message
  uint64_t expected = 0;  // the bound it broke
};

// Decodes one frame of `codec` from payload[0, bytes) into out[0, pixels). Allocates nothing,
// never reads outside the payload, never writes outside `out`. Returns false and fills `problem`
// when the payload is corrupt, truncated, decodes to a pixel count other than `pixels`, or the
// codec is unsupported; `out` then holds an unspecified partial frame.
bool decode_oni_depth(uint32_t codec, const uint8_t* payload, size_t bytes, uint16_t* out, size_t pixels,
                      OniDecodeProblem* problem);

// "<field> at byte N (V against E)" (or "(value V)" without a bound) for messages, N = payload_offset + problem.offset (the
// payload's first byte in the file, or 0 for payload-relative bytes).
std::string describe(const OniDecodeProblem& problem, uint64_t payload_offset);

}  // namespace dp::platform
