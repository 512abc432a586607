#include "platform/v4l2_source.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <thread>
#include <vector>

#include "tools/common/error.h"

namespace dp::platform {

using tools::fail;

std::string fourcc_text(uint32_t f) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    char c = char((f >> (8 * i)) & 0xff);
    s += (c >= 32 && c < 127) ? c : '?';
  }
  return s;
}

V4l2Syscalls real_v4l2_syscalls() {
  V4l2Syscalls s;
  s.open = [](const char* path, int flags) { return ::open(path, flags); };
  s.close = [](int fd) { return ::close(fd); };
  s.ioctl = [](int fd, unsigned long request, void* arg) {
    int r;
    do r = ::ioctl(fd, request, arg);
    while (r == -1 && errno == EINTR);
    return r;
  };
  s.mmap = [](void* addr, size_t length, int prot, int flags, int fd, off_t offset) {
    return ::mmap(addr, length, prot, flags, fd, offset);
  };
  s.munmap = [](void* addr, size_t length) { return ::munmap(addr, length); };
  s.poll = [](struct pollfd* fds, nfds_t count, int timeout_ms) { return ::poll(fds, count, timeout_ms); };
  return s;
}

namespace {

constexpr uint32_t kZ16 = v4l2_fourcc('Z', '1', '6', ' ');
constexpr uint32_t kY16 = v4l2_fourcc('Y', '1', '6', ' ');

class V4l2Source final : public FrameSource {
 public:
  V4l2Source(const std::string& path, const SourceOptions& options, V4l2Syscalls sys)
      : path_(path), options_(options), sys_(std::move(sys)) {
    std::string why;
    if (!open_device(&why, options.v4l2_width, options.v4l2_height)) fail(why);
    width_ = format_.fmt.pix.width;
    height_ = format_.fmt.pix.height;
  }
  ~V4l2Source() override { close_device(); }

  int width() const override { return width_; }
  int height() const override { return height_; }
  CameraIntrinsics intrinsics() const override { return resolve(kinect_v1_intrinsics(width_, height_)); }
  bool live() const override { return true; }
  uint32_t pixel_format() const { return format_.fmt.pix.pixelformat; }

  NextStatus next(uint16_t* depth_mm, FrameInfo* info) override {
    if (failed_) return NextStatus::kError;
    if (fd_ < 0) return reconnect();
    pollfd p{fd_, POLLIN, 0};
    int r = sys_.poll(&p, 1, options_.poll_timeout_ms);
    if (r < 0) return errno == EINTR ? NextStatus::kNoFrame : lose("poll failed: " + std::string(std::strerror(errno)));
    if (r == 0) return NextStatus::kNoFrame;
    if (p.revents & (POLLERR | POLLHUP | POLLNVAL)) return lose("the device reported an error (unplugged?)");
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    if (sys_.ioctl(fd_, VIDIOC_DQBUF, &buf) < 0) {
      if (errno == EAGAIN) return NextStatus::kNoFrame;
      return lose("VIDIOC_DQBUF: " + std::string(std::strerror(errno)));
    }
    if (options_.latest_only) {
      // Older filled buffers go straight back to the driver: only the newest frame is used.
      for (;;) {
        pollfd again{fd_, POLLIN, 0};
        if (sys_.poll(&again, 1, 0) != 1 || !(again.revents & POLLIN)) break;
        v4l2_buffer newer{};
        newer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        newer.memory = V4L2_MEMORY_MMAP;
        if (sys_.ioctl(fd_, VIDIOC_DQBUF, &newer) < 0) break;
        note_sequence(buf.sequence);
        ++stats_.dropped_frames;
        if (buf.index < buffers_.size() && sys_.ioctl(fd_, VIDIOC_QBUF, &buf) < 0)
          return lose("VIDIOC_QBUF: " + std::string(std::strerror(errno)));
        buf = newer;
      }
    }
    NextStatus status = NextStatus::kNoFrame;
    const size_t row_bytes = size_t(width_) * 2;
    const size_t stride = format_.fmt.pix.bytesperline;
    const size_t needed = stride * size_t(height_ - 1) + row_bytes;
    if (buf.index >= buffers_.size() || (buf.flags & V4L2_BUF_FLAG_ERROR) || buf.bytesused < needed) {
      warning_ = "v4l2:" + path_ + ": short or damaged buffer (" + std::to_string(buf.bytesused) + " of " +
                 std::to_string(needed) + " bytes, frame skipped)";
      ++stats_.corrupt_frames;
    } else {
      const auto* base = static_cast<const uint8_t*>(buffers_[buf.index].start);
      for (int y = 0; y < height_; ++y) std::memcpy(depth_mm + size_t(y) * width_, base + size_t(y) * stride, row_bytes);
      note_sequence(buf.sequence);
      info->index = index_++;
      info->timestamp_us = uint64_t(buf.timestamp.tv_sec) * 1000000u + uint64_t(buf.timestamp.tv_usec);
      ++stats_.frames;
      status = NextStatus::kFrame;
    }
    if (buf.index < buffers_.size() && sys_.ioctl(fd_, VIDIOC_QBUF, &buf) < 0) {
      // The frame (if any) is already copied; the loss is reported by the next call.
      int err = errno;
      if (status == NextStatus::kFrame) {
        pending_loss_ = "VIDIOC_QBUF: " + std::string(std::strerror(err));
        close_device();
        return status;
      }
      return lose("VIDIOC_QBUF: " + std::string(std::strerror(err)));
    }
    return status;
  }

