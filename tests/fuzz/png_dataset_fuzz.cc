// libFuzzer target: PNG decoding (tools/common/png_io) and the dataset reader (meta.json +
// frames.jsonl, tools/common/dataset) refuse malformed input with a ToolError, never crash or
// allocate for sizes a header merely declares. Input: PNG bytes, or (when it holds the separator)
// meta.json, separator, frames.jsonl.
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "tests/fuzz/fuzz_files.h"
#include "tools/common/dataset.h"
#include "tools/common/error.h"
#include "tools/common/png_io.h"

namespace {
const char kSeparator[] = "\n--frames.jsonl--\n";

// A scratch dataset directory for this process (meta.json and frames.jsonl rewritten per input).
const std::string& scratch() {
  static const std::string dir = [] {
    std::string d = "/dev/shm/dp-fuzz-dataset-" + std::to_string(::getpid());
    std::filesystem::create_directories(d);
    std::atexit([] { std::filesystem::remove_all("/dev/shm/dp-fuzz-dataset-" + std::to_string(::getpid())); });
    return d;
  }();
  return dir;
}

void write(const std::string& path, const uint8_t* data, size_t size) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) __builtin_trap();
  if (size) std::fwrite(data, 1, size, f);
  std::fclose(f);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const size_t cut = dp::fuzz::split_at(data, size, kSeparator, sizeof kSeparator - 1);
  try {
    if (cut == size) {
      dp::fuzz::MemFile png(data, size);
      const dp::tools::ImageU16 a = dp::tools::read_png_u16(png.path());
      if (a.pixels.size() != size_t(a.width) * size_t(a.height)) __builtin_trap();
      const dp::tools::ImageU8 b = dp::tools::read_png_u8(png.path());
      if (b.pixels.size() != size_t(b.width) * size_t(b.height)) __builtin_trap();
    } else {
      write(scratch() + "/meta.json", data, cut);
      const size_t rest = cut + sizeof kSeparator - 1;
      write(scratch() + "/frames.jsonl", data + rest, size - rest);
      const dp::tools::Dataset ds = dp::tools::open_dataset(scratch());
      for (const dp::tools::FrameRecord& r : ds.frames)
        if (!r.joints.empty() && r.joints.size() != ds.meta.joints.size()) __builtin_trap();
    }
  } catch (const dp::tools::ToolError&) {
  }
  return 0;
}
