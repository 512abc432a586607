#include "platform/openni_source.h"

#include <OpenNI.h>
#include <dlfcn.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <thread>

#include "platform/oni_container.h"
#include "platform/openni_driver/feed_abi.h"
#include "tools/common/error.h"

namespace dp::platform {

using tools::fail;

namespace {

std::string extended_error() {
  const char* e = openni::OpenNI::getExtendedError();
  std::string s = e ? e : "";
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (char& c : s)
    if (c == '\n' || c == '\t') c = ' ';
  while (!s.empty() && s.front() == ' ') s.erase(s.begin());
  return s.empty() ? "no detail from OpenNI2" : s;
}

// Copies one OpenNI2 depth frame into the caller's buffer. False when its geometry or format
// does not match the stream's (a corrupt frame).
bool copy_depth(const openni::VideoFrameRef& frame, int width, int height, uint16_t* out) {
  if (!frame.isValid() || frame.getWidth() != width || frame.getHeight() != height) return false;
  const auto format = frame.getVideoMode().getPixelFormat();
  const int stride = frame.getStrideInBytes();
  if (stride < width * 2 || frame.getDataSize() < stride * (height - 1) + width * 2) return false;
  const auto* base = static_cast<const uint8_t*>(frame.getData());
  for (int y = 0; y < height; ++y) {
    const auto* row = reinterpret_cast<const uint16_t*>(base + size_t(y) * stride);
    uint16_t* dst = out + size_t(y) * width;
    if (format == openni::PIXEL_FORMAT_DEPTH_100_UM) {
      for (int x = 0; x < width; ++x) dst[x] = uint16_t((row[x] + 5) / 10);
    } else {
      std::memcpy(dst, row, size_t(width) * 2);
    }
  }
  return true;
}

void check_depth_mode(const openni::VideoMode& mode, const std::string& what) {
  const auto format = mode.getPixelFormat();
  if (format != openni::PIXEL_FORMAT_DEPTH_1_MM && format != openni::PIXEL_FORMAT_DEPTH_100_UM)
    fail(what + ": depth pixel format " + std::to_string(int(format)) +
         " is not millimetres or 100 µm (raw shift formats are not supported)");
  if (mode.getResolutionX() < 1 || mode.getResolutionY() < 1 ||
      mode.getResolutionX() > blob::kMaxFrameDimension || mode.getResolutionY() > blob::kMaxFrameDimension)
    fail(what + ": bad depth resolution " + std::to_string(mode.getResolutionX()) + "x" +
         std::to_string(mode.getResolutionY()));
}

class OniSource final : public FrameSource {
 public:
  OniSource(const std::string& path, bool repeat) : path_(path), repeat_(repeat) {
    if (FILE* f = std::fopen(path.c_str(), "rb")) {
      std::fclose(f);
    } else {
      fail("oni:" + path + ": cannot open the file");
    }
    // libOniFile trusts the lengths in the file: check the container before it reads a byte.
    const OniContainerSummary container = check_oni_container(path);
    ensure_openni();
    if (device_.open(path.c_str()) != openni::STATUS_OK)
      fail("oni:" + path + ": not a readable OpenNI2 recording (truncated or corrupt; " + extended_error() + ")");
    if (!device_.isFile()) fail("oni:" + path + ": OpenNI2 did not open it as a recording");
    openni::PlaybackControl* playback = device_.getPlaybackControl();
    if (!playback) fail("oni:" + path + ": no playback control");
    // Every frame once (with repeat_: the file again and again), as fast as the reader reads.
    playback->setSpeed(-1.0f);
    playback->setRepeatEnabled(repeat_);
    if (!device_.hasSensor(openni::SENSOR_DEPTH)) fail("oni:" + path + ": the recording has no depth stream");
    if (stream_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK)
      fail("oni:" + path + ": cannot open its depth stream (" + extended_error() + ")");
    check_depth_mode(stream_.getVideoMode(), "oni:" + path);
    width_ = stream_.getVideoMode().getResolutionX();
    height_ = stream_.getVideoMode().getResolutionY();
    own_ = intrinsics_from_fov(width_, height_, stream_.getHorizontalFieldOfView(), stream_.getVerticalFieldOfView());
    total_ = playback->getNumberOfFrames(stream_);
    if (total_ <= 0) fail("oni:" + path + ": the recording holds no depth frame (truncated or corrupt?)");
    if (total_ != container.depth_frames || (container.width && (container.width != width_ || container.height != height_)))
      fail("oni:" + path + ": OpenNI2 reads " + std::to_string(total_) + " frames of " + std::to_string(width_) + "x" +
           std::to_string(height_) + " but the file holds " + std::to_string(container.depth_frames) + " of " +
           std::to_string(container.width) + "x" + std::to_string(container.height) + " (corrupt recording)");
    if (stream_.start() != openni::STATUS_OK)
      fail("oni:" + path + ": cannot start playback (" + extended_error() + ")");
  }
  ~OniSource() override {
    // OniFile's player thread walks its stream list and raises frames without a lock; destroying
    // a started stream under it crashes (about one teardown in ten). Stopped, the thread only
    // polls for a started stream every 10 ms: let it settle there before the stream goes.
    stream_.stop();
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    stream_.destroy();
    device_.close();
  }
  int width() const override { return width_; }
  int height() const override { return height_; }
  CameraIntrinsics intrinsics() const override { return resolve(own_); }
  int64_t frame_count() const override { return total_; }

