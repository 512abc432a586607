// libFuzzer target: the BVH reader (tools/synth/motion.h, load_bvh) refuses malformed input with a
// ToolError, never crashes or hangs. Written against the public load_bvh(path, stride).
#include <cstdint>

#include "tests/fuzz/fuzz_files.h"
#include "tools/common/error.h"
#include "tools/synth/motion.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  dp::fuzz::MemFile bvh(data, size);
  try {
    const dp::synth::MotionClip clip = dp::synth::load_bvh(bvh.path(), 1);
    for (const auto& frame : clip.frames)
      if (frame.size() != clip.segments.size()) __builtin_trap();
  } catch (const dp::tools::ToolError&) {
  }
  return 0;
}
