// Depth-camera USB ids, libusb enumeration, the hotplug watcher and unplug/replug through the
// source interface — against a fake device list.
#include <gtest/gtest.h>

#include <cstring>

#include "platform/hotplug_source.h"
#include "platform/usb_devices.h"
#include "tools/common/error.h"

using namespace dp;
using namespace dp::platform;

namespace {

struct FakeBus : UsbLister {
  std::vector<UsbDevice>* devices;
  bool broken = false;
  explicit FakeBus(std::vector<UsbDevice>* d) : devices(d) {}
  std::vector<UsbDevice> list() override {
    if (broken) tools::fail("fake bus unreadable");
    return *devices;
  }
};

UsbDevice dev(uint16_t vendor, uint16_t product, const char* port, uint8_t address = 5) {
  UsbDevice d;
  d.vendor = vendor;
  d.product = product;
  d.bus = 1;
  d.address = address;
  d.port_path = port;
  return d;
}

// A live source producing frames whose pixels all equal a running counter.
struct CountingSource : FrameSource {
  int w, h;
  int* counter;
  explicit CountingSource(int* c, int width = 4, int height = 2) : w(width), h(height), counter(c) {}
  int width() const override { return w; }
  int height() const override { return h; }
  CameraIntrinsics intrinsics() const override { return kinect_v1_intrinsics(w, h); }
  bool live() const override { return true; }
  NextStatus next(uint16_t* depth, FrameInfo* info) override {
    ++*counter;
    for (int i = 0; i < w * h; ++i) depth[i] = uint16_t(*counter);
    info->index = *counter;
    ++stats_.frames;
    return NextStatus::kFrame;
  }
};

}  // namespace

TEST(PlatformUsb, DepthCameraRuleByVendorAndProduct) {
  EXPECT_NE(depth_camera_name(0x1d27, 0x0601), nullptr);  // Asus Xtion PRO LIVE
  EXPECT_NE(depth_camera_name(0x1d27, 0x0600), nullptr);  // PrimeSense Carmine
  EXPECT_NE(depth_camera_name(0x045e, 0x02ae), nullptr);  // Kinect v1 camera
  EXPECT_EQ(depth_camera_name(0x045e, 0x02b0), nullptr);  // Kinect v1 motor: not a camera
  EXPECT_EQ(depth_camera_name(0x045e, 0x02ad), nullptr);  // Kinect v1 audio
  EXPECT_EQ(depth_camera_name(0x045e, 0x0745), nullptr);  // a Microsoft mouse receiver
  EXPECT_NE(depth_camera_name(0x2bc5, 0x0401), nullptr);  // Orbbec Astra
  EXPECT_NE(depth_camera_name(0x8086, 0x0b07), nullptr);  // RealSense D435
  EXPECT_NE(depth_camera_name(0x8086, 0x0b3a), nullptr);  // RealSense D435i
  EXPECT_EQ(depth_camera_name(0x8086, 0x0001), nullptr);  // other Intel USB ids
  EXPECT_EQ(depth_camera_name(0x046d, 0x0825), nullptr);  // a webcam
  EXPECT_NE(std::string(depth_camera_route(0x045e)).find("freenect"), std::string::npos);

  std::vector<UsbDevice> bus = {dev(0x046d, 0x0825, "1-1"), dev(0x1d27, 0x0601, "1-2"), dev(0x045e, 0x02b0, "1-3"),
                                dev(0x045e, 0x02ae, "1-3.1")};
  std::vector<UsbDevice> cams = depth_cameras(bus);
  ASSERT_EQ(cams.size(), 2u);
  EXPECT_EQ(cams[0].port_path, "1-2");
  EXPECT_EQ(cams[1].product, 0x02ae);
  EXPECT_NE(describe(cams[1]).find("045e:02ae"), std::string::npos);
  EXPECT_NE(describe(cams[1]).find("Kinect"), std::string::npos);
}

TEST(PlatformUsb, LibusbEnumerationRuns) {
  // No camera here; the real bus must still be listable (or fail with a clear ToolError).
  std::unique_ptr<UsbLister> lister = make_libusb_lister();
  try {
    std::vector<UsbDevice> all = lister->list();
    for (const auto& d : all) EXPECT_FALSE(d.port_path.empty());
  } catch (const tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("libusb"), std::string::npos) << e.what();
  }
}

