// V4L2 depth capture (`v4l2:/dev/videoN`), e.g. an Intel RealSense through uvcvideo.
// mmap streaming with kV4l2BufferCount buffers; pixel format Z16 preferred, Y16 accepted (both
// read as uint16 millimetres). Every system call goes through a V4l2Syscalls table so tests can
// run the capture logic against a fake device.
//
// Errors at open (each one ToolError line naming the device): no such file, permission denied,
// not a V4L2 device, no capture/streaming capability, no depth format (lists the formats the
// device offers), requested size refused, buffers refused. While streaming: a short or
// error-flagged buffer is skipped and counted as corrupt; ENODEV/EIO (unplugged) returns
// kDeviceLost and later calls reopen the device every reconnect_interval_ms.
#pragma once
#include <poll.h>
#include <sys/types.h>

#include <cstddef>
#include <functional>
#include <memory>
#include <string>

#include "platform/frame_source.h"

namespace dp::platform {

constexpr int kV4l2BufferCount = 4;

struct V4l2Syscalls {
  std::function<int(const char* path, int flags)> open;
  std::function<int(int fd)> close;
  std::function<int(int fd, unsigned long request, void* arg)> ioctl;  // sets errno on −1
  std::function<void*(void* addr, size_t length, int prot, int flags, int fd, off_t offset)> mmap;
  std::function<int(void* addr, size_t length)> munmap;
  std::function<int(struct pollfd* fds, nfds_t count, int timeout_ms)> poll;
};

// The real system calls (open/close/ioctl/mmap/munmap/poll).
V4l2Syscalls real_v4l2_syscalls();

// `syscalls` null = the real ones. The table is copied.
std::unique_ptr<FrameSource> open_v4l2_source(const std::string& path, const SourceOptions& options,
                                              const V4l2Syscalls* syscalls = nullptr);

// "Z16 " style text for a fourcc (for messages).
std::string fourcc_text(uint32_t fourcc);

}  // namespace dp::platform
