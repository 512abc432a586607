// depthpose's own OpenNI2 driver: one depth device per attached feed (feed_abi.h). Built as
// libdepthpose_feed.so.0 and loaded by OpenNI2 from its private Drivers/ folder.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>

#define XN_NEW(type, ...) new type(__VA_ARGS__)
#define XN_DELETE(p) delete (p)
#include "Driver/OniDriverAPI.h"
#include "platform/openni_driver/feed_abi.h"

namespace {

std::mutex g_mutex;
const DpFeed* g_feed = nullptr;            // guarded by g_mutex
std::atomic<int64_t> g_served{0};
std::atomic<int> g_idle{1};
std::atomic<int> g_running_streams{0};

class FeedDriver;
FeedDriver* g_driver = nullptr;

bool uri_names_feed(const char* uri, const DpFeed* feed) {
  const size_t n = std::strlen(DP_FEED_URI_PREFIX);
  return feed && uri && std::strncmp(uri, DP_FEED_URI_PREFIX, n) == 0 && std::strcmp(uri + n, feed->name) == 0;
}

OniVideoMode video_mode_of(const DpFeed& feed) {
  OniVideoMode mode{};
  mode.pixelFormat = ONI_PIXEL_FORMAT_DEPTH_1_MM;
  mode.resolutionX = feed.width;
  mode.resolutionY = feed.height;
  mode.fps = feed.fps;
  return mode;
}

template <typename T>
OniStatus put(void* data, int* size, const T& value) {
  if (*size < int(sizeof(T))) return ONI_STATUS_BAD_PARAMETER;
  std::memcpy(data, &value, sizeof(T));
  *size = int(sizeof(T));
  return ONI_STATUS_OK;
}

void report_lost();

class FeedStream : public oni::driver::StreamBase {
 public:
  explicit FeedStream(const DpFeed& feed) : feed_(feed), mode_(video_mode_of(feed)) {}
  ~FeedStream() override { stop(); }

  OniStatus start() override {
    if (thread_.joinable()) return ONI_STATUS_OK;
    running_ = true;
    g_idle = 0;
    ++g_running_streams;
    thread_ = std::thread([this] { run(); });
    return ONI_STATUS_OK;
  }
  // Joins the producer thread (OpenNI2 frees the stream right after stop()).
  void stop() override {
    if (!thread_.joinable()) return;
    running_ = false;
    thread_.join();
    --g_running_streams;
  }

  OniBool isPropertySupported(int id) override {
    switch (id) {
      case ONI_STREAM_PROPERTY_VIDEO_MODE: case ONI_STREAM_PROPERTY_CROPPING:
      case ONI_STREAM_PROPERTY_MAX_VALUE: case ONI_STREAM_PROPERTY_MIN_VALUE:
      case ONI_STREAM_PROPERTY_HORIZONTAL_FOV: case ONI_STREAM_PROPERTY_VERTICAL_FOV:
      case ONI_STREAM_PROPERTY_MIRRORING: case ONI_STREAM_PROPERTY_STRIDE:
        return TRUE;
      default:
        return FALSE;
    }
  }
  OniStatus getProperty(int id, void* data, int* size) override {
    switch (id) {
      case ONI_STREAM_PROPERTY_VIDEO_MODE: return put(data, size, mode_);
      case ONI_STREAM_PROPERTY_CROPPING: {
        OniCropping cropping{};
        cropping.enabled = FALSE;
        cropping.width = feed_.width;
        cropping.height = feed_.height;
        return put(data, size, cropping);
      }
      case ONI_STREAM_PROPERTY_MAX_VALUE: return put(data, size, int(feed_.max_depth_mm));
      case ONI_STREAM_PROPERTY_MIN_VALUE: return put(data, size, int(0));
      case ONI_STREAM_PROPERTY_HORIZONTAL_FOV: return put(data, size, feed_.horizontal_fov_rad);
      case ONI_STREAM_PROPERTY_VERTICAL_FOV: return put(data, size, feed_.vertical_fov_rad);
      case ONI_STREAM_PROPERTY_MIRRORING: return put(data, size, OniBool(FALSE));
      case ONI_STREAM_PROPERTY_STRIDE: return put(data, size, int(feed_.width * 2));
      default: return ONI_STATUS_NOT_SUPPORTED;
    }
  }
  // The feed has one fixed mode: setting it to itself succeeds, anything else is refused.
  OniStatus setProperty(int id, const void* data, int size) override {
    if (id == ONI_STREAM_PROPERTY_VIDEO_MODE && size == int(sizeof(OniVideoMode))) {
      OniVideoMode want;
      std::memcpy(&want, data, sizeof want);
      return want.pixelFormat == mode_.pixelFormat && want.resolutionX == mode_.resolutionX &&
                     want.resolutionY == mode_.resolutionY
                 ? ONI_STATUS_OK
                 : ONI_STATUS_NOT_SUPPORTED;
    }
    if (id == ONI_STREAM_PROPERTY_CROPPING && size == int(sizeof(OniCropping))) {
      OniCropping want;
      std::memcpy(&want, data, sizeof want);
      return want.enabled ? ONI_STATUS_NOT_SUPPORTED : ONI_STATUS_OK;
    }
    if (id == ONI_STREAM_PROPERTY_MIRRORING && size == int(sizeof(OniBool))) {
      OniBool want;
      std::memcpy(&want, data, sizeof want);
      return want ? ONI_STATUS_NOT_SUPPORTED : ONI_STATUS_OK;
    }
    return ONI_STATUS_NOT_SUPPORTED;
  }