 private:
  struct Buffer {
    void* start = nullptr;
    size_t length = 0;
  };

  std::string label() const { return "v4l2:" + path_; }

  // Sequence gaps are frames the driver captured but had no free buffer for.
  void note_sequence(uint32_t sequence) {
    if (have_sequence_ && sequence > last_sequence_ + 1) stats_.dropped_frames += sequence - last_sequence_ - 1;
    have_sequence_ = true;
    last_sequence_ = sequence;
  }

  bool open_device(std::string* why, int want_width, int want_height) {
    fd_ = sys_.open(path_.c_str(), O_RDWR | O_NONBLOCK);
    if (fd_ < 0) {
      int err = errno;
      *why = label() + (err == ENOENT ? ": no such device (is the camera plugged in?)"
                        : err == EACCES ? ": permission denied (add yourself to the 'video' group)"
                                        : ": cannot open: " + std::string(std::strerror(err)));
      return false;
    }
    if (!configure(why, want_width, want_height)) {
      close_device();
      return false;
    }
    return true;
  }

  bool configure(std::string* why, int want_width, int want_height) {
    v4l2_capability cap{};
    if (sys_.ioctl(fd_, VIDIOC_QUERYCAP, &cap) < 0) {
      *why = label() + ": not a V4L2 device (VIDIOC_QUERYCAP: " + std::strerror(errno) + ")";
      return false;
    }
    uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) {
      *why = label() + ": not a video capture device";
      return false;
    }
    if (!(caps & V4L2_CAP_STREAMING)) {
      *why = label() + ": the device cannot stream (no V4L2_CAP_STREAMING)";
      return false;
    }
    std::vector<uint32_t> offered;
    for (uint32_t i = 0; i < 64; ++i) {
      v4l2_fmtdesc d{};
      d.index = i;
      d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      if (sys_.ioctl(fd_, VIDIOC_ENUM_FMT, &d) < 0) break;
      offered.push_back(d.pixelformat);
    }
    uint32_t chosen = 0;
    for (uint32_t want : {kZ16, kY16})
      for (uint32_t f : offered)
        if (!chosen && f == want) chosen = f;
    if (!chosen) {
      std::string list;
      for (uint32_t f : offered) list += (list.empty() ? "" : ", ") + fourcc_text(f);
      *why = label() + ": no depth format (want Z16 or Y16; the device offers " + (list.empty() ? "none" : list) + ")";
      return false;
    }
    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (sys_.ioctl(fd_, VIDIOC_G_FMT, &fmt) < 0) {
      *why = label() + ": VIDIOC_G_FMT: " + std::strerror(errno);
      return false;
    }
    fmt.fmt.pix.pixelformat = chosen;
    if (want_width > 0) {
      fmt.fmt.pix.width = uint32_t(want_width);
      fmt.fmt.pix.height = uint32_t(want_height);
    }
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    fmt.fmt.pix.bytesperline = 0;
    if (sys_.ioctl(fd_, VIDIOC_S_FMT, &fmt) < 0) {
      *why = label() + ": VIDIOC_S_FMT " + fourcc_text(chosen) + ": " + std::strerror(errno);
      return false;
    }
    if (fmt.fmt.pix.pixelformat != chosen) {
      *why = label() + ": the device did not accept pixel format " + fourcc_text(chosen) + " (got " +
             fourcc_text(fmt.fmt.pix.pixelformat) + ")";
      return false;
    }
    if (want_width > 0 && (int(fmt.fmt.pix.width) != want_width || int(fmt.fmt.pix.height) != want_height)) {
      *why = label() + ": the device refused " + std::to_string(want_width) + "x" + std::to_string(want_height) +
             " (it offers " + std::to_string(fmt.fmt.pix.width) + "x" + std::to_string(fmt.fmt.pix.height) + ")";
      return false;
    }
    if (fmt.fmt.pix.width < 1 || fmt.fmt.pix.height < 1 || fmt.fmt.pix.width > uint32_t(blob::kMaxFrameDimension) ||
        fmt.fmt.pix.height > uint32_t(blob::kMaxFrameDimension)) {
      *why = label() + ": bad frame size " + std::to_string(fmt.fmt.pix.width) + "x" + std::to_string(fmt.fmt.pix.height);
      return false;
    }
    if (fmt.fmt.pix.bytesperline < fmt.fmt.pix.width * 2) fmt.fmt.pix.bytesperline = fmt.fmt.pix.width * 2;
    format_ = fmt;

