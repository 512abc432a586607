// libFuzzer target: the Acclaim ASF/AMC reader (tools/synth/motion.h, load_asf_amc) refuses
// malformed input with a ToolError, never crashes or hangs. Input: ASF text, separator, AMC text.
#include <cstdint>

#include "tests/fuzz/fuzz_files.h"
#include "tools/common/error.h"
#include "tools/synth/motion.h"

namespace {
const char kSeparator[] = "\n--amc--\n";
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const size_t cut = dp::fuzz::split_at(data, size, kSeparator, sizeof kSeparator - 1);
  const size_t rest = cut == size ? size : cut + sizeof kSeparator - 1;
  dp::fuzz::MemFile asf(data, cut);
  dp::fuzz::MemFile amc(data + rest, size - rest);
  try {
    const dp::synth::MotionClip clip = dp::synth::load_asf_amc(asf.path(), amc.path(), 1);
    for (const auto& frame : clip.frames)
      if (frame.size() != clip.segments.size()) __builtin_trap();
  } catch (const dp::tools::ToolError&) {
  }
  return 0;
}
