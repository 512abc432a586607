// Lets `depthpose info` describe OpenNI2 recordings (tools/info/info.h describer hook).
#include <cstdio>
#include <cstring>

#include "platform/openni_source.h"
#include "tools/info/info.h"

namespace dp::tools {
namespace {

bool describe_oni_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  if (bytes.size() < 4 || std::memcmp(bytes.data(), "NI10", 4) != 0) return false;
  auto source = platform::open_oni_source(path);  // throws ToolError when unreadable
  const CameraIntrinsics k = source->intrinsics();
  std::printf("%s: OpenNI2 recording, %lld depth frames of %dx%d, fx %.2f fy %.2f cx %.2f cy %.2f (from its field of view)\n",
              path.c_str(), (long long)source->frame_count(), source->width(), source->height(), k.fx, k.fy, k.cx, k.cy);
  return true;
}

const InfoDescriberRegistrar registrar(describe_oni_file);

}  // namespace
}  // namespace dp::tools