    v4l2_requestbuffers req{};
    req.count = kV4l2BufferCount;
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    if (sys_.ioctl(fd_, VIDIOC_REQBUFS, &req) < 0 || req.count < 2) {
      *why = label() + ": the device refused mmap streaming buffers";
      return false;
    }
    for (uint32_t i = 0; i < req.count; ++i) {
      v4l2_buffer buf{};
      buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      buf.memory = V4L2_MEMORY_MMAP;
      buf.index = i;
      if (sys_.ioctl(fd_, VIDIOC_QUERYBUF, &buf) < 0) {
        *why = label() + ": VIDIOC_QUERYBUF: " + std::strerror(errno);
        return false;
      }
      void* start = sys_.mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, off_t(buf.m.offset));
      if (start == MAP_FAILED) {
        *why = label() + ": mmap of buffer " + std::to_string(i) + " failed: " + std::strerror(errno);
        return false;
      }
      buffers_.push_back({start, buf.length});
      if (sys_.ioctl(fd_, VIDIOC_QBUF, &buf) < 0) {
        *why = label() + ": VIDIOC_QBUF: " + std::strerror(errno);
        return false;
      }
    }
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (sys_.ioctl(fd_, VIDIOC_STREAMON, &type) < 0) {
      *why = label() + ": VIDIOC_STREAMON: " + std::strerror(errno);
      return false;
    }
    streaming_ = true;
    have_sequence_ = false;
    return true;
  }

  void close_device() {
    if (fd_ < 0) return;
    if (streaming_) {
      int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      sys_.ioctl(fd_, VIDIOC_STREAMOFF, &type);
      streaming_ = false;
    }
    for (auto& b : buffers_) sys_.munmap(b.start, b.length);
    buffers_.clear();
    sys_.close(fd_);
    fd_ = -1;
  }

  NextStatus lose(const std::string& why) {
    close_device();
    warning_ = label() + ": device lost: " + why;
    ++stats_.device_lost;
    last_attempt_ = std::chrono::steady_clock::now();
    return NextStatus::kDeviceLost;
  }

  NextStatus reconnect() {
    if (!pending_loss_.empty()) {
      std::string why = std::move(pending_loss_);
      pending_loss_.clear();
      fd_ = -1;
      return lose(why);
    }
    auto now = std::chrono::steady_clock::now();
    auto due = last_attempt_ + std::chrono::milliseconds(options_.reconnect_interval_ms);
    if (now < due) {
      auto wait = std::min(due - now, std::chrono::steady_clock::duration(std::chrono::milliseconds(options_.poll_timeout_ms)));
      std::this_thread::sleep_for(wait);
      if (std::chrono::steady_clock::now() < due) return NextStatus::kDeviceLost;
    }
    last_attempt_ = std::chrono::steady_clock::now();
    std::string why;
    if (!open_device(&why, width_, height_)) return NextStatus::kDeviceLost;
    ++stats_.reconnects;
    warning_ = label() + ": device back";
    return NextStatus::kNoFrame;
  }

  std::string path_;
  SourceOptions options_;
  V4l2Syscalls sys_;
  int fd_ = -1;
  bool streaming_ = false, failed_ = false;
  v4l2_format format_{};
  std::vector<Buffer> buffers_;
  int width_ = 0, height_ = 0;
  int64_t index_ = 0;
  bool have_sequence_ = false;
  uint32_t last_sequence_ = 0;
  std::string pending_loss_;
  std::chrono::steady_clock::time_point last_attempt_{};
};

}  // namespace

std::unique_ptr<FrameSource> open_v4l2_source(const std::string& path, const SourceOptions& options,
                                              const V4l2Syscalls* syscalls) {
  return std::make_unique<V4l2Source>(path, options, syscalls ? *syscalls : real_v4l2_syscalls());
}

}  // namespace dp::platform