 private:
  void run() {
    int frame_index = 0;
    bool lost = false;
    const int bytes = feed_.width * feed_.height * 2;
    while (running_) {
      OniFrame* frame = getServices().acquireFrame();
      if (!frame) break;
      uint64_t timestamp_us = 0;
      int r = feed_.next_frame(feed_.user, static_cast<uint16_t*>(frame->data), &timestamp_us);
      if (r == kDpFeedFrame) {
        frame->dataSize = bytes;
        frame->sensorType = ONI_SENSOR_DEPTH;
        frame->timestamp = timestamp_us;
        frame->frameIndex = ++frame_index;
        frame->width = feed_.width;
        frame->height = feed_.height;
        frame->videoMode = mode_;
        frame->croppingEnabled = FALSE;
        frame->cropOriginX = 0;
        frame->cropOriginY = 0;
        frame->stride = feed_.width * 2;
        raiseNewFrame(frame);
        ++g_served;
      }
      getServices().releaseFrame(frame);
      if (r == kDpFeedEnd) break;
      if (r == kDpFeedLost) {
        lost = true;
        break;
      }
    }
    if (lost) report_lost();
    g_idle = 1;
  }

  DpFeed feed_;
  OniVideoMode mode_;
  std::thread thread_;
  std::atomic<bool> running_{false};
};

class FeedDevice : public oni::driver::DeviceBase {
 public:
  explicit FeedDevice(const DpFeed& feed) : feed_(feed), mode_(video_mode_of(feed)) {
    sensor_.sensorType = ONI_SENSOR_DEPTH;
    sensor_.numSupportedVideoModes = 1;
    sensor_.pSupportedVideoModes = &mode_;
  }
  OniStatus getSensorInfoList(OniSensorInfo** sensors, int* count) override {
    *sensors = &sensor_;
    *count = 1;
    return ONI_STATUS_OK;
  }
  oni::driver::StreamBase* createStream(OniSensorType type) override {
    return type == ONI_SENSOR_DEPTH ? new FeedStream(feed_) : nullptr;
  }
  void destroyStream(oni::driver::StreamBase* stream) override { delete stream; }

 private:
  DpFeed feed_;
  OniVideoMode mode_;
  OniSensorInfo sensor_{};
};

// Connection state is a flag flipped atomically, never a lock held across OpenNI2 callbacks:
// OpenNI2 calls tryDevice() with its context lock held, and deviceConnected() takes that lock.
class FeedDriver : public oni::driver::DriverBase {
 public:
  explicit FeedDriver(OniDriverServices* services) : DriverBase(services) { g_driver = this; }
  ~FeedDriver() override { g_driver = nullptr; }

