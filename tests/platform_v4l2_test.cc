// V4L2 capture logic against a fake device behind the system-call table.
#include <errno.h>
#include <gtest/gtest.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <cstring>
#include <deque>
#include <map>

#include "platform/v4l2_source.h"
#include "tools/common/error.h"

using namespace dp;
using namespace dp::platform;

namespace {

constexpr uint32_t kZ16 = v4l2_fourcc('Z', '1', '6', ' ');
constexpr uint32_t kY16 = v4l2_fourcc('Y', '1', '6', ' ');
constexpr uint32_t kYUYV = v4l2_fourcc('Y', 'U', 'Y', 'V');
constexpr uint32_t kMJPG = v4l2_fourcc('M', 'J', 'P', 'G');

// An in-memory V4L2 capture device with mmap buffers.
struct FakeDevice {
  bool exists = true;       // the device node is there
  bool unplugged = false;   // the open handle is dead (ENODEV)
  std::vector<uint32_t> formats = {kYUYV, kY16, kZ16};
  uint32_t width = 8, height = 4, stride = 24;  // bytesperline padded beyond width·2 = 16
  uint32_t current_format = kYUYV;
  bool streaming = false;
  int open_count = 0, close_count = 0, unmapped = 0;
  std::vector<std::vector<uint8_t>> buffers;
  std::deque<uint32_t> queued;
  std::deque<std::vector<uint16_t>> pending;  // frames the "sensor" will produce
  uint32_t sequence = 0;
  uint32_t sequence_step = 1;                  // >1 simulates frames the driver dropped
  bool short_next = false;

  std::vector<uint16_t> frame(uint16_t base) const {
    std::vector<uint16_t> f(size_t(width) * height);
    for (size_t i = 0; i < f.size(); ++i) f[i] = uint16_t(base + i);
    return f;
  }

  int ioctl(unsigned long request, void* arg) {
    if (unplugged) {
      errno = ENODEV;
      return -1;
    }
    switch (request) {
      case VIDIOC_QUERYCAP: {
        auto* cap = static_cast<v4l2_capability*>(arg);
        std::memset(cap, 0, sizeof *cap);
        cap->capabilities = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_DEVICE_CAPS;
        cap->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
        return 0;
      }
      case VIDIOC_ENUM_FMT: {
        auto* d = static_cast<v4l2_fmtdesc*>(arg);
        if (d->index >= formats.size()) {
          errno = EINVAL;
          return -1;
        }
        d->pixelformat = formats[d->index];
        return 0;
      }
      case VIDIOC_G_FMT:
      case VIDIOC_S_FMT: {
        auto* f = static_cast<v4l2_format*>(arg);
        if (request == VIDIOC_S_FMT) {
          bool known = false;
          for (uint32_t x : formats) known |= x == f->fmt.pix.pixelformat;
          if (known) current_format = f->fmt.pix.pixelformat;
        }
        // The device has one size: it answers with it whatever was asked.
        f->fmt.pix.width = width;
        f->fmt.pix.height = height;
        f->fmt.pix.pixelformat = current_format;
        f->fmt.pix.bytesperline = stride;
        f->fmt.pix.sizeimage = stride * height;
        return 0;
      }
      case VIDIOC_REQBUFS: {
        auto* r = static_cast<v4l2_requestbuffers*>(arg);
        r->count = std::min<uint32_t>(r->count, 3);
        buffers.assign(r->count, std::vector<uint8_t>(size_t(stride) * height, 0xEE));
        return 0;
      }
      case VIDIOC_QUERYBUF: {
        auto* b = static_cast<v4l2_buffer*>(arg);
        if (b->index >= buffers.size()) {
          errno = EINVAL;
          return -1;
        }
        b->length = uint32_t(buffers[b->index].size());
        b->m.offset = b->index * 4096;
        return 0;
      }
      case VIDIOC_QBUF:
        queued.push_back(static_cast<v4l2_buffer*>(arg)->index);
        return 0;
      case VIDIOC_DQBUF: {
        if (!streaming || queued.empty() || pending.empty()) {
          errno = EAGAIN;
          return -1;
        }
        auto* b = static_cast<v4l2_buffer*>(arg);
        const uint32_t index = queued.front();
        queued.pop_front();
        std::vector<uint16_t> f = std::move(pending.front());
        pending.pop_front();
        for (uint32_t y = 0; y < height; ++y)
          std::memcpy(buffers[index].data() + size_t(y) * stride, f.data() + size_t(y) * width, width * 2);
        b->index = index;
        b->bytesused = short_next ? stride * height / 2 : stride * height;
        short_next = false;
        b->flags = 0;
        b->sequence = sequence;
        sequence += sequence_step;
        b->timestamp.tv_sec = 1;
        b->timestamp.tv_usec = long(b->sequence) * 1000;
        return 0;
      }
      case VIDIOC_STREAMON: streaming = true; return 0;
      case VIDIOC_STREAMOFF: streaming = false; return 0;
      default: errno = ENOTTY; return -1;
    }
  }

