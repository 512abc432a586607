// Shared option handling of the app subcommands (run, record).
#pragma once
#include <string>
#include <vector>

#include "platform/frame_source.h"
#include "tools/common/args.h"

namespace dp::tools {

// Options every source-reading subcommand accepts (besides --source).
inline const std::vector<std::string> kSourceOptionNames = {"--intrinsics", "--v4l2-size", "--poll-ms", "--reconnect-ms"};
inline const char* kSourceUsage =
    "  --source SRC         raw:GLOB:WxH | dataset:DIR | oni:FILE | openni[:URI] | v4l2:/dev/videoN\n"
    "  --intrinsics FX,FY,CX,CY  override the camera intrinsics (pixels; default: the source's own,\n"
    "                       Kinect v1 fx=fy=525 cx=319.5 cy=239.5 for raw and v4l2 at 640x480)\n"
    "  --v4l2-size WxH      ask a V4L2 device for this size (default: its current one)\n"
    "  --poll-ms N          live sources: wait at most N ms for a frame (default 500)\n"
    "  --reconnect-ms N     live sources: look for a lost device every N ms (default 500)\n";

platform::SourceOptions source_options_from(const Args& args);
// Whether re-opening the spec gives the same frames again (files), i.e. not a live device.
bool source_is_replayable(const std::string& spec);

}  // namespace dp::tools
