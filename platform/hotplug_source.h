// USB hotplug around a live source: when the watched camera leaves the bus the inner source is
// closed and next() returns kDeviceLost (stats().device_lost counts the event once); while it is
// away next() keeps returning kDeviceLost (sleeping away_sleep_ms per call instead of spinning);
// when the same camera (same port and id) is back, the source is reopened and frames resume
// (stats().reconnects). A reopened source must have the same frame size, else kError.
// The inner source's own kDeviceLost/kNoFrame are returned unchanged.
#pragma once
#include <functional>
#include <memory>

#include "platform/frame_source.h"
#include "platform/usb_devices.h"

namespace dp::platform {

struct HotplugOptions {
  int poll_interval_ms = 250;  // how often the bus is listed while the camera is present
  int away_sleep_ms = 50;      // next() sleep while the camera is away
};

using SourceOpener = std::function<std::unique_ptr<FrameSource>()>;

// `first` is the already-open source; `camera` the USB device it reads (must be attached now).
std::unique_ptr<FrameSource> watch_hotplug(std::unique_ptr<FrameSource> first, SourceOpener reopen,
                                           std::unique_ptr<UsbLister> lister, const UsbDevice& camera,
                                           const HotplugOptions& options = {});

}  // namespace dp::platform
