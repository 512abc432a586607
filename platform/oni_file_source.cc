#include "platform/oni_file_source.h"

#include <vector>

#include "platform/oni_codec.h"
#include "platform/oni_container.h"
#include "tools/common/error.h"

namespace dp::platform {

using tools::fail;

namespace {

class OniFileSource final : public IndexedFileSource {
 public:
  OniFileSource(const std::string& path, std::unique_ptr<MappedOniFile> file, std::vector<OniFrameRecord> frames,
                const OniContainerSummary& info)
      : IndexedFileSource(frames.size()), label_("oni:" + path), file_(std::move(file)), info_(info),
        frames_(std::move(frames)) {
    own_ = info_.has_fov ? intrinsics_from_fov(info_.width, info_.height, float(info_.horizontal_fov),
                                               float(info_.vertical_fov))
                         : kinect_v1_intrinsics(info_.width, info_.height);
  }
  int width() const override { return info_.width; }
  int height() const override { return info_.height; }
  CameraIntrinsics intrinsics() const override { return resolve(own_); }

 private:
  bool read_frame(size_t index, uint16_t* depth_mm, uint64_t* timestamp_us, std::string* why) override {
    const size_t pixels = size_t(info_.width) * size_t(info_.height);
    const OniFrameRecord& f = frames_[index];
    // A changed payload byte that still decodes (a different depth value) is caught here, by the
    // integrity trailer's CRC-32, before the codec sees it.
    const std::string mismatch = oni_payload_crc_mismatch(file_->data(), info_, f, index);
    if (!mismatch.empty()) {
      *why = label_ + ": frame " + std::to_string(index) + " is corrupt (" + mismatch + "; frame skipped)";
      return false;
    }
    OniDecodeProblem problem;
    if (!decode_oni_depth(info_.codec, file_->data() + f.payload_offset, f.payload_bytes, depth_mm, pixels, &problem)) {
      // Reported in file bytes, as the container's messages are.
      *why = label_ + ": frame " + std::to_string(index) + " is corrupt (" + oni_codec_name(info_.codec) + " " +
             describe(problem, f.payload_offset) + "; frame skipped)";
      return false;
    }
    if (info_.pixel_format == kOniPixelFormatDepth100um)
      for (size_t p = 0; p < pixels; ++p) depth_mm[p] = uint16_t((depth_mm[p] + 5) / 10);
    *timestamp_us = f.timestamp_us;
    return true;
  }

  std::string label_;
  std::unique_ptr<MappedOniFile> file_;
  OniContainerSummary info_;
  std::vector<OniFrameRecord> frames_;
  CameraIntrinsics own_{};
};

}  // namespace

std::unique_ptr<FrameSource> open_oni_source(const std::string& path) {
  const std::string label = "oni:" + path;
  auto file = std::make_unique<MappedOniFile>(path, label);
  std::vector<OniFrameRecord> frames;
  const OniContainerSummary info = check_oni_bytes(file->data(), file->size(), label, &frames);
  if (!info.width)
    fail(label + ": not a readable OpenNI2 recording (the depth stream has no xnMapOutputMode: no resolution)");
  return std::make_unique<OniFileSource>(path, std::move(file), std::move(frames), info);
}

}  // namespace dp::platform
