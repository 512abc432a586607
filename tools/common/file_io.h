// Whole-file input with a size limit, atomic output, and checked standard output, for the tools.
// Every function throws ToolError naming the file (or "standard output") on failure.
#pragma once
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace dp::tools {

// The bytes of a regular file of at most limits::kMaxInputFileBytes. A missing or unreadable file,
// a directory, a device or pipe (/dev/zero: its size cannot be known in advance) and a larger file
// are refused before anything is allocated. `what` names the file's role ("blob", "PNG") in messages.
std::vector<uint8_t> read_file_bytes(const std::string& path, const char* what = "file");
std::string read_file_text(const std::string& path, const char* what = "file");

// Writes `size` bytes to `path` atomically: a temporary file in the same directory
// (path + ".tmp-<pid>-<n>"), flushed and closed with errors checked, then renamed over `path` (no
// fsync: the guarantee is against a failing or killed process, not a power cut). On
// any failure the temporary file is removed and `path` is left as it was. An existing `path` that
// is not a regular file (a device such as /dev/full, a pipe) is written directly, errors checked.
void write_file_atomic(const std::string& path, const void* data, size_t size);
inline void write_file_atomic(const std::string& path, const std::string& text) {
  write_file_atomic(path, text.data(), text.size());
}

// An output streamed over time (a per-frame log), written atomically: lines go to a temporary
// file beside `path`; commit() checks every write, flushes, closes and renames it over `path`.
// Destroyed without commit() (an error on the way), it removes the temporary file.
class AtomicOutputFile {
 public:
  explicit AtomicOutputFile(const std::string& path);  // ToolError when the directory is not writable
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;
  std::FILE* get() const { return file_; }
  void write(const std::string& text);  // errors surface at commit()
  void commit();                        // ToolError naming `path` on any failed write
  const std::string& path() const { return path_; }

 private:
  std::string path_, tmp_;
  std::FILE* file_ = nullptr;
};

// A temporary name beside `path` for an output being built (file or directory): path + ".tmp-<pid>-<n>".
std::string temporary_path_for(const std::string& path);

// Flushes `out` (stdout by default) and fails with "cannot write to <name>: <reason>" if any write
// to it failed (a full disk, a closed pipe, /dev/full). Commands call it before reporting success.
void check_output_stream(std::FILE* out = stdout, const char* name = "standard output");

}  // namespace dp::tools
