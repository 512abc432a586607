#include "platform/oni_recorder.h"

#include <OpenNI.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <chrono>
#include <cstring>
#include <thread>
#include <vector>

#include "platform/oni_container.h"
#include "platform/oni_file_source.h"
#include "platform/openni_driver/feed_abi.h"
#include "platform/openni_source.h"
#include "tools/common/error.h"

namespace dp::platform {

using tools::fail;

void zero_frame_border(uint16_t* depth, int width, int height) {
  if (width < 1 || height < 1) return;
  std::memset(depth, 0, size_t(width) * 2);
  std::memset(depth + size_t(height - 1) * width, 0, size_t(width) * 2);
  for (int y = 0; y < height; ++y) {
    depth[size_t(y) * width] = 0;
    depth[size_t(y) * width + width - 1] = 0;
  }
}

namespace {

uint32_t frame_crc(const uint16_t* depth, size_t pixels) {
  return uint32_t(::crc32(0L, reinterpret_cast<const Bytef*>(depth), uInt(pixels * 2)));
}

int64_t file_size(const std::string& path) {
  struct stat st{};
  return ::stat(path.c_str(), &st) == 0 ? int64_t(st.st_size) : -1;
}

// The recorder thread writes the file header, the stream's records (attach) and its start records
// as it handles start(); once the file has stopped growing for a while it records what arrives.
void wait_until_recorder_settles(const std::string& path) {
  using clock = std::chrono::steady_clock;
  const auto give_up = clock::now() + std::chrono::seconds(3);
  int64_t last = -1;
  auto stable_since = clock::now();
  while (clock::now() < give_up) {
    int64_t size = file_size(path);
    if (size != last) {
      last = size;
      stable_since = clock::now();
    } else if (size > 0 && clock::now() - stable_since > std::chrono::milliseconds(80)) {
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

// OpenNI2 2.2's recorder ends a recording with ftruncate(file, 2 × its length) (seen with strace:
// the file position is 109988 after the end record, then ftruncate(fd, 219976)), so every file
// it writes is twice its content, the second half zeros. Cut the file back to its end record
// (check_oni_bytes has checked that only zeros follow it), then append depthpose's integrity
// trailer (platform/oni_container.h): the CRC-32 of every depth payload as stored, so a reader
// notices a changed byte that still decodes. OpenNI2's player stops at the end record and ignores it.
void finish_recording(const std::string& path) {
  const std::string label = "oni:" + path;
  std::vector<uint8_t> trailer;
  uint64_t records_end = 0, file_bytes = 0;
  {
    const MappedOniFile file(path, label);
    std::vector<OniFrameRecord> frames;
    const OniContainerSummary s = check_oni_bytes(file.data(), file.size(), label, &frames);
    if (s.integrity_trailer) fail("record: " + path + " already holds an integrity trailer (OpenNI2 wrote it?)");
    trailer = oni_integrity_trailer(file.data(), frames);
    records_end = s.records_end;
    file_bytes = s.file_bytes;
  }
  if (records_end < file_bytes && ::truncate(path.c_str(), off_t(records_end)) != 0)
    fail("record: cannot trim " + path + " to its " + std::to_string(records_end) + " bytes (" + std::strerror(errno) +
         ")");
  FILE* f = std::fopen(path.c_str(), "ab");
  if (!f) fail("record: cannot append the integrity trailer to " + path + " (" + std::strerror(errno) + ")");
  const bool written = std::fwrite(trailer.data(), 1, trailer.size(), f) == trailer.size();
  if (std::fclose(f) != 0 || !written)
    fail("record: cannot append the integrity trailer to " + path + " (" + std::strerror(errno) + ")");
}

struct Attempt {
  int64_t served = 0;            // frames the driver raised to OpenNI2
  int64_t corrupt_skipped = 0;
  std::vector<uint32_t> crcs;    // of the served frames
};

Attempt record_once(FrameSource& source, const std::string& out_path, const RecordOptions& options) {
  const int w = source.width(), h = source.height();
  std::atomic<bool> gate{false};
  std::string source_error;
  Attempt attempt;
  int64_t handed = 0;
  auto next = [&](uint16_t* depth, uint64_t* timestamp_us) -> int {
    if (!gate.load()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      return kDpFeedAgain;
    }
    if (options.max_frames >= 0 && handed >= options.max_frames) return kDpFeedEnd;
    FrameInfo info;
    switch (source.next(depth, &info)) {
      case NextStatus::kFrame:
        if (options.zero_border) zero_frame_border(depth, w, h);
        attempt.crcs.push_back(frame_crc(depth, size_t(w) * h));
        *timestamp_us = info.timestamp_us;
        ++handed;
        return kDpFeedFrame;
      case NextStatus::kEnd: return kDpFeedEnd;
      case NextStatus::kNoFrame:
      case NextStatus::kDeviceLost: return kDpFeedAgain;
      case NextStatus::kError:
        source_error = source.last_error();
        return kDpFeedEnd;
    }
    return kDpFeedEnd;
  };
  Feed feed("record-" + std::to_string(::getpid()), w, h, options.fps, source.intrinsics(), next);
  {
    openni::Device device;
    if (device.open(feed.uri().c_str()) != openni::STATUS_OK)
      fail("record: cannot open depthpose's OpenNI2 feed device (" + std::string(openni::OpenNI::getExtendedError()) + ")");
    openni::VideoStream stream;
    if (stream.create(device, openni::SENSOR_DEPTH) != openni::STATUS_OK) fail("record: cannot create the feed's depth stream");
    // OpenNI2 2.2 hangs or crashes when Recorder::create() fails (its destructor joins a thread
    // it never started): make sure the file can be written before asking it.
    if (FILE* probe = std::fopen(out_path.c_str(), "wb")) {
      std::fclose(probe);
    } else {
      stream.destroy();
      fail("record: cannot write " + out_path + " (" + std::strerror(errno) + ")");
    }
    openni::Recorder recorder;
    if (recorder.create(out_path.c_str()) != openni::STATUS_OK) {
      stream.destroy();
      fail("record: cannot write " + out_path);
    }
    recorder.attach(stream, false);
    if (stream.start() != openni::STATUS_OK) fail("record: cannot start the feed's depth stream");
    recorder.start();
    wait_until_recorder_settles(out_path);
    gate = true;
    while (!feed.idle()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    attempt.served = feed.frames_served();
    // The recorder writes what it has queued before its thread ends in destroy().
    recorder.stop();
    recorder.destroy();
    stream.stop();
    stream.destroy();
    device.close();
  }
  if (!source_error.empty()) fail("record: the source failed: " + source_error);
  attempt.corrupt_skipped = source.stats().corrupt_frames;
  return attempt;
}

void verify(const std::string& path, const std::string& out_path, const SourceFactory& reopen,
            const Attempt& attempt, int64_t in_file, const RecordOptions& options, RecordReport* report);

}  // namespace

RecordReport record_oni(const SourceFactory& reopen, bool replayable, const std::string& out_path,
                        const RecordOptions& options) {
  ensure_openni();
  RecordReport report;
  Attempt attempt;
  int64_t in_file = 0;
  const int attempts = replayable ? std::max(1, options.attempts) : 1;
  // OpenNI2 keeps a device per file URI for the life of the process: every attempt writes and
  // checks a file name never opened before, renamed to out_path once verified.
  static std::atomic<int> serial{0};
  std::string path;
  for (int a = 1; a <= attempts; ++a) {
    if (!path.empty()) ::unlink(path.c_str());
    path = out_path + ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(serial++);
    if (FILE* probe = std::fopen(path.c_str(), "wb")) {
      std::fclose(probe);
    } else {
      fail("record: cannot write " + out_path + " (" + std::strerror(errno) + ")");
    }
    try {
      std::unique_ptr<FrameSource> source = reopen();
      report.width = source->width();
      report.height = source->height();
      attempt = record_once(*source, path, options);
      report.attempts = a;
      if (attempt.served == 0) fail("record: the source delivered no frame; nothing recorded");
      finish_recording(path);
      in_file = open_openni_oni_source(path)->frame_count();  // OpenNI2 itself reads the file
    } catch (...) {
      ::unlink(path.c_str());  // a failed attempt leaves no .partial file behind
      throw;
    }
    if (in_file == attempt.served) break;
    if (a == attempts) {
      ::unlink(path.c_str());
      fail("record: " + out_path + " would hold " + std::to_string(in_file) + " frames but " +
           std::to_string(attempt.served) + " were served (OpenNI2's recorder dropped frames)");
    }
  }
  try {
    verify(path, out_path, replayable ? reopen : SourceFactory(), attempt, in_file, options, &report);
  } catch (...) {
    ::unlink(path.c_str());
    throw;
  }
  if (::rename(path.c_str(), out_path.c_str()) != 0) {
    ::unlink(path.c_str());
    fail("record: cannot write " + out_path + " (rename failed)");
  }
  report.frames_recorded = in_file;
  report.corrupt_skipped = attempt.corrupt_skipped;
  report.verified_by_pixels = replayable;
  return report;
}

namespace {

// Replays `path` and compares it with the source (reopened) or the served frames' CRCs; messages
// name `out_path`, the file the user asked for.
void verify(const std::string& path, const std::string& out_path, const SourceFactory& reopen,
            const Attempt& attempt, int64_t in_file, const RecordOptions& options, RecordReport* report) {
  // Verification: replay the file with the reader `run` uses and compare with the source frame by
  // frame.
  auto replay = open_oni_source(path);
  const int w = replay->width(), h = replay->height();
  if (w != report->width || h != report->height)
    fail("record: " + out_path + " replays at " + std::to_string(w) + "x" + std::to_string(h) + ", recorded " +
         std::to_string(report->width) + "x" + std::to_string(report->height));
  std::vector<uint16_t> recorded(size_t(w) * h), expected(size_t(w) * h);
  std::unique_ptr<FrameSource> again = reopen ? reopen() : nullptr;
  FrameInfo info;
  for (int64_t i = 0; i < in_file; ++i) {
    if (replay->next(recorded.data(), &info) != NextStatus::kFrame)
      fail("record: verification: frame " + std::to_string(i) + " of " + out_path + " cannot be read back (" +
           replay->last_error() + ")");
    if (again) {
      if (again->next(expected.data(), &info) != NextStatus::kFrame)
        fail("record: verification: the source no longer has frame " + std::to_string(i));
      if (options.zero_border) zero_frame_border(expected.data(), w, h);
      int64_t differing = 0, first = -1;
      for (size_t p = 0; p < recorded.size(); ++p)
        if (recorded[p] != expected[p]) {
          if (first < 0) first = int64_t(p);
          ++differing;
        }
      if (differing)
        fail("record: verification: frame " + std::to_string(i) + " of " + out_path + " differs from the source in " +
             std::to_string(differing) + " pixel(s), first at (" + std::to_string(first % w) + "," +
             std::to_string(first / w) + "): recorded " + std::to_string(recorded[size_t(first)]) + ", source " +
             std::to_string(expected[size_t(first)]) +
             " (OpenNI2's 16zT codec corrupts rare frames; --zero-border avoids it)");
    } else if (frame_crc(recorded.data(), recorded.size()) != attempt.crcs[size_t(i)]) {
      fail("record: verification: frame " + std::to_string(i) + " of " + out_path +
           " differs from the frame served (CRC-32 mismatch)");
    }
    ++report->frames_verified;
  }
  if (replay->next(recorded.data(), &info) != NextStatus::kEnd)
    fail("record: verification: " + out_path + " holds more frames than it says");
}

}  // namespace

}  // namespace dp::platform
