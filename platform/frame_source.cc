#include "platform/frame_source.h"

#include <fcntl.h>
#include <glob.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "platform/oni_file_source.h"
#include "platform/openni_source.h"
#include "platform/v4l2_source.h"
#include "tools/common/dataset.h"
#include "tools/common/error.h"
#include "tools/common/png_io.h"

namespace dp::platform {

using tools::fail;

const char* next_status_name(NextStatus status) {
  switch (status) {
    case NextStatus::kFrame: return "frame";
    case NextStatus::kEnd: return "end";
    case NextStatus::kNoFrame: return "no frame";
    case NextStatus::kDeviceLost: return "device lost";
    case NextStatus::kError: return "error";
  }
  return "?";
}

CameraIntrinsics kinect_v1_intrinsics(int width, int height) {
  // 525 px is the Kinect v1 depth focal length at 640x480; scale it with the width.
  float f = 525.0f * float(width) / 640.0f;
  return CameraIntrinsics{f, f, (float(width) - 1.0f) / 2.0f, (float(height) - 1.0f) / 2.0f};
}

CameraIntrinsics intrinsics_from_fov(int width, int height, float hfov, float vfov) {
  if (!(hfov > 0.01f && hfov < 3.1f) || !(vfov > 0.01f && vfov < 3.1f)) return kinect_v1_intrinsics(width, height);
  return CameraIntrinsics{float(width) / (2.0f * std::tan(hfov / 2.0f)),
                          float(height) / (2.0f * std::tan(vfov / 2.0f)), (float(width) - 1.0f) / 2.0f,
                          (float(height) - 1.0f) / 2.0f};
}

void parse_size(const std::string& text, const std::string& what, int* width, int* height) {
  int w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w < 1 || h < 1 ||
      w > blob::kMaxFrameDimension || h > blob::kMaxFrameDimension)
    fail(what + ": bad frame size '" + text + "' (want WxH, e.g. 640x480, each 1.." +
         std::to_string(blob::kMaxFrameDimension) + ")");
  *width = w;
  *height = h;
}

NextStatus IndexedFileSource::next(uint16_t* depth_mm, FrameInfo* info) {
  while (position_ < count_) {
    const size_t index = position_++;
    uint64_t timestamp_us = 0;
    if (!read_frame(index, depth_mm, &timestamp_us, &warning_)) {
      ++stats_.corrupt_frames;
      continue;
    }
    info->index = int64_t(index);
    info->timestamp_us = timestamp_us;
    ++stats_.frames;
    return NextStatus::kFrame;
  }
  return NextStatus::kEnd;
}

namespace {

constexpr uint64_t kFilePeriodUs = 33333;  // files without timestamps play as 30 frames/s

class RawSource final : public IndexedFileSource {
 public:
  RawSource(std::vector<std::string> files, int width, int height)
      : IndexedFileSource(files.size()), files_(std::move(files)), width_(width), height_(height) {}
  int width() const override { return width_; }
  int height() const override { return height_; }
  CameraIntrinsics intrinsics() const override { return resolve(kinect_v1_intrinsics(width_, height_)); }

 private:
  bool read_frame(size_t index, uint16_t* depth_mm, uint64_t* timestamp_us, std::string* why) override {
    const size_t want = size_t(width_) * size_t(height_) * 2;
    const std::string& path = files_[index];
    // Plain system calls: no stdio buffer is allocated per frame.
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
      *why = path + ": cannot open (frame skipped)";
      return false;
    }
    size_t got = 0;
    auto* bytes = reinterpret_cast<uint8_t*>(depth_mm);
    while (got < want) {
      const ssize_t n = ::read(fd, bytes + got, want - got);
      if (n <= 0) break;
      got += size_t(n);
    }
    uint8_t extra;
    const bool longer = got == want && ::read(fd, &extra, 1) > 0;
    ::close(fd);
    if (got != want || longer) {
      *why = path + ": not " + std::to_string(width_) + "x" + std::to_string(height_) + " uint16 depth (" +
             (got < want ? "too short" : "too long") + ", frame skipped)";
      return false;
    }
    // Files are little endian, as is every host we build for (x86-64).
    *timestamp_us = uint64_t(index) * kFilePeriodUs;
    return true;
  }

  std::vector<std::string> files_;
  int width_, height_;
};

class DatasetSource final : public IndexedFileSource {
 public:
  explicit DatasetSource(tools::Dataset dataset)
      : IndexedFileSource(dataset.frames.size()), dataset_(std::move(dataset)) {
    const auto& m = dataset_.meta;
    own_ = CameraIntrinsics{float(m.fx), float(m.fy), float(m.cx), float(m.cy)};
  }
  int width() const override { return dataset_.meta.width; }
  int height() const override { return dataset_.meta.height; }
  CameraIntrinsics intrinsics() const override { return resolve(own_); }

 private:
  bool read_frame(size_t index, uint16_t* depth_mm, uint64_t* timestamp_us, std::string* why) override {
    try {
      // Dataset::load_depth checks the PNG's presence, format and size against meta.json.
      tools::ImageU16 image = dataset_.load_depth(index);
      std::memcpy(depth_mm, image.pixels.data(), image.pixels.size() * sizeof(uint16_t));
    } catch (const std::exception& e) {
      *why = std::string(e.what()) + " (frame skipped)";
      return false;
    }
    *timestamp_us = uint64_t(index) * kFilePeriodUs;
    return true;
  }

  tools::Dataset dataset_;
  CameraIntrinsics own_{};
};

