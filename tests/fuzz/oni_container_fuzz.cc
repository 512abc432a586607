// libFuzzer target: depthpose's .oni reader. Inputs starting with "NI10" go through the container
// walk (platform/oni_container.h) and, when accepted, every indexed depth frame through its codec
// (platform/oni_codec.h) after its integrity-trailer CRC check when the file has one; other inputs go straight to a codec: byte 0 picks NONE/16zP/16zT, bytes
// 1–2 the pixel count (1..4096), the rest is the payload. Anything may be refused (a ToolError or
// a false from the decoder); nothing may crash, read outside the input or write outside the frame.
#include <cstdint>
#include <cstring>
#include <vector>

#include "forest_blob/blob_format.h"
#include "platform/oni_codec.h"
#include "platform/oni_container.h"
#include "tools/common/error.h"

namespace {

// Frames decoded per accepted container, and pixels per frame: keeps one input fast.
constexpr size_t kMaxFramesDecoded = 16;
constexpr size_t kMaxPixelsDecoded = 1 << 20;

void fuzz_container(const uint8_t* data, size_t size) {
  std::vector<dp::platform::OniFrameRecord> frames;
  try {
    const dp::platform::OniContainerSummary s = dp::platform::check_oni_bytes(data, size, "fuzz.oni", &frames);
    if (s.width < 0 || s.width > dp::blob::kMaxFrameDimension || s.height < 0 ||
        s.height > dp::blob::kMaxFrameDimension || s.depth_frames < 1 || size_t(s.depth_frames) != frames.size() ||
        !dp::platform::oni_codec_supported(s.codec))
      __builtin_trap();
    const size_t pixels = size_t(s.width) * size_t(s.height);
    if (pixels == 0 || pixels > kMaxPixelsDecoded) return;
    std::vector<uint16_t> out(pixels);
    dp::platform::OniDecodeProblem problem;
    for (size_t i = 0; i < frames.size() && i < kMaxFramesDecoded; ++i) {
      const dp::platform::OniFrameRecord& f = frames[i];
      if (f.payload_offset > size || f.payload_bytes > size - f.payload_offset) __builtin_trap();
      if (s.integrity_trailer && (s.trailer_offset != s.records_end || s.trailer_offset > size)) __builtin_trap();
      (void)dp::platform::oni_payload_crc_mismatch(data, s, f, i);
      if (!dp::platform::decode_oni_depth(s.codec, data + f.payload_offset, f.payload_bytes, out.data(), pixels, &problem) &&
          problem.offset > f.payload_bytes)
        __builtin_trap();
    }
  } catch (const dp::tools::ToolError&) {
  }
}

void fuzz_codec(const uint8_t* data, size_t size) {
  if (size < 3) return;
  const uint32_t codecs[] = {dp::platform::kOniCodecUncompressed, dp::platform::kOniCodec16z,
                             dp::platform::kOniCodec16zTable};
  const uint32_t codec = codecs[data[0] % 3];
  const size_t pixels = 1 + (size_t(data[1]) | size_t(data[2]) << 8) % 4096;
  // An exact-size copy: ASan sees any read past the payload.
  std::vector<uint8_t> payload(data + 3, data + size);
  std::vector<uint16_t> out(pixels);
  dp::platform::OniDecodeProblem problem;
  if (!dp::platform::decode_oni_depth(codec, payload.data(), payload.size(), out.data(), pixels, &problem) &&
      problem.offset > payload.size())
    __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size >= 4 && std::memcmp(data, "NI10", 4) == 0)
    fuzz_container(data, size);
  else
    fuzz_codec(data, size);
  return 0;
}
