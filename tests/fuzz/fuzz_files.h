// Fuzz-target helper: the parsers under test read files by path, so each input is handed to them
// as an anonymous in-memory file (memfd) named by its /proc/self/fd path: no disk I/O, nothing
// left behind.
#pragma once
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <string>

namespace dp::fuzz {

class MemFile {
 public:
  MemFile(const uint8_t* data, size_t size) {
    fd_ = ::memfd_create("dp-fuzz", MFD_CLOEXEC);
    if (fd_ < 0) __builtin_trap();
    size_t done = 0;
    while (done < size) {
      const ssize_t n = ::write(fd_, data + done, size - done);
      if (n <= 0) __builtin_trap();
      done += size_t(n);
    }
  }
  ~MemFile() { ::close(fd_); }
  MemFile(const MemFile&) = delete;
  MemFile& operator=(const MemFile&) = delete;
  std::string path() const { return "/proc/self/fd/" + std::to_string(fd_); }

 private:
  int fd_ = -1;
};

// Splits an input at the first occurrence of `separator` (for parsers that read two files).
inline size_t split_at(const uint8_t* data, size_t size, const char* separator, size_t separator_size) {
  for (size_t i = 0; i + separator_size <= size; ++i) {
    size_t k = 0;
    while (k < separator_size && data[i + k] == uint8_t(separator[k])) ++k;
    if (k == separator_size) return i;
  }
  return size;
}

}  // namespace dp::fuzz