  NextStatus next(uint16_t* depth_mm, FrameInfo* info) override {
    if (failed_) return NextStatus::kError;
    while (read_ < total_) {
      // After the last frame readFrame() would block forever; a missing frame (truncated file)
      // shows up as a wait that never ends, hence the timeout.
      openni::VideoStream* streams[] = {&stream_};
      int ready = -1;
      if (openni::OpenNI::waitForAnyStream(streams, 1, &ready, kFrameTimeoutMs) != openni::STATUS_OK) {
        failed_ = true;
        error_ = "oni:" + path_ + ": truncated or corrupt recording: frame " + std::to_string(read_ + 1) +
                 " of " + std::to_string(total_) + " never arrived";
        return NextStatus::kError;
      }
      openni::VideoFrameRef frame;
      if (stream_.readFrame(&frame) != openni::STATUS_OK) {
        failed_ = true;
        error_ = "oni:" + path_ + ": cannot read frame " + std::to_string(read_ + 1) + " (" + extended_error() + ")";
        return NextStatus::kError;
      }
      const int64_t index = read_++;
      if (!copy_depth(frame, width_, height_, depth_mm)) {
        warning_ = "oni:" + path_ + ": frame " + std::to_string(index) + " has the wrong size (frame skipped)";
        ++stats_.corrupt_frames;
        continue;
      }
      info->index = index;
      info->timestamp_us = frame.getTimestamp();
      ++stats_.frames;
      return NextStatus::kFrame;
    }
    return NextStatus::kEnd;
  }
  bool rewind() override {
    if (!repeat_ || failed_) return false;
    read_ = 0;  // OpenNI2 goes on with the file's first frame
    return true;
  }

 private:
  static constexpr int kFrameTimeoutMs = 2000;
  std::string path_;
  openni::Device device_;
  openni::VideoStream stream_;
  int width_ = 0, height_ = 0;
  int64_t total_ = 0, read_ = 0;
  bool failed_ = false;
  bool repeat_ = false;
  CameraIntrinsics own_{};
};

class DeviceSource final : public FrameSource, public openni::OpenNI::DeviceDisconnectedListener {
 public:
  DeviceSource(const std::string& uri, const SourceOptions& options) : uri_(uri), options_(options) {
    ensure_openni();
    std::string why;
    if (!open_device(&why)) fail(why);
    width_ = stream_.getVideoMode().getResolutionX();
    height_ = stream_.getVideoMode().getResolutionY();
    own_ = intrinsics_from_fov(width_, height_, stream_.getHorizontalFieldOfView(), stream_.getVerticalFieldOfView());
    openni::OpenNI::addDeviceDisconnectedListener(this);
  }
  ~DeviceSource() override {
    openni::OpenNI::removeDeviceDisconnectedListener(this);
    close_device();
  }
  int width() const override { return width_; }
  int height() const override { return height_; }
  CameraIntrinsics intrinsics() const override { return resolve(own_); }
  bool live() const override { return true; }

  void onDeviceDisconnected(const openni::DeviceInfo* info) override {
    if (info && info->getUri() == opened_uri_) disconnected_ = true;
  }

