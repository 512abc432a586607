// Frame-source throughput: raw files, .oni replay through OpenNI2, and recording through our
// OpenNI2 driver (record + pixel-for-pixel verification). 120 frames built from the 12 Skeltrack
// frames (640x480) in a temporary directory.
#include <stdlib.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "platform/frame_source.h"
#include "platform/oni_recorder.h"

using namespace dp::platform;
using Clock = std::chrono::steady_clock;

static double drain(FrameSource& s, int64_t* frames) {
  std::vector<uint16_t> depth(size_t(s.width()) * s.height());
  FrameInfo info;
  const auto t0 = Clock::now();
  *frames = 0;
  while (s.next(depth.data(), &info) == NextStatus::kFrame) ++*frames;
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

int main() {
  char pattern[] = "/tmp/depthpose_bench_XXXXXX";
  if (!mkdtemp(pattern)) return 1;
  const std::string dir = pattern;
  std::vector<std::string> inputs;
  for (const auto& e : std::filesystem::directory_iterator("../shared/data/skeltrack-frames")) inputs.push_back(e.path());
  if (inputs.size() != 12) {
    std::fprintf(stderr, "app_sources_bench: needs the 12 frames in ../shared/data/skeltrack-frames\n");
    return 1;
  }
  std::sort(inputs.begin(), inputs.end());
  for (int i = 0; i < 120; ++i) {
    char name[64];
    std::snprintf(name, sizeof name, "/f%03d.raw", i);
    std::filesystem::copy_file(inputs[size_t(i) % 12], dir + name);
  }
  const std::string spec = "raw:" + dir + "/f*.raw:640x480";
  int64_t n = 0;
  auto raw = open_source(spec);
  double t = drain(*raw, &n);
  std::printf("raw 640x480 read:         %5lld frames in %.3f s = %7.0f frames/s\n", (long long)n, t, double(n) / t);

  const auto r0 = Clock::now();
  RecordReport rep = record_oni([&] { return open_source(spec); }, true, dir + "/x.oni", RecordOptions{});
  const double tr = std::chrono::duration<double>(Clock::now() - r0).count();
  std::printf("record + verify (.oni):   %5lld frames in %.3f s = %7.0f frames/s (attempts %d, file %lld bytes)\n",
              (long long)rep.frames_recorded, tr, double(rep.frames_recorded) / tr, rep.attempts,
              (long long)std::filesystem::file_size(dir + "/x.oni"));

  auto oni = open_source("oni:" + dir + "/x.oni");
  t = drain(*oni, &n);
  std::printf(".oni replay (OpenNI2):    %5lld frames in %.3f s = %7.0f frames/s\n", (long long)n, t, double(n) / t);
  oni.reset();
  std::filesystem::remove_all(dir);
  return 0;
}
