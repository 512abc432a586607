#include "tools/common/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>

#include "tools/common/error.h"
#include "tools/common/limits.h"

namespace dp::tools {

namespace {

std::string mib(uint64_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

// Reads exactly the size fstat reported (the file may not grow under us beyond it).
template <typename Buffer>
Buffer read_whole(const std::string& path, const char* what) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) fail(std::string("cannot open ") + what + " " + path + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int e = errno;
    ::close(fd);
    fail(std::string("cannot read ") + what + " " + path + ": " + std::strerror(e));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    fail(path + ": not a regular file (a " + what + " is read whole; devices, pipes and directories are refused)");
  }
  if (uint64_t(st.st_size) > limits::kMaxInputFileBytes) {
    ::close(fd);
    fail(path + ": " + what + " of " + std::to_string(uint64_t(st.st_size)) + " bytes exceeds the limit of " +
         mib(limits::kMaxInputFileBytes) + " (tools/common/limits.h)");
  }
  Buffer out(size_t(st.st_size), 0);
  size_t got = 0;
  while (got < out.size()) {
    const ssize_t n = ::read(fd, reinterpret_cast<char*>(&out[0]) + got, out.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int e = n < 0 ? errno : 0;
      ::close(fd);
      fail(std::string("cannot read ") + what + " " + path + ": " + (e ? std::strerror(e) : "file shrank while reading"));
    }
    got += size_t(n);
  }
  ::close(fd);
  return out;
}

}  // namespace

std::vector<uint8_t> read_file_bytes(const std::string& path, const char* what) {
  return read_whole<std::vector<uint8_t>>(path, what);
}

std::string read_file_text(const std::string& path, const char* what) { return read_whole<std::string>(path, what); }

std::string temporary_path_for(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  return path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

void write_file_atomic(const std::string& path, const void* data, size_t size) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    // A device or pipe (/dev/stdout, /dev/full): nothing to rename over; write it directly and
    // report any error.
    if (S_ISDIR(st.st_mode)) fail("cannot write " + path + ": it is a directory");
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) fail("cannot open " + path + ": " + std::strerror(errno));
    errno = 0;
    const size_t n = size ? std::fwrite(data, 1, size, f) : 0;
    const bool flushed = std::fflush(f) == 0;
    const int e = errno;
    if (std::fclose(f) != 0 || !flushed || n != size) fail("cannot write " + path + ": " + std::strerror(e ? e : EIO));
    return;
  }
  const std::string tmp = temporary_path_for(path);
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) fail("cannot create " + tmp + " (for " + path + "): " + std::strerror(errno));
  errno = 0;
  const size_t n = size ? std::fwrite(data, 1, size, f) : 0;
  const bool flushed = std::fflush(f) == 0;
  const int e = errno;
  const bool closed = std::fclose(f) == 0;
  if (n != size || !flushed || !closed) {
    std::remove(tmp.c_str());
    fail("cannot write " + path + ": " + std::strerror(e ? e : EIO) + " (nothing written)");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int re = errno;
    std::remove(tmp.c_str());
    fail("cannot replace " + path + ": " + std::strerror(re));
  }
}

AtomicOutputFile::AtomicOutputFile(const std::string& path) : path_(path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    if (S_ISDIR(st.st_mode)) fail("cannot write " + path + ": it is a directory");
    file_ = std::fopen(path.c_str(), "wb");  // a device or pipe: written directly
    if (!file_) fail("cannot open " + path + ": " + std::strerror(errno));
    return;
  }
  tmp_ = temporary_path_for(path);
  file_ = std::fopen(tmp_.c_str(), "wb");
  if (!file_) fail("cannot create " + tmp_ + " (for " + path + "): " + std::strerror(errno));
}

AtomicOutputFile::~AtomicOutputFile() {
  if (file_) {
    std::fclose(file_);
    if (!tmp_.empty()) std::remove(tmp_.c_str());
  }
}

void AtomicOutputFile::write(const std::string& text) {
  if (!text.empty()) std::fwrite(text.data(), 1, text.size(), file_);
}

void AtomicOutputFile::commit() {
  if (!file_) fail("cannot write " + path_ + ": already closed");
  errno = 0;
  const bool ok = !std::ferror(file_) && std::fflush(file_) == 0;
  const int e = errno;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || !closed) {
    if (!tmp_.empty()) std::remove(tmp_.c_str());
    fail("cannot write " + path_ + ": " + std::strerror(e ? e : EIO) + (tmp_.empty() ? "" : " (nothing written)"));
  }
  if (tmp_.empty()) return;
  if (std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    const int re = errno;
    std::remove(tmp_.c_str());
    fail("cannot replace " + path_ + ": " + std::strerror(re));
  }
}

void check_output_stream(std::FILE* out, const char* name) {
  errno = 0;
  const bool flushed = std::fflush(out) == 0;
  if (!flushed || std::ferror(out)) {
    const int e = errno;
    std::clearerr(out);
    fail(std::string("cannot write to ") + name + ": " + std::strerror(e ? e : EIO));
  }
}

}  // namespace dp::tools