TEST(PlatformUsb, WatcherReportsArrivalsDeparturesAndReplug) {
  std::vector<UsbDevice> bus = {dev(0x046d, 0x0825, "1-1")};
  FakeBus fake(&bus);
  HotplugWatcher w(fake);
  EXPECT_TRUE(w.poll().empty());
  bus.push_back(dev(0x1d27, 0x0601, "1-2", 7));
  auto events = w.poll();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].change, HotplugWatcher::Change::kArrived);
  EXPECT_EQ(events[0].device.product, 0x0601);
  EXPECT_TRUE(w.poll().empty());
  const UsbDevice xtion = bus.back();
  bus.pop_back();
  events = w.poll();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].change, HotplugWatcher::Change::kLeft);
  EXPECT_FALSE(w.attached(xtion));
  // Replugged into the same port it gets a new bus address: still the same camera.
  bus.push_back(dev(0x1d27, 0x0601, "1-2", 9));
  events = w.poll();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].change, HotplugWatcher::Change::kArrived);
  EXPECT_TRUE(w.attached(xtion));
  // The webcam leaving is no event: it is not a depth camera.
  bus.erase(bus.begin());
  EXPECT_TRUE(w.poll().empty());
}

TEST(PlatformUsb, UnplugAndReplugThroughTheSourceInterface) {
  std::vector<UsbDevice> bus = {dev(0x8086, 0x0b07, "2-1")};
  auto lister = std::make_unique<FakeBus>(&bus);
  FakeBus* fake = lister.get();
  int counter = 0, opens = 0;
  bool ready = true;
  SourceOpener reopen = [&]() -> std::unique_ptr<FrameSource> {
    if (!ready) tools::fail("/dev/video4: no such device");
    ++opens;
    return std::make_unique<CountingSource>(&counter);
  };
  HotplugOptions o;
  o.poll_interval_ms = 0;
  o.away_sleep_ms = 0;
  auto source = watch_hotplug(std::make_unique<CountingSource>(&counter), reopen, std::move(lister), bus[0], o);
  ASSERT_EQ(source->width(), 4);
  std::vector<uint16_t> depth(8, 0);
  FrameInfo info;
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(depth[0], 1);
  EXPECT_EQ(info.index, 0);

  bus.clear();  // unplugged
  depth.assign(8, 4242);
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kDeviceLost);
  EXPECT_NE(source->last_warning().find("8086:0b07"), std::string::npos) << source->last_warning();
  for (int i = 0; i < 5; ++i) EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kDeviceLost);
  EXPECT_EQ(depth[0], 4242) << "no frame data is written while the camera is away";
  EXPECT_EQ(source->stats().device_lost, 1);

  bus.push_back(dev(0x8086, 0x0b07, "2-1", 11));  // back, but its device node is not ready yet
  ready = false;
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kDeviceLost);
  EXPECT_NE(source->last_warning().find("not ready"), std::string::npos);
  ready = true;
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kNoFrame);
  EXPECT_EQ(opens, 1);
  EXPECT_EQ(source->stats().reconnects, 1);
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(depth[0], 2);
  EXPECT_EQ(info.index, 1) << "indices continue across the replug";
  EXPECT_EQ(source->stats().frames, 2);

  // An unreadable bus is an error, not a silent "still there".
  fake->broken = true;
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kError);
  EXPECT_NE(source->last_error().find("fake bus"), std::string::npos);
}

TEST(PlatformUsb, ReplugWithADifferentFrameSizeIsAnError) {
  std::vector<UsbDevice> bus = {dev(0x2bc5, 0x0401, "3-1")};
  int counter = 0;
  HotplugOptions o;
  o.poll_interval_ms = 0;
  o.away_sleep_ms = 0;
  auto source = watch_hotplug(
      std::make_unique<CountingSource>(&counter), [&] { return std::make_unique<CountingSource>(&counter, 8, 2); },
      std::make_unique<FakeBus>(&bus), bus[0], o);
  std::vector<uint16_t> depth(16);
  FrameInfo info;
  bus.clear();
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kDeviceLost);
  bus.push_back(dev(0x2bc5, 0x0401, "3-1"));
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kError);
  EXPECT_NE(source->last_error().find("different frame size"), std::string::npos);
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kError);
}
