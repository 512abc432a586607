#include "platform/hotplug_source.h"

#include <chrono>
#include <thread>

namespace dp::platform {

namespace {

using Clock = std::chrono::steady_clock;

class HotplugSource final : public FrameSource {
 public:
  HotplugSource(std::unique_ptr<FrameSource> first, SourceOpener reopen, std::unique_ptr<UsbLister> lister,
                const UsbDevice& camera, const HotplugOptions& options)
      : inner_(std::move(first)), reopen_(std::move(reopen)), lister_(std::move(lister)), watcher_(*lister_),
        camera_(camera), options_(options) {
    width_ = inner_->width();
    height_ = inner_->height();
    intrinsics_ = inner_->intrinsics();
    watcher_.poll();
    last_poll_ = Clock::now();
  }
  int width() const override { return width_; }
  int height() const override { return height_; }
  CameraIntrinsics intrinsics() const override { return resolve(intrinsics_); }
  bool live() const override { return true; }

  NextStatus next(uint16_t* depth_mm, FrameInfo* info) override {
    if (failed_) return NextStatus::kError;
    if (inner_) {
      if (Clock::now() - last_poll_ >= std::chrono::milliseconds(options_.poll_interval_ms)) {
        if (!poll()) return NextStatus::kError;
        if (!watcher_.attached(camera_)) {
          fold_inner_stats();
          inner_.reset();
          warning_ = "device lost: " + describe(camera_) + " left the USB bus";
          ++own_lost_;
          sync_stats();
          return NextStatus::kDeviceLost;
        }
      }
      NextStatus s = inner_->next(depth_mm, info);
      sync_stats();
      if (s == NextStatus::kFrame) {
        info->index = index_++;
        ++stats_.frames;
      } else if (s == NextStatus::kError) {
        failed_ = true;
        error_ = inner_->last_error();
      } else if (s == NextStatus::kDeviceLost) {
        warning_ = inner_->last_warning();
      }
      return s;
    }
    // Away: look for it again.
    if (!poll()) return NextStatus::kError;
    if (!watcher_.attached(camera_)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(options_.away_sleep_ms));
      return NextStatus::kDeviceLost;
    }
    try {
      std::unique_ptr<FrameSource> again = reopen_();
      if (again->width() != width_ || again->height() != height_) {
        failed_ = true;
        error_ = describe(camera_) + " came back with a different frame size";
        return NextStatus::kError;
      }
      inner_ = std::move(again);
    } catch (const std::exception& e) {
      // Back on the bus but not ready yet (device node, firmware): try again on a later call.
      warning_ = std::string("camera back but not ready: ") + e.what();
      std::this_thread::sleep_for(std::chrono::milliseconds(options_.away_sleep_ms));
      return NextStatus::kDeviceLost;
    }
    ++own_reconnects_;
    sync_stats();
    warning_ = "device back: " + describe(camera_);
    return NextStatus::kNoFrame;
  }

 private:
  bool poll() {
    last_poll_ = Clock::now();
    try {
      watcher_.poll();
      return true;
    } catch (const std::exception& e) {
      failed_ = true;
      error_ = e.what();
      return false;
    }
  }
  // Totals = closed inner sources (folded) + the open one + the losses seen on the bus.
  void fold_inner_stats() {
    const SourceStats& s = inner_->stats();
    folded_.corrupt_frames += s.corrupt_frames;
    folded_.dropped_frames += s.dropped_frames;
    folded_.device_lost += s.device_lost;
    folded_.reconnects += s.reconnects;
  }
  void sync_stats() {
    SourceStats open{};
    if (inner_) open = inner_->stats();
    stats_.corrupt_frames = folded_.corrupt_frames + open.corrupt_frames;
    stats_.dropped_frames = folded_.dropped_frames + open.dropped_frames;
    stats_.device_lost = folded_.device_lost + open.device_lost + own_lost_;
    stats_.reconnects = folded_.reconnects + open.reconnects + own_reconnects_;
  }
  SourceStats folded_{};
  int64_t own_lost_ = 0, own_reconnects_ = 0;

  std::unique_ptr<FrameSource> inner_;
  SourceOpener reopen_;
  std::unique_ptr<UsbLister> lister_;
  HotplugWatcher watcher_;
  UsbDevice camera_;
  HotplugOptions options_;
  int width_ = 0, height_ = 0;
  CameraIntrinsics intrinsics_{};
  int64_t index_ = 0;
  bool failed_ = false;
  Clock::time_point last_poll_{};
};

}  // namespace

std::unique_ptr<FrameSource> watch_hotplug(std::unique_ptr<FrameSource> first, SourceOpener reopen,
                                           std::unique_ptr<UsbLister> lister, const UsbDevice& camera,
                                           const HotplugOptions& options) {
  return std::make_unique<HotplugSource>(std::move(first), std::move(reopen), std::move(lister), camera, options);
}

}  // namespace dp::platform