  V4l2Syscalls table() {
    V4l2Syscalls s;
    s.open = [this](const char*, int) {
      if (!exists) {
        errno = ENOENT;
        return -1;
      }
      unplugged = false;
      queued.clear();
      streaming = false;
      ++open_count;
      return 7;
    };
    s.close = [this](int) {
      ++close_count;
      return 0;
    };
    s.ioctl = [this](int, unsigned long request, void* arg) { return ioctl(request, arg); };
    s.mmap = [this](void*, size_t length, int, int, int, off_t offset) -> void* {
      const size_t index = size_t(offset) / 4096;
      if (index >= buffers.size() || length != buffers[index].size()) return MAP_FAILED;
      return buffers[index].data();
    };
    s.munmap = [this](void*, size_t) {
      ++unmapped;
      return 0;
    };
    s.poll = [this](pollfd* fds, nfds_t, int) {
      if (unplugged) {
        fds[0].revents = POLLERR;
        return 1;
      }
      fds[0].revents = (streaming && !queued.empty() && !pending.empty()) ? POLLIN : 0;
      return fds[0].revents ? 1 : 0;
    };
    return s;
  }
};

std::string open_error(FakeDevice& dev, const SourceOptions& o = {}) {
  V4l2Syscalls s = dev.table();
  try {
    open_v4l2_source("/dev/video9", o, &s);
  } catch (const tools::ToolError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(PlatformV4l2, CapturesZ16WithPaddedRowsAndCountsDrops) {
  FakeDevice dev;
  V4l2Syscalls s = dev.table();
  auto source = open_v4l2_source("/dev/video9", {}, &s);
  EXPECT_EQ(dev.current_format, kZ16) << "Z16 is preferred over Y16";
  ASSERT_EQ(source->width(), 8);
  ASSERT_EQ(source->height(), 4);
  EXPECT_TRUE(source->live());
  EXPECT_TRUE(dev.streaming);
  EXPECT_EQ(dev.queued.size(), 3u);  // every buffer queued before streaming

  std::vector<uint16_t> depth(32);
  FrameInfo info;
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kNoFrame);  // nothing yet: poll timeout
  dev.pending.push_back(dev.frame(100));
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(depth, dev.frame(100)) << "rows must be read at bytesperline, not width·2";
  EXPECT_EQ(info.index, 0);
  EXPECT_EQ(info.timestamp_us, 1000000u);
  EXPECT_EQ(dev.queued.size(), 3u) << "the buffer goes back to the driver";

  dev.sequence_step = 3;  // the driver drops two frames after the next one
  for (uint16_t base : {200, 300, 400}) dev.pending.push_back(dev.frame(base));
  for (uint16_t base : {200, 300, 400}) {
    ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
    EXPECT_EQ(depth, dev.frame(base));
  }
  EXPECT_EQ(source->stats().frames, 4);
  EXPECT_EQ(source->stats().dropped_frames, 4);
  source.reset();
  EXPECT_FALSE(dev.streaming);
  EXPECT_EQ(dev.unmapped, 3);
  EXPECT_EQ(dev.close_count, 1);
}

TEST(PlatformV4l2, AcceptsY16AndRefusesDevicesWithoutDepth) {
  FakeDevice y16;
  y16.formats = {kYUYV, kY16};
  V4l2Syscalls s = y16.table();
  auto source = open_v4l2_source("/dev/video9", {}, &s);
  EXPECT_EQ(y16.current_format, kY16);

  FakeDevice colour;
  colour.formats = {kYUYV, kMJPG};
  const std::string why = open_error(colour);
  EXPECT_NE(why.find("no depth format"), std::string::npos) << why;
  EXPECT_NE(why.find("YUYV, MJPG"), std::string::npos) << why;
  EXPECT_NE(why.find("/dev/video9"), std::string::npos) << why;
  EXPECT_EQ(colour.close_count, 1) << "the device is closed after a refused open";

  FakeDevice missing;
  missing.exists = false;
  EXPECT_NE(open_error(missing).find("no such device"), std::string::npos);

  FakeDevice fixed;
  SourceOptions want;
  want.v4l2_width = 640;
  want.v4l2_height = 480;
  const std::string refused = open_error(fixed, want);
  EXPECT_NE(refused.find("refused 640x480"), std::string::npos) << refused;
  EXPECT_NE(refused.find("offers 8x4"), std::string::npos) << refused;
}

TEST(PlatformV4l2, ShortBufferIsSkippedAndCounted) {
  FakeDevice dev;
  V4l2Syscalls s = dev.table();
  auto source = open_v4l2_source("/dev/video9", {}, &s);
  std::vector<uint16_t> depth(32, 7);
  FrameInfo info;
  dev.short_next = true;
  dev.pending.push_back(dev.frame(1));
  dev.pending.push_back(dev.frame(500));
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kNoFrame);
  EXPECT_EQ(source->stats().corrupt_frames, 1);
  EXPECT_NE(source->last_warning().find("short"), std::string::npos);
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(depth, dev.frame(500));
  EXPECT_EQ(dev.queued.size(), 3u);
}

TEST(PlatformV4l2, UnplugReportsLostThenReopensWhenBack) {
  FakeDevice dev;
  V4l2Syscalls s = dev.table();
  SourceOptions o;
  o.poll_timeout_ms = 1;
  o.reconnect_interval_ms = 1;
  auto source = open_v4l2_source("/dev/video9", o, &s);
  std::vector<uint16_t> depth(32);
  FrameInfo info;
  dev.pending.push_back(dev.frame(10));
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);

