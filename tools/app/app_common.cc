#include "tools/app/app_common.h"

#include "tools/common/dataset.h"
#include "tools/common/error.h"

namespace dp::tools {

platform::SourceOptions source_options_from(const Args& args) {
  platform::SourceOptions o;
  if (args.has("--intrinsics")) {
    std::vector<std::string> parts = split_list(args.get("--intrinsics"));
    if (parts.size() != 4) fail("--intrinsics wants FX,FY,CX,CY, got '" + args.get("--intrinsics") + "'");
    float v[4];
    for (int i = 0; i < 4; ++i) {
      char* end = nullptr;
      v[i] = std::strtof(parts[size_t(i)].c_str(), &end);
      if (*end) fail("--intrinsics: '" + parts[size_t(i)] + "' is not a number");
    }
    check_intrinsics(v[0], v[1], v[2], v[3], "--intrinsics");  // finite, within tools/common/limits.h
    o.has_intrinsics = true;
    o.intrinsics = CameraIntrinsics{v[0], v[1], v[2], v[3]};
  }
  if (args.has("--v4l2-size")) platform::parse_size(args.get("--v4l2-size"), "--v4l2-size", &o.v4l2_width, &o.v4l2_height);
  o.poll_timeout_ms = int(args.get_int("--poll-ms", o.poll_timeout_ms));
  o.reconnect_interval_ms = int(args.get_int("--reconnect-ms", o.reconnect_interval_ms));
  if (o.poll_timeout_ms < 1 || o.reconnect_interval_ms < 1) fail("--poll-ms and --reconnect-ms must be positive");
  return o;
}

bool source_is_replayable(const std::string& spec) {
  return spec.rfind("raw:", 0) == 0 || spec.rfind("dataset:", 0) == 0 || spec.rfind("oni:", 0) == 0;
}

}  // namespace dp::tools
