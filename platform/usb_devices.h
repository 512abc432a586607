// Depth cameras on USB: which vendor/product ids are depth cameras, enumeration through libusb,
// and a hotplug watcher (arrived / left) over any device lister, so the logic runs in tests
// against a fake list.
//
// Depth-camera rule (by USB id):
//   1d27:*     PrimeSense / Asus Xtion (every PrimeSense product id is a depth sensor)
//   045e:02ae  Microsoft Kinect v1 camera (Xbox 360);  045e:02bf  Kinect for Windows camera
//              (the Kinect's motor and audio ids are not cameras)
//   2bc5:*     Orbbec (Astra and successors; a camera may also list its colour UVC id)
//   8086:xxxx  Intel RealSense: only the listed RealSense product ids (Intel's other USB ids are not
//              cameras): F200, SR300, R200, D4xx, L5xx families
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace dp::platform {

struct UsbDevice {
  uint16_t vendor = 0, product = 0;
  uint8_t bus = 0, address = 0;
  std::string port_path;  // "bus-port.port..." e.g. "1-2.4": stable across replug into the same port
};

// Names the depth camera behind a vendor/product id, or returns nullptr when it is not one.
const char* depth_camera_name(uint16_t vendor, uint16_t product);

// The OpenNI2/V4L2 route a camera family takes (for `depthpose devices`).
const char* depth_camera_route(uint16_t vendor);

class UsbLister {
 public:
  virtual ~UsbLister() = default;
  // Every attached USB device. Throws ToolError when the bus cannot be read at all.
  virtual std::vector<UsbDevice> list() = 0;
};

// libusb-1.0 enumeration (one libusb context for the lister's lifetime).
std::unique_ptr<UsbLister> make_libusb_lister();

// Attached depth cameras from a device list (in list order).
std::vector<UsbDevice> depth_cameras(const std::vector<UsbDevice>& devices);

// Tracks the set of attached depth cameras between polls. Identity = port path + vendor:product,
// so a camera replugged into the same port is "the same camera back".
class HotplugWatcher {
 public:
  enum class Change { kArrived, kLeft };
  struct Event {
    Change change;
    UsbDevice device;
  };
  explicit HotplugWatcher(UsbLister& lister);
  // Lists the bus and returns what changed since the previous poll (first poll: arrivals).
  std::vector<Event> poll();
  const std::vector<UsbDevice>& cameras() const { return cameras_; }
  // Whether `device` (by identity) is attached at the last poll.
  bool attached(const UsbDevice& device) const;

 private:
  UsbLister& lister_;
  std::vector<UsbDevice> cameras_;
};

std::string describe(const UsbDevice& device);  // "1d27:0601 PrimeSense ... at bus 1 port 1-2.4"

}  // namespace dp::platform