  dev.unplugged = true;
  dev.exists = false;
  EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kDeviceLost);
  EXPECT_EQ(source->stats().device_lost, 1);
  EXPECT_EQ(dev.close_count, 1);
  EXPECT_EQ(dev.unmapped, 3);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(source->next(depth.data(), &info), NextStatus::kDeviceLost);
  EXPECT_EQ(source->stats().device_lost, 1) << "one loss, however long it lasts";

  dev.exists = true;
  NextStatus st = NextStatus::kDeviceLost;
  for (int i = 0; i < 100 && st == NextStatus::kDeviceLost; ++i) st = source->next(depth.data(), &info);
  EXPECT_EQ(st, NextStatus::kNoFrame);  // reopened, nothing captured yet
  EXPECT_EQ(dev.open_count, 2);
  EXPECT_EQ(source->stats().reconnects, 1);
  dev.pending.push_back(dev.frame(900));
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(depth, dev.frame(900));
  EXPECT_EQ(info.index, 1);
}

TEST(PlatformV4l2, LatestOnlyHandsOverTheNewestFrame) {
  FakeDevice dev;
  V4l2Syscalls s = dev.table();
  SourceOptions o;
  o.latest_only = true;
  auto source = open_v4l2_source("/dev/video9", o, &s);
  std::vector<uint16_t> depth(32);
  FrameInfo info;
  for (uint16_t base : {10, 20, 30}) dev.pending.push_back(dev.frame(base));
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(depth, dev.frame(30)) << "the two older queued frames are not delivered late";
  EXPECT_EQ(source->stats().dropped_frames, 2);
  EXPECT_EQ(dev.queued.size(), 3u) << "every buffer back with the driver";
  dev.pending.push_back(dev.frame(40));
  ASSERT_EQ(source->next(depth.data(), &info), NextStatus::kFrame);
  EXPECT_EQ(depth, dev.frame(40));
  EXPECT_EQ(source->stats().dropped_frames, 2);
  EXPECT_EQ(info.index, 1);
}