class SubsampledSource final : public FrameSource {
 public:
  SubsampledSource(std::unique_ptr<FrameSource> inner, int factor)
      : inner_(std::move(inner)), factor_(factor), full_(size_t(inner_->width()) * size_t(inner_->height())) {}
  int width() const override { return inner_->width() / factor_; }
  int height() const override { return inner_->height() / factor_; }
  CameraIntrinsics intrinsics() const override {
    const CameraIntrinsics k = inner_->intrinsics();
    const float f = float(factor_);
    return resolve(CameraIntrinsics{k.fx / f, k.fy / f, k.cx / f, k.cy / f});
  }
  bool live() const override { return inner_->live(); }
  int64_t frame_count() const override { return inner_->frame_count(); }
  NextStatus next(uint16_t* depth_mm, FrameInfo* info) override {
    const NextStatus status = inner_->next(full_.data(), info);
    stats_ = inner_->stats();
    warning_ = inner_->last_warning();
    error_ = inner_->last_error();
    if (status != NextStatus::kFrame) return status;
    const int w = width(), h = height(), full_width = inner_->width();
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        depth_mm[size_t(y) * w + x] = full_[size_t(y) * factor_ * full_width + size_t(x) * factor_];
    return status;
  }
  bool rewind() override { return inner_->rewind(); }

 private:
  std::unique_ptr<FrameSource> inner_;
  int factor_;
  std::vector<uint16_t> full_;  // one frame of inner's, allocated once
};

}  // namespace

std::unique_ptr<FrameSource> subsample_source(std::unique_ptr<FrameSource> inner, int factor) {
  if (factor < 1 || factor > kMaxSubsample)
    fail("subsample factor " + std::to_string(factor) + " outside 1.." + std::to_string(kMaxSubsample));
  if (inner->width() / factor < 1 || inner->height() / factor < 1)
    fail("subsample factor " + std::to_string(factor) + " leaves no pixel of a " + std::to_string(inner->width()) + "x" +
         std::to_string(inner->height()) + " frame");
  if (factor == 1) return inner;
  return std::make_unique<SubsampledSource>(std::move(inner), factor);
}

std::unique_ptr<FrameSource> open_raw_source(const std::string& glob_pattern, int width, int height) {
  glob_t g{};
  int rc = ::glob(glob_pattern.c_str(), 0, nullptr, &g);
  std::vector<std::string> files;
  if (rc == 0)
    for (size_t i = 0; i < g.gl_pathc; ++i) files.emplace_back(g.gl_pathv[i]);
  globfree(&g);
  if (files.empty()) fail("raw source: no file matches '" + glob_pattern + "'");
  std::sort(files.begin(), files.end());
  // A source whose every file has the wrong size is a wrong-resolution mistake, not a corrupt
  // frame: say so up front instead of skipping everything.
  const off_t want = off_t(width) * height * 2;
  struct stat st{};
  if (::stat(files[0].c_str(), &st) == 0 && st.st_size != want) {
    bool all_wrong = true;
    for (const auto& f : files)
      if (::stat(f.c_str(), &st) == 0 && st.st_size == want) { all_wrong = false; break; }
    if (all_wrong)
      fail("raw source: " + files[0] + " has " + std::to_string(st.st_size) + " bytes, not " +
           std::to_string(width) + "x" + std::to_string(height) + "x2 = " + std::to_string(want) +
           " (wrong resolution?)");
  }
  return std::make_unique<RawSource>(std::move(files), width, height);
}

std::unique_ptr<FrameSource> open_dataset_source(const std::string& dir) {
  tools::Dataset dataset = tools::open_dataset(dir);
  const auto& m = dataset.meta;
  if (m.width < 1 || m.height < 1 || m.width > blob::kMaxFrameDimension || m.height > blob::kMaxFrameDimension)
    fail("dataset " + dir + ": bad frame size " + std::to_string(m.width) + "x" + std::to_string(m.height));
  if (!(m.fx > 0) || !(m.fy > 0)) fail("dataset " + dir + ": meta.json has no positive fx/fy");
  if (dataset.frames.empty()) fail("dataset " + dir + ": frames.jsonl lists no frame");
  return std::make_unique<DatasetSource>(std::move(dataset));
}

std::unique_ptr<FrameSource> open_source(const std::string& spec, const SourceOptions& options) {
  auto colon = spec.find(':');
  std::string kind = spec.substr(0, colon);
  std::string rest = colon == std::string::npos ? std::string() : spec.substr(colon + 1);
  std::unique_ptr<FrameSource> source;
  if (kind == "raw") {
    auto last = rest.rfind(':');
    if (last == std::string::npos || last == 0)
      fail("source '" + spec + "': want raw:GLOB:WxH (e.g. raw:frames/*.raw:640x480)");
    int w = 0, h = 0;
    parse_size(rest.substr(last + 1), "source '" + spec + "'", &w, &h);
    source = open_raw_source(rest.substr(0, last), w, h);
  } else if (kind == "dataset") {
    if (rest.empty()) fail("source '" + spec + "': want dataset:DIR");
    source = open_dataset_source(rest);
  } else if (kind == "oni") {
    if (rest.empty()) fail("source '" + spec + "': want oni:FILE");
    source = open_oni_source(rest);
  } else if (kind == "openni") {
    source = open_openni_device_source(rest, options);
  } else if (kind == "v4l2") {
    if (rest.empty()) fail("source '" + spec + "': want v4l2:/dev/videoN");
    source = open_v4l2_source(rest, options);
  } else {
    fail("unknown source '" + spec + "' (want raw:GLOB:WxH, dataset:DIR, oni:FILE, openni[:URI] or v4l2:/dev/videoN)");
  }
  if (options.has_intrinsics) source->set_intrinsics_override(options.intrinsics);
  return source;
}

}  // namespace dp::platform
