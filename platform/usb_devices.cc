#include "platform/usb_devices.h"

#include <libusb-1.0/libusb.h>

#include <algorithm>
#include <cstdio>

#include "tools/common/error.h"

namespace dp::platform {

namespace {

struct RealSenseId {
  uint16_t product;
  const char* name;
};
// Intel RealSense depth cameras (product ids as published by librealsense).
constexpr RealSenseId kRealSense[] = {
    {0x0a66, "Intel RealSense F200"},  {0x0aa5, "Intel RealSense SR300"}, {0x0b48, "Intel RealSense SR305"},
    {0x0a80, "Intel RealSense R200"},  {0x0ad1, "Intel RealSense D400"},  {0x0ad2, "Intel RealSense D410"},
    {0x0ad3, "Intel RealSense D415"},  {0x0ad4, "Intel RealSense D430"},  {0x0ad5, "Intel RealSense D430 MM"},
    {0x0af6, "Intel RealSense D420"},  {0x0afe, "Intel RealSense D420 MM"}, {0x0aff, "Intel RealSense D410 MM"},
    {0x0b00, "Intel RealSense D400 MM"}, {0x0b01, "Intel RealSense D430 MM RGB"}, {0x0b03, "Intel RealSense D460"},
    {0x0b07, "Intel RealSense D435"},  {0x0b0c, "Intel RealSense D405 (USB2)"}, {0x0b3a, "Intel RealSense D435i"},
    {0x0b49, "Intel RealSense D416"},  {0x0b4b, "Intel RealSense D430i"}, {0x0b4d, "Intel RealSense D465"},
    {0x0b52, "Intel RealSense D416 RGB"}, {0x0b5b, "Intel RealSense D405"}, {0x0b5c, "Intel RealSense D455"},
    {0x0ad6, "Intel RealSense D400 (USB2)"}, {0x0b3d, "Intel RealSense L515 (pre-production)"},
    {0x0b64, "Intel RealSense L515"},  {0x0b68, "Intel RealSense L535"},
};

class LibusbLister final : public UsbLister {
 public:
  LibusbLister() {
    int rc = libusb_init(&context_);
    if (rc != 0) {
      context_ = nullptr;
      error_ = libusb_error_name(rc);
    }
  }
  ~LibusbLister() override {
    if (context_) libusb_exit(context_);
  }
  std::vector<UsbDevice> list() override {
    if (!context_) tools::fail("libusb cannot start (" + error_ + "); is /dev/bus/usb readable?");
    libusb_device** devices = nullptr;
    ssize_t n = libusb_get_device_list(context_, &devices);
    if (n < 0) tools::fail(std::string("libusb cannot list USB devices: ") + libusb_error_name(int(n)));
    std::vector<UsbDevice> out;
    for (ssize_t i = 0; i < n; ++i) {
      libusb_device_descriptor d{};
      if (libusb_get_device_descriptor(devices[i], &d) != 0) continue;
      UsbDevice u;
      u.vendor = d.idVendor;
      u.product = d.idProduct;
      u.bus = libusb_get_bus_number(devices[i]);
      u.address = libusb_get_device_address(devices[i]);
      uint8_t ports[8];
      int depth = libusb_get_port_numbers(devices[i], ports, 8);
      u.port_path = std::to_string(u.bus);
      for (int p = 0; p < depth; ++p) u.port_path += (p ? "." : "-") + std::to_string(ports[p]);
      out.push_back(u);
    }
    libusb_free_device_list(devices, 1);
    return out;
  }

 private:
  libusb_context* context_ = nullptr;
  std::string error_;
};

bool same_camera(const UsbDevice& a, const UsbDevice& b) {
  return a.vendor == b.vendor && a.product == b.product && a.port_path == b.port_path;
}

}  // namespace

const char* depth_camera_name(uint16_t vendor, uint16_t product) {
  switch (vendor) {
    case 0x1d27: return "PrimeSense / Asus Xtion depth sensor";
    case 0x045e:
      if (product == 0x02ae) return "Microsoft Kinect v1 camera (Xbox 360)";
      if (product == 0x02bf) return "Microsoft Kinect for Windows camera";
      return nullptr;
    case 0x2bc5: return "Orbbec depth camera";
    case 0x8086:
      for (const auto& r : kRealSense)
        if (r.product == product) return r.name;
      return nullptr;
    default: return nullptr;
  }
}

const char* depth_camera_route(uint16_t vendor) {
  switch (vendor) {
    case 0x1d27: return "--source openni (OpenNI2 PS1080/PSLink driver: make openni-devices)";
    case 0x045e: return "--source openni (needs the freenect OpenNI2 driver, see docs/app.md)";
    case 0x2bc5: return "--source openni (Orbbec's OpenNI2 driver) or v4l2 if it exposes Z16";
    case 0x8086: return "--source v4l2:/dev/videoN (uvcvideo, Z16)";
    default: return "";
  }
}

std::unique_ptr<UsbLister> make_libusb_lister() { return std::make_unique<LibusbLister>(); }

std::vector<UsbDevice> depth_cameras(const std::vector<UsbDevice>& devices) {
  std::vector<UsbDevice> out;
  for (const auto& d : devices)
    if (depth_camera_name(d.vendor, d.product)) out.push_back(d);
  return out;
}

HotplugWatcher::HotplugWatcher(UsbLister& lister) : lister_(lister) {}

std::vector<HotplugWatcher::Event> HotplugWatcher::poll() {
  std::vector<UsbDevice> now = depth_cameras(lister_.list());
  std::vector<Event> events;
  for (const auto& old : cameras_)
    if (std::none_of(now.begin(), now.end(), [&](const UsbDevice& d) { return same_camera(d, old); }))
      events.push_back({Change::kLeft, old});
  for (const auto& d : now)
    if (std::none_of(cameras_.begin(), cameras_.end(), [&](const UsbDevice& old) { return same_camera(d, old); }))
      events.push_back({Change::kArrived, d});
  cameras_ = std::move(now);
  return events;
}

bool HotplugWatcher::attached(const UsbDevice& device) const {
  return std::any_of(cameras_.begin(), cameras_.end(), [&](const UsbDevice& d) { return same_camera(d, device); });
}

std::string describe(const UsbDevice& d) {
  char id[16];
  std::snprintf(id, sizeof id, "%04x:%04x", d.vendor, d.product);
  const char* name = depth_camera_name(d.vendor, d.product);
  return std::string(id) + " " + (name ? name : "USB device") + " at bus " + std::to_string(d.bus) + " port " +
         d.port_path;
}

}  // namespace dp::platform
