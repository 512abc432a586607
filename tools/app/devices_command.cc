// `depthpose devices`: depth cameras on USB (libusb), the route to read each, and optionally a
// hotplug watch.
#include <dirent.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "platform/openni_source.h"
#include "platform/usb_devices.h"
#include "tools/cli/command.h"
#include "tools/common/args.h"
#include "tools/common/error.h"

namespace dp::tools {

static void print_openni_drivers() {
  const std::string dir = platform::openni_library_dir() + "/OpenNI2/Drivers";
  std::string names;
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d))
      if (e->d_name[0] != '.') names += std::string(names.empty() ? "" : ", ") + e->d_name;
    closedir(d);
  }
  std::printf("OpenNI2 drivers in %s: %s\n", dir.c_str(), names.empty() ? "(none)" : names.c_str());
}

static int run_devices(int argc, char** argv) {
  Args args(argc, argv,
            "usage: depthpose devices [--watch SECONDS]\n"
            "  Lists the depth cameras attached over USB (PrimeSense/Asus 1d27, Kinect v1 045e:02ae,\n"
            "  Orbbec 2bc5, Intel RealSense 8086) and how to read each; says so when none is attached.\n"
            "  --watch SECONDS      then report cameras arriving and leaving for that long\n",
            {"--watch"});
  if (args.help_requested()) {
    std::printf("%s", args.usage().c_str());
    return 0;
  }
  const double watch_seconds = args.get_double("--watch", 0);
  if (watch_seconds < 0) fail("--watch wants a non-negative number of seconds");
  std::unique_ptr<platform::UsbLister> lister = platform::make_libusb_lister();
  platform::HotplugWatcher watcher(*lister);
  watcher.poll();
  const auto& cameras = watcher.cameras();
  if (cameras.empty()) {
    std::printf("no depth camera attached (looked for PrimeSense/Asus 1d27:*, Kinect v1 045e:02ae/02bf, "
                "Orbbec 2bc5:*, Intel RealSense 8086:<RealSense ids>)\n");
  } else {
    for (const auto& c : cameras)
      std::printf("%s\n    read it with %s\n", platform::describe(c).c_str(), platform::depth_camera_route(c.vendor));
  }
  print_openni_drivers();
  if (watch_seconds > 0) {
    std::printf("watching for %.0f s ...\n", watch_seconds);
    std::fflush(stdout);
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(watch_seconds);
    while (std::chrono::steady_clock::now() < end) {
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
      for (const auto& e : watcher.poll()) {
        std::printf("%s %s\n", e.change == platform::HotplugWatcher::Change::kArrived ? "arrived:" : "left:   ",
                    platform::describe(e.device).c_str());
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

DP_REGISTER_COMMAND(devices, "devices", "list attached depth cameras (USB) and watch hotplug", run_devices);

}  // namespace dp::tools