  OniStatus tryDevice(const char* uri) override {
    {
      std::lock_guard<std::mutex> lock(g_mutex);
      if (!uri_names_feed(uri, g_feed)) return ONI_STATUS_ERROR;
      if (g_feed->present && !g_feed->present(g_feed->user)) return ONI_STATUS_ERROR;
    }
    connect(uri);
    return ONI_STATUS_OK;
  }
  oni::driver::DeviceBase* deviceOpen(const char* uri, const char*) override {
    std::lock_guard<std::mutex> lock(g_mutex);
    if (!uri_names_feed(uri, g_feed)) return nullptr;
    return new FeedDevice(*g_feed);
  }
  void deviceClose(oni::driver::DeviceBase* device) override { delete device; }
  void shutdown() override {}

  // Announces the device (once until it is lost). OpenNI2 keeps a disconnected device's URI
  // in its driver table and then never asks tryDevice() again, so a replugged device must be
  // announced by the driver itself, as a USB hotplug driver does.
  void connect(const std::string& uri) {
    bool expected = false;
    if (!connected_.compare_exchange_strong(expected, true)) return;
    OniDeviceInfo info{};
    std::snprintf(info.uri, sizeof info.uri, "%s", uri.c_str());
    std::snprintf(info.vendor, sizeof info.vendor, "depthpose");
    std::snprintf(info.name, sizeof info.name, "feed");
    {
      std::lock_guard<std::mutex> lock(info_mutex_);
      info_ = info;
    }
    deviceConnected(&info);
  }
  void lost() {
    bool expected = true;
    if (!connected_.compare_exchange_strong(expected, false)) return;
    OniDeviceInfo info;
    {
      std::lock_guard<std::mutex> lock(info_mutex_);
      info = info_;
    }
    deviceDisconnected(&info);
  }

 private:
  std::atomic<bool> connected_{false};
  std::mutex info_mutex_;
  OniDeviceInfo info_{};
};

void report_lost() {
  if (g_driver) g_driver->lost();
}

// Watches feed->present() like a USB hotplug thread and announces the device when it appears.
std::thread g_hotplug;
std::atomic<bool> g_hotplug_stop{false};

void hotplug_loop() {
  while (!g_hotplug_stop.load()) {
    std::string uri;
    {
      std::lock_guard<std::mutex> lock(g_mutex);
      if (g_feed && (!g_feed->present || g_feed->present(g_feed->user))) uri = std::string(DP_FEED_URI_PREFIX) + g_feed->name;
    }
    if (!uri.empty() && g_driver) g_driver->connect(uri);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

void stop_hotplug() {
  if (!g_hotplug.joinable()) return;
  g_hotplug_stop = true;
  g_hotplug.join();
}

}  // namespace

ONI_EXPORT_DRIVER(FeedDriver)

ONI_C_API_EXPORT int dp_feed_attach(const DpFeed* feed) {
  if (feed && feed->abi_version != DP_FEED_ABI_VERSION) return -1;
  if (g_running_streams.load() != 0) return -1;
  stop_hotplug();
  {
    std::lock_guard<std::mutex> lock(g_mutex);
    g_feed = feed;
    g_served = 0;
  }
  // Tell OpenNI2 the previous feed's device is gone, and announce the new one before returning
  // so that it can be opened at once.
  if (g_driver) g_driver->lost();
  if (feed && g_driver && (!feed->present || feed->present(feed->user)))
    g_driver->connect(std::string(DP_FEED_URI_PREFIX) + feed->name);
  if (feed) {
    g_hotplug_stop = false;
    g_hotplug = std::thread(hotplug_loop);
  }
  return 0;
}

ONI_C_API_EXPORT int64_t dp_feed_frames_served(void) { return g_served.load(); }
ONI_C_API_EXPORT int dp_feed_idle(void) { return g_idle.load(); }
