#include "platform/arena_memory.h"

#include <sys/mman.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <utility>

#include "tools/common/error.h"

namespace dp::platform {

ArenaMemory::ArenaMemory(size_t bytes) {
  if (bytes == 0) throw tools::ToolError("arena memory: zero bytes asked for");
  const bool huge = bytes >= kHugePageBytes;
  const size_t page = huge ? kHugePageBytes : size_t(4096);
  const size_t length = (bytes + page - 1) / page * page;
  // Over-map by one huge page so that a 2 MiB-aligned range of `length` bytes lies inside; the
  // unaligned head and tail are unmapped again.
  const size_t over = huge ? length + kHugePageBytes : length;
  void* map = ::mmap(nullptr, over, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (map == MAP_FAILED)
    throw tools::ToolError("cannot map a " + std::to_string(bytes) + "-byte arena: " + std::strerror(errno));
  uint8_t* base = static_cast<uint8_t*>(map);
  if (huge) {
    const uintptr_t start = (reinterpret_cast<uintptr_t>(base) + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    uint8_t* aligned = reinterpret_cast<uint8_t*>(start);
    if (aligned > base) ::munmap(base, size_t(aligned - base));
    const size_t tail = size_t(base + over - (aligned + length));
    if (tail) ::munmap(aligned + length, tail);
    base = aligned;
    huge_page_advice_ = ::madvise(base, length, MADV_HUGEPAGE) == 0;
  }
  data_ = base;
  size_ = bytes;
  mapped_ = length;
}

ArenaMemory::~ArenaMemory() { release(); }

ArenaMemory::ArenaMemory(ArenaMemory&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)),
      size_(std::exchange(other.size_, 0)),
      mapped_(std::exchange(other.mapped_, 0)),
      huge_page_advice_(std::exchange(other.huge_page_advice_, false)) {}

ArenaMemory& ArenaMemory::operator=(ArenaMemory&& other) noexcept {
  if (this != &other) {
    release();
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    mapped_ = std::exchange(other.mapped_, 0);
    huge_page_advice_ = std::exchange(other.huge_page_advice_, false);
  }
  return *this;
}

void ArenaMemory::release() {
  if (data_) ::munmap(data_, mapped_);
  data_ = nullptr;
  size_ = mapped_ = 0;
  huge_page_advice_ = false;
}

}  // namespace dp::platform