  NextStatus next(uint16_t* depth_mm, FrameInfo* info) override {
    if (failed_) return NextStatus::kError;
    if (!open_) return reconnect();
    openni::VideoStream* streams[] = {&stream_};
    int ready = -1;
    openni::Status rc = openni::OpenNI::waitForAnyStream(streams, 1, &ready, options_.poll_timeout_ms);
    if (disconnected_) return lose("OpenNI2 reported the device disconnected");
    if (rc == openni::STATUS_TIME_OUT) return NextStatus::kNoFrame;
    if (rc != openni::STATUS_OK) return lose("waiting for a frame failed (" + extended_error() + ")");
    openni::VideoFrameRef frame;
    if (stream_.readFrame(&frame) != openni::STATUS_OK) return lose("reading a frame failed (" + extended_error() + ")");
    // Device frame indices are consecutive; a gap means frames we never read (the stream holds
    // only the newest frame).
    const int64_t device_index = frame.getFrameIndex();
    if (last_device_index_ >= 0 && device_index > last_device_index_ + 1)
      stats_.dropped_frames += device_index - last_device_index_ - 1;
    last_device_index_ = device_index;
    if (!copy_depth(frame, width_, height_, depth_mm)) {
      warning_ = "openni: a frame had the wrong size (frame skipped)";
      ++stats_.corrupt_frames;
      return NextStatus::kNoFrame;
    }
    info->index = index_++;
    info->timestamp_us = frame.getTimestamp();
    ++stats_.frames;
    return NextStatus::kFrame;
  }

 private:
  std::string label() const { return uri_.empty() ? std::string("openni") : "openni:" + uri_; }

  bool open_device(std::string* why) {
    disconnected_ = false;
    if (device_.open(uri_.empty() ? openni::ANY_DEVICE : uri_.c_str()) != openni::STATUS_OK) {
      *why = label() + ": no such OpenNI2 device (" + extended_error() +
             "); drivers are loaded from " + openni_library_dir() + "/OpenNI2/Drivers (see docs/app.md)";
      return false;
    }
    opened_uri_ = device_.getDeviceInfo().getUri();
    if (!device_.hasSensor(openni::SENSOR_DEPTH) || stream_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
      *why = label() + ": the device has no usable depth sensor (" + extended_error() + ")";
      device_.close();
      return false;
    }
    try {
      check_depth_mode(stream_.getVideoMode(), label());
    } catch (const std::exception& e) {
      *why = e.what();
      stream_.destroy();
      device_.close();
      return false;
    }
    if (stream_.start() != openni::STATUS_OK) {
      *why = label() + ": cannot start the depth stream (" + extended_error() + ")";
      stream_.destroy();
      device_.close();
      return false;
    }
    open_ = true;
    last_device_index_ = -1;
    return true;
  }
  void close_device() {
    if (!open_) return;
    stream_.stop();
    stream_.destroy();
    device_.close();
    open_ = false;
  }
  NextStatus lose(const std::string& why) {
    close_device();
    warning_ = label() + ": device lost: " + why;
    ++stats_.device_lost;
    last_attempt_ = std::chrono::steady_clock::now();
    return NextStatus::kDeviceLost;
  }
  NextStatus reconnect() {
    auto now = std::chrono::steady_clock::now();
    auto due = last_attempt_ + std::chrono::milliseconds(options_.reconnect_interval_ms);
    if (now < due) {
      auto wait = std::min(due - now, std::chrono::steady_clock::duration(std::chrono::milliseconds(options_.poll_timeout_ms)));
      std::this_thread::sleep_for(wait);
      if (std::chrono::steady_clock::now() < due) return NextStatus::kDeviceLost;
    }
    last_attempt_ = std::chrono::steady_clock::now();
    std::string why;
    if (!open_device(&why)) return NextStatus::kDeviceLost;
    const auto& mode = stream_.getVideoMode();
    if (mode.getResolutionX() != width_ || mode.getResolutionY() != height_) {
      close_device();
      failed_ = true;
      error_ = label() + ": the device came back with a different resolution";
      return NextStatus::kError;
    }
    ++stats_.reconnects;
    warning_ = label() + ": device back";
    return NextStatus::kNoFrame;
  }

