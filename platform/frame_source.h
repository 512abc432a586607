// Depth frame sources for the app: files, datasets, .oni recordings, OpenNI2 devices, V4L2.
//
// Contract:
//   - open_source(spec) parses a source spec, opens the source and checks it (geometry, pixel
//     format, presence of the device). Every problem throws dp::tools::ToolError with one line
//     naming the problem and the file/device. After a successful open, width()/height() and
//     intrinsics() are fixed for the source's lifetime.
//   - next() fills a caller-owned buffer of width()·height() uint16 millimetres (row-major, no
//     padding, 0 = no reading) and never throws. It returns:
//       kFrame       a frame was written; `info` describes it
//       kEnd         the stream is over (files: after the last frame); every later call says kEnd
//       kNoFrame     live sources: nothing arrived within the poll timeout (try again)
//       kDeviceLost  live sources: the device went away; later calls try to reconnect and return
//                    kDeviceLost (still away) or kFrame (back). The frame buffer is untouched.
//       kError       unrecoverable; last_error() says why; later calls say kError
//   - Corrupt frames (unreadable PNG, raw file of the wrong size, short V4L2 buffer) are skipped
//     and counted in stats().corrupt_frames; next() moves on to the following frame.
//   - Not thread safe: one thread calls next().
//
// Specs:
//   raw:GLOB:WxH        uint16 little-endian millimetre files, sorted by name (e.g.
//                       ../shared/data/skeltrack-frames/*.raw:640x480)
//   dataset:DIR         dataset layout v1 (tools/common/dataset.h), depth/NNNNNN.png in order
//   oni:FILE            OpenNI .oni recording, each frame once, as fast as it can be read, by
//                       depthpose's own reader (platform/oni_file_source.h)
//   openni              first OpenNI2 device;  openni:URI  a given device URI
//   v4l2:/dev/videoN    V4L2 depth capture (mmap streaming, Z16 preferred, Y16 accepted)
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "runtime/depthpose.h"

namespace dp::platform {

enum class NextStatus { kFrame, kEnd, kNoFrame, kDeviceLost, kError };
const char* next_status_name(NextStatus status);

struct FrameInfo {
  int64_t index = 0;          // 0-based position in the source's stream (skipped frames count)
  uint64_t timestamp_us = 0;  // source clock; files without one: index · frame period
};

struct SourceStats {
  int64_t frames = 0;          // frames delivered by next()
  int64_t corrupt_frames = 0;  // skipped because unreadable / wrong size
  int64_t dropped_frames = 0;  // live sources: frames the device produced that we never read
  int64_t device_lost = 0;     // times the device went away
  int64_t reconnects = 0;      // times it came back
};

// Kinect v1 depth camera defaults (fx = fy = 525, principal point at the image centre).
CameraIntrinsics kinect_v1_intrinsics(int width, int height);
// Pinhole intrinsics from a field of view in radians (principal point at the image centre); the
// Kinect v1 defaults when either angle is outside 0.01..3.1.
CameraIntrinsics intrinsics_from_fov(int width, int height, float horizontal_fov, float vertical_fov);

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual int width() const = 0;
  virtual int height() const = 0;
  virtual CameraIntrinsics intrinsics() const = 0;
  virtual bool live() const { return false; }
  // Frame count when known in advance (files), else −1.
  virtual int64_t frame_count() const { return -1; }
  // See the contract above. `depth_mm` holds width()·height() elements.
  virtual NextStatus next(uint16_t* depth_mm, FrameInfo* info) = 0;
  // Starts again at the first frame, allocating nothing (raw, dataset and oni: sources); the stats
  // keep counting. False when the source cannot: live sources, OpenNI2's own .oni player
  // (open_openni_oni_source) without repeat (OpenNI2 2.2's PlaybackControl::seek crashes).
  virtual bool rewind() { return false; }
  const std::string& last_error() const { return error_; }
  // Last non-fatal problem (a skipped corrupt frame, a lost device), for logs. Empty if none.
  const std::string& last_warning() const { return warning_; }
  const SourceStats& stats() const { return stats_; }
  // Overrides the intrinsics the source reports (e.g. a user-calibrated camera).
  void set_intrinsics_override(const CameraIntrinsics& k) { override_ = k; has_override_ = true; }

 protected:
  CameraIntrinsics resolve(const CameraIntrinsics& own) const { return has_override_ ? override_ : own; }
  std::string error_, warning_;
  SourceStats stats_;

 private:
  CameraIntrinsics override_{};
  bool has_override_ = false;
};

// A file source whose frames are read by index (raw files, datasets, .oni recordings): next()
// walks 0..frame_count()−1 in order, skipping and counting the frames read_frame() refuses
// (stats().corrupt_frames, last_warning() = its reason); rewind() starts again at 0, allocating
// nothing.
class IndexedFileSource : public FrameSource {
 public:
  int64_t frame_count() const override { return int64_t(count_); }
  NextStatus next(uint16_t* depth_mm, FrameInfo* info) final;
  bool rewind() final {
    position_ = 0;
    return true;
  }

 protected:
  explicit IndexedFileSource(size_t count) : count_(count) {}
  // Writes frame `index` (width()·height() pixels) and its timestamp; false with `why` (a one-line
  // warning ending in "frame skipped") for a frame that cannot be read.
  virtual bool read_frame(size_t index, uint16_t* depth_mm, uint64_t* timestamp_us, std::string* why) = 0;

 private:
  size_t count_;
  size_t position_ = 0;
};

struct SourceOptions {
  bool has_intrinsics = false;
  CameraIntrinsics intrinsics{};  // used when has_intrinsics
  int poll_timeout_ms = 500;      // live sources: how long next() waits before kNoFrame
  int reconnect_interval_ms = 500;// live sources: how often a lost device is looked for
  // V4L2: requested size (0 = keep the device's current one).
  int v4l2_width = 0, v4l2_height = 0;
  // Live sources: hand over only the newest frame, counting older queued ones as dropped
  // (`run --realtime`). OpenNI2 streams always do; V4L2 otherwise delivers its queue in order.
  bool latest_only = false;
};

// Opens a source from its spec (see above). Throws ToolError naming the problem.
std::unique_ptr<FrameSource> open_source(const std::string& spec, const SourceOptions& options = {});

// The individual sources, for tests and tools that already parsed the spec.
std::unique_ptr<FrameSource> open_raw_source(const std::string& glob_pattern, int width, int height);
std::unique_ptr<FrameSource> open_dataset_source(const std::string& dir);

// Every `factor`-th pixel of every `factor`-th row of `inner`'s frames (pixel (x, y) of a frame is
// inner's (factor·x, factor·y)): a floor(W/factor) × floor(H/factor) source with the intrinsics
// scaled by 1/factor (the same field of view), for small recordings (`record --subsample`, soak
// runs). Statuses, stats, warnings and rewind() are inner's. Throws ToolError when factor is
// outside 1..kMaxSubsample or leaves less than one pixel per side.
constexpr int kMaxSubsample = 16;
std::unique_ptr<FrameSource> subsample_source(std::unique_ptr<FrameSource> inner, int factor);

// Parses "WxH" (e.g. "640x480"); throws ToolError naming `what` on malformed text.
void parse_size(const std::string& text, const std::string& what, int* width, int* height);

}  // namespace dp::platform
