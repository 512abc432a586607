// libFuzzer target: the .oni container check (platform/oni_container.h) refuses or accepts any
// byte string with a ToolError at most, and what it accepts has a sane depth resolution.
#include <cstdint>

#include "forest_blob/blob_format.h"
#include "platform/oni_container.h"
#include "tools/common/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const dp::platform::OniContainerSummary s = dp::platform::check_oni_bytes(data, size, "fuzz.oni");
    if (s.width < 0 || s.width > dp::blob::kMaxFrameDimension || s.height < 0 ||
        s.height > dp::blob::kMaxFrameDimension || s.depth_frames < 1)
      __builtin_trap();
  } catch (const dp::tools::ToolError&) {
  }
  return 0;
}