  std::string uri_, opened_uri_;
  SourceOptions options_;
  openni::Device device_;
  openni::VideoStream stream_;
  bool open_ = false, failed_ = false;
  std::atomic<bool> disconnected_{false};
  int width_ = 0, height_ = 0;
  int64_t index_ = 0, last_device_index_ = -1;
  std::chrono::steady_clock::time_point last_attempt_{};
  CameraIntrinsics own_{};
};

}  // namespace

void ensure_openni() {
  static std::once_flag once;
  static std::string error;
  std::call_once(once, [] {
    if (openni::OpenNI::initialize() != openni::STATUS_OK) error = "OpenNI2 initialization failed: " + extended_error();
  });
  if (!error.empty()) fail(error);
}

std::string openni_library_dir() {
  Dl_info info{};
  if (!dladdr(reinterpret_cast<void*>(&oniInitialize), &info) || !info.dli_fname) return "(unknown)";
  std::string path = info.dli_fname;
  auto slash = path.rfind('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

std::unique_ptr<FrameSource> open_openni_oni_source(const std::string& path, bool repeat) {
  return std::make_unique<OniSource>(path, repeat);
}

std::unique_ptr<FrameSource> open_openni_device_source(const std::string& uri, const SourceOptions& options) {
  return std::make_unique<DeviceSource>(uri, options);
}

// ---- Feed ---------------------------------------------------------------------------------------

struct Feed::Impl {
  DpFeed abi{};
  std::string name;
  NextFn next;
  PresentFn present;
  DpFeedAttachFn attach = nullptr;
  DpFeedServedFn served = nullptr;
  DpFeedIdleFn idle = nullptr;
  void* handle = nullptr;

  static int next_trampoline(void* user, uint16_t* depth, uint64_t* timestamp_us) {
    return static_cast<Impl*>(user)->next(depth, timestamp_us);
  }
  static int present_trampoline(void* user) {
    auto* self = static_cast<Impl*>(user);
    return !self->present || self->present() ? 1 : 0;
  }
};

Feed::Feed(const std::string& name, int width, int height, int fps, const CameraIntrinsics& intrinsics, NextFn next,
           PresentFn present)
    : impl_(std::make_unique<Impl>()) {
  ensure_openni();
  const std::string path = openni_library_dir() + "/OpenNI2/Drivers/libdepthpose_feed.so.0";
  // OpenNI2 already loaded the driver: RTLD_NOLOAD hands us the same instance.
  impl_->handle = dlopen(path.c_str(), RTLD_NOW | RTLD_NOLOAD);
  if (!impl_->handle)
    fail("depthpose's OpenNI2 driver is not loaded (expected " + path + "; run make to build it)");
  impl_->attach = reinterpret_cast<DpFeedAttachFn>(dlsym(impl_->handle, DP_FEED_ATTACH_SYMBOL));
  impl_->served = reinterpret_cast<DpFeedServedFn>(dlsym(impl_->handle, DP_FEED_SERVED_SYMBOL));
  impl_->idle = reinterpret_cast<DpFeedIdleFn>(dlsym(impl_->handle, DP_FEED_IDLE_SYMBOL));
  if (!impl_->attach || !impl_->served || !impl_->idle) {
    dlclose(impl_->handle);
    fail(path + ": not depthpose's feed driver (symbols missing)");
  }
  impl_->name = name;
  impl_->next = std::move(next);
  impl_->present = std::move(present);
  DpFeed& f = impl_->abi;
  f.abi_version = DP_FEED_ABI_VERSION;
  f.name = impl_->name.c_str();
  f.width = width;
  f.height = height;
  f.fps = fps;
  f.horizontal_fov_rad = 2.0f * std::atan(float(width) / (2.0f * intrinsics.fx));
  f.vertical_fov_rad = 2.0f * std::atan(float(height) / (2.0f * intrinsics.fy));
  f.max_depth_mm = 65534;
  f.user = impl_.get();
  f.next_frame = &Impl::next_trampoline;
  f.present = &Impl::present_trampoline;
  if (impl_->attach(&f) != 0) {
    dlclose(impl_->handle);
    fail("depthpose's OpenNI2 driver is busy (a feed stream is still running)");
  }
}

Feed::~Feed() {
  impl_->attach(nullptr);
  dlclose(impl_->handle);
}

std::string Feed::uri() const { return DP_FEED_URI_PREFIX + impl_->name; }
int64_t Feed::frames_served() const { return impl_->served(); }
bool Feed::idle() const { return impl_->idle() != 0; }

}  // namespace dp::platform
