#include "platform/oni_file_source.h"

#include <vector>

#include "platform/oni_codec.h"
#include "platform/oni_container.h"
#include "tools/common/error.h"

namespace dp::platform {

using tools::fail;

namespace {

class OniFileSource final : public FrameSource {
 public:
  explicit OniFileSource(const std::string& path) : label_("oni:" + path), file_(path, label_) {
    info_ = check_oni_bytes(file_.data(), file_.size(), label_, &frames_);
    if (!info_.width)
      fail(label_ + ": not a readable OpenNI2 recording (the depth stream has no xnMapOutputMode: no resolution)");
    own_ = info_.has_fov ? intrinsics_from_fov(info_.width, info_.height, float(info_.horizontal_fov),
                                               float(info_.vertical_fov))
                         : kinect_v1_intrinsics(info_.width, info_.height);
  }
  int width() const override { return info_.width; }
  int height() const override { return info_.height; }
  CameraIntrinsics intrinsics() const override { return resolve(own_); }
  int64_t frame_count() const override { return int64_t(frames_.size()); }

  NextStatus next(uint16_t* depth_mm, FrameInfo* info) override {
    const size_t pixels = size_t(info_.width) * size_t(info_.height);
    while (position_ < frames_.size()) {
      const size_t index = position_++;
      const OniFrameRecord& f = frames_[index];
      OniDecodeProblem problem;
      if (!decode_oni_depth(info_.codec, file_.data() + f.payload_offset, f.payload_bytes, depth_mm, pixels, &problem)) {
        // Reported in file bytes, as the container's messages are.
        warning_ = label_ + ": frame " + std::to_string(index) + " is corrupt (" + oni_codec_name(info_.codec) + " " +
                   describe(problem, f.payload_offset) + "; frame skipped)";
        ++stats_.corrupt_frames;
        continue;
      }
      if (info_.pixel_format == kOniPixelFormatDepth100um)
        for (size_t p = 0; p < pixels; ++p) depth_mm[p] = uint16_t((depth_mm[p] + 5) / 10);
      info->index = int64_t(index);
      info->timestamp_us = f.timestamp_us;
      ++stats_.frames;
      return NextStatus::kFrame;
    }
    return NextStatus::kEnd;
  }
  bool rewind() override {
    position_ = 0;
    return true;
  }

 private:
  std::string label_;
  MappedOniFile file_;
  OniContainerSummary info_;
  std::vector<OniFrameRecord> frames_;
  CameraIntrinsics own_{};
  size_t position_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> open_oni_source(const std::string& path) { return std::make_unique<OniFileSource>(path); }

}  // namespace dp::platform
