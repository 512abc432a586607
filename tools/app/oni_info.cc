// Lets `depthpose info` describe .oni recordings (tools/info/info.h describer hook): the container
// is checked and every depth frame decoded by depthpose's reader, so a corrupt frame is an error
// naming its byte, not a silent success; in a recording with depthpose's integrity trailer each
// payload is also checked against its CRC-32 (platform/oni_container.h).
#include <cstdio>
#include <cstring>

#include "platform/oni_codec.h"
#include "platform/oni_container.h"
#include "platform/oni_file_source.h"
#include "tools/common/error.h"
#include "tools/info/info.h"

namespace dp::tools {
namespace {

bool describe_oni_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  if (bytes.size() < 4 || std::memcmp(bytes.data(), "NI10", 4) != 0) return false;
  const platform::OniContainerSummary c = platform::check_oni_bytes(bytes.data(), bytes.size(), "oni:" + path);
  auto source = platform::open_oni_source(path);  // throws ToolError when unreadable
  std::vector<uint16_t> depth(size_t(source->width()) * size_t(source->height()));
  platform::FrameInfo info;
  while (source->next(depth.data(), &info) == platform::NextStatus::kFrame) {
  }
  if (source->stats().corrupt_frames)
    fail(source->last_warning() + " (" + std::to_string(source->stats().corrupt_frames) + " of " +
         std::to_string(source->frame_count()) + " frames corrupt)");
  const CameraIntrinsics k = source->intrinsics();
  std::printf("%s: OpenNI recording, %lld depth frames of %dx%d (%s, %s), every frame decoded; fx %.2f fy %.2f "
              "cx %.2f cy %.2f (%s)\n",
              path.c_str(), (long long)source->frame_count(), source->width(), source->height(),
              platform::oni_codec_name(c.codec).c_str(),
              c.pixel_format == platform::kOniPixelFormatDepth100um ? "100 µm" : "1 mm", k.fx, k.fy, k.cx, k.cy,
              c.has_fov ? "from its field of view" : "Kinect v1 defaults: no field of view recorded");
  if (c.integrity_trailer)
    std::printf("  integrity trailer: every depth payload matches its CRC-32 (%lld frames)\n",
                (long long)c.depth_frames);
  else
    std::printf("  no integrity trailer (recorded by another tool): payload corruption that still decodes cannot be "
                "detected\n");
  return true;
}

const InfoDescriberRegistrar registrar(describe_oni_file);

}  // namespace
}  // namespace dp::tools
