// libFuzzer target: the trained-forest (.forest) parser refuses or accepts any byte string with a
// ToolError at most: never a crash, a hang or an allocation beyond what the bytes justify.
#include <cstdint>

#include "tools/common/error.h"
#include "tools/train/forest_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    dp::train::parse_forest(data, size, "fuzz.forest");
  } catch (const dp::tools::ToolError&) {
  }
  return 0;
}
