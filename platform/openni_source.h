// OpenNI2 sources (.oni replay, devices) and the feed that serves frames through depthpose's own
// OpenNI2 driver (platform/openni_driver/).
//
// OpenNI2 (Debian 2.2.0.33) loads its drivers only from <dir of libOpenNI2.so.0>/OpenNI2/Drivers/.
// The build links the CLI and tests with rpath $ORIGIN/../openni, so that directory is
// build/openni/ (mk/openni.mk): libOniFile (replay) and libdepthpose_feed (ours). Real cameras need
// their driver there too (`make openni-devices` links Debian's PS1080/PSLink; docs/app.md says how
// to add the freenect driver for a Kinect v1).
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "platform/frame_source.h"

namespace dp::platform {

// Initializes OpenNI2 once per process; throws ToolError with OpenNI2's own message on failure.
void ensure_openni();
// Directory libOpenNI2.so.0 was loaded from (where OpenNI2 looks for OpenNI2/Drivers/).
std::string openni_library_dir();

// An .oni recording played by OpenNI2's file driver (libOniFile): every frame once, in order, as
// fast as it can be read (setSpeed(-1), no repeat; frame count from the file; never seeks). `oni:`
// sources use depthpose's own reader (platform/oni_file_source.h); this one remains for `record`,
// which checks that OpenNI2 reads what it wrote, and for the tests comparing the two readers. Its
// player thread grows by ≈ 19 bytes a frame (docs/app.md, Soak). Throws ToolError for a missing, corrupt or depth-less
// file. A recording that ends early (truncated) makes next() return kError naming the frame.
// With `repeat`, OpenNI2 plays the file in a loop: next() returns kEnd at the end of every
// play-through and rewind() continues with the next one (no seek, no reopen).
std::unique_ptr<FrameSource> open_openni_oni_source(const std::string& path, bool repeat = false);

// openni / openni:URI — a device (first one when `uri` is empty). Live: next() waits up to
// options.poll_timeout_ms. A disconnect (OpenNI2 event or read failure) returns kDeviceLost once
// the device is closed; later calls reopen the URI every options.reconnect_interval_ms and resume
// (the device must come back with the same resolution, else kError).
std::unique_ptr<FrameSource> open_openni_device_source(const std::string& uri, const SourceOptions& options);

// Serves frames to OpenNI2 as the device DP_FEED_URI_PREFIX + name through libdepthpose_feed.
// While it exists, OpenNI2 can open uri() like a camera; its stream calls `next` on the driver's
// thread. Only one Feed may exist at a time (the driver holds one).
class Feed {
 public:
  // Returns a DpFeedResult (platform/openni_driver/feed_abi.h): 1 frame, 0 again, −1 end, −2 lost.
  using NextFn = std::function<int(uint16_t* depth, uint64_t* timestamp_us)>;
  using PresentFn = std::function<bool()>;
  // Throws ToolError when the driver is not loaded (build/openni missing) or already busy.
  Feed(const std::string& name, int width, int height, int fps, const CameraIntrinsics& intrinsics,
       NextFn next, PresentFn present = {});
  ~Feed();
  Feed(const Feed&) = delete;
  Feed& operator=(const Feed&) = delete;

  std::string uri() const;
  int64_t frames_served() const;  // frames the driver raised to OpenNI2
  bool idle() const;              // the driver thread has ended (end/lost/stop)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dp::platform
