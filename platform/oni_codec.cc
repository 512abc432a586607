#include "platform/oni_codec.h"

#include <cstring>

namespace dp::platform {

namespace {

uint16_t load_u16(const uint8_t* p) { return uint16_t(p[0] | p[1] << 8); }

bool refuse(OniDecodeProblem* problem, size_t offset, const char* field, uint64_t value = 0, uint64_t expected = 0) {
  *problem = OniDecodeProblem{offset, field, value, expected};
  return false;
}

// 16z stream in in[begin, end) → out[0, pixels), each running value handed to `lookup(v, at,
// &pixel)` (identity for 16zP, table lookup for 16zT; `at` is the code's payload byte for
// messages), which returns false (problem filled) for a value it cannot map.
template <typename Lookup>
bool decode_16z(const uint8_t* in, size_t begin, size_t end, uint16_t* out, size_t pixels, Lookup lookup,
                OniDecodeProblem* problem) {
  if (end - begin < 2) return refuse(problem, begin, "first value beyond the payload");
  uint16_t v = load_u16(in + begin);
  size_t written = 0;
  // Writes v (mapped) once; false when the frame is already full or v does not map.
  auto emit = [&](size_t at) -> bool {
    if (written == pixels) return refuse(problem, at, "more pixels than the frame holds", written + 1, pixels);
    if (!lookup(v, at, &out[written])) return false;
    ++written;
    return true;
  };
  if (!emit(begin)) return false;
  size_t p = begin + 2;
  // An escape at `at` (the byte after the 0x?F or 0xFF code): a 7-bit delta or a 15-bit value.
  auto escape = [&](size_t at) -> bool {
    if (at >= end) return refuse(problem, at, "escape byte beyond the payload");
    const uint8_t c = in[at];
    if (c & 0x80) {
      v = uint16_t(v - (int(c) - 192));
      p = at + 1;
    } else {
      if (at + 1 >= end) return refuse(problem, at, "second byte of a full value beyond the payload");
      v = uint16_t(c << 8 | in[at + 1]);
      p = at + 2;
    }
    return emit(at);
  };
  while (p < end) {
    const uint8_t b = in[p];
    if (b < 0xE0) {
      const int high = b >> 4, low = b & 0x0F;
      if (high > 12) return refuse(problem, p, "delta code (high nibble 13 is never written)", b);
      v = uint16_t(v - (high - 6));
      if (!emit(p)) return false;
      if (low == 0x0F) {
        if (!escape(p + 1)) return false;
      } else if (low == 0x0D) {
        ++p;
      } else if (low == 0x0E) {
        return refuse(problem, p, "delta code (low nibble 14 is never written)", b);
      } else {
        v = uint16_t(v - (low - 6));
        if (!emit(p)) return false;
        ++p;
      }
    } else if (b == 0xFF) {
      if (!escape(p + 1)) return false;
    } else {
      if (b == 0xE0 || b > 0xEF) return refuse(problem, p, "repeat code (0xE1..0xEF)", b);
      const size_t copies = size_t(b - 0xE0) * 2;
      for (size_t k = 0; k < copies; ++k)
        if (!emit(p)) return false;
      ++p;
    }
  }
  if (written != pixels) return refuse(problem, end, "pixel count (frame ends early)", written, pixels);
  return true;
}

}  // namespace

bool oni_codec_supported(uint32_t codec) {
  return codec == kOniCodecUncompressed || codec == kOniCodec16z || codec == kOniCodec16zTable;
}

uint64_t max_oni_payload_bytes(uint32_t codec, uint64_t pixels) {
  const uint64_t stream = 2 + 3 * (pixels ? pixels - 1 : 0);
  if (codec == kOniCodecUncompressed) return pixels * 2;
  if (codec == kOniCodec16z) return stream;
  return 2 + 2 * 65536 + stream;  // 16zT, and the bound for a codec not known yet
}

std::string oni_codec_name(uint32_t codec) {
  std::string s;
  for (int k = 0; k < 4; ++k) {
    const uint8_t c = uint8_t(codec >> (8 * k));
    if (c >= 0x20 && c <= 0x7E) {
      s += char(c);
    } else {
      static const char* hex = "0123456789abcdef";
      s += "\\x";
      s += hex[c >> 4];
      s += hex[c & 15];
    }
  }
  return s;
}

bool decode_oni_depth(uint32_t codec, const uint8_t* payload, size_t bytes, uint16_t* out, size_t pixels,
                      OniDecodeProblem* problem) {
  if (pixels == 0) return refuse(problem, 0, "frame of 0 pixels");
  if (codec == kOniCodecUncompressed) {
    if (bytes != pixels * 2) return refuse(problem, 0, "uncompressed frame size in bytes", bytes, pixels * 2);
    std::memcpy(out, payload, bytes);  // little endian, as is every host we build for
    return true;
  }
  if (codec == kOniCodec16z) {
    return decode_16z(payload, 0, bytes, out, pixels, [](uint16_t v, size_t, uint16_t* o) { *o = v; return true; }, problem);
  }
  if (codec == kOniCodec16zTable) {
    if (bytes < 2) return refuse(problem, 0, "table size beyond the payload");
    const size_t entries = load_u16(payload);
    if (entries == 0) return refuse(problem, 0, "table size (0 entries)");
    if (bytes - 2 < entries * 2) return refuse(problem, 0, "table beyond the payload", entries * 2, bytes - 2);
    const uint8_t* table = payload + 2;
    return decode_16z(
        payload, 2 + entries * 2, bytes, out, pixels,
        [&](uint16_t index, size_t at, uint16_t* o) {
          if (index >= entries) return refuse(problem, at, "table index", index, entries);
          *o = load_u16(table + size_t(index) * 2);
          return true;
        },
        problem);
  }
  return refuse(problem, 0, "codec (NONE, 16zP or 16zT)", codec);
}

std::string describe(const OniDecodeProblem& problem, uint64_t payload_offset) {
  std::string s = std::string(problem.field) + " at byte " + std::to_string(payload_offset + problem.offset);
  if (problem.expected)
    s += " (" + std::to_string(problem.value) + " against " + std::to_string(problem.expected) + ")";
  else if (problem.value)
    s += " (value " + std::to_string(problem.value) + ")";
  return s;
}

}  // namespace dp::platform
