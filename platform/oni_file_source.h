// oni:FILE — depthpose's own .oni player: the container is checked and indexed once at open
// (platform/oni_container.h), then each next() decodes one depth frame straight from the mapped
// file into the caller's buffer (platform/oni_codec.h). No OpenNI2 code and no thread: nothing
// is allocated after open, so a looped soak stays flat.
#pragma once
#include <memory>
#include <string>

#include "platform/frame_source.h"

namespace dp::platform {

// Opens `path` (throws ToolError "oni:<path>: ..." naming the byte and field for a missing,
// truncated or corrupt recording, one without a depth stream or resolution, or with an
// unsupported codec or pixel format). The source delivers every depth frame once, in file order,
// as fast as it is asked; rewind() starts again at the first frame (always possible). A frame
// whose payload does not decode to width × height pixels is skipped (stats().corrupt_frames) with
// a warning naming the file, the frame, the file byte and the field; so is, in a recording with
// depthpose's integrity trailer (platform/oni_container.h), a frame whose stored payload no
// longer has the CRC-32 the trailer records (the warning names the frame, the trailer entry's
// byte and the payload's byte range). Depth in 100 µm units is
// converted to millimetres ((v + 5) / 10). Intrinsics come from the depth node's field of view
// (xnFOV), else the Kinect v1 defaults. frame_count() is the number of depth frames in the file.
std::unique_ptr<FrameSource> open_oni_source(const std::string& path);

}  // namespace dp::platform
