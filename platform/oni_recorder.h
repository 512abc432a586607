// Records any FrameSource into an OpenNI2 .oni file through depthpose's own OpenNI2 driver (the
// frames go through openni::Recorder exactly as a camera's would), then verifies the file: OpenNI2's
// own player must count the frames served, and depthpose's reader (platform/oni_file_source.h, what
// `run` plays) must give them back pixel for pixel. The file ends with depthpose's integrity
// trailer (platform/oni_container.h: a CRC-32 per depth payload) after OpenNI2's end record.
//
// Facts about Debian's OpenNI2 2.2.0.33 this works around:
//   - Recorder::start() only queues a message; frames raised before the recorder thread handled it
//     are dropped. We hold frames back until the file stops growing after start() and verify the
//     recorded frame count afterwards (a replayable source is recorded again on a shortfall).
//   - Depth is stored with the 16zT codec, which can corrupt the last pixels of a frame in rare
//     patterns: the recording is compared with the source pixel for pixel. `zero_border` blanks
//     the outermost pixel ring of every frame before recording, which avoids the problem.
#pragma once
#include <cstdint>
#include <functional>
#include <string>

#include "platform/frame_source.h"

namespace dp::platform {

struct RecordOptions {
  int64_t max_frames = -1;   // −1 = until the source ends
  bool zero_border = false;  // blank the outermost pixel ring before recording
  int fps = 30;              // nominal rate written into the file's video mode
  int attempts = 3;          // replayable sources: re-record on a frame-count shortfall
};

struct RecordReport {
  int64_t frames_recorded = 0;   // frames in the file
  int64_t frames_verified = 0;   // frames compared pixel for pixel (or by checksum, live sources)
  int64_t corrupt_skipped = 0;   // corrupt source frames skipped (not recorded)
  int attempts = 0;
  bool verified_by_pixels = false;  // false: live source, compared by per-frame CRC-32
  int width = 0, height = 0;
};

// Opens a fresh copy of the source (the same frames again) or returns null for live sources.
using SourceFactory = std::function<std::unique_ptr<FrameSource>()>;

// Records `reopen()`'s frames into `out_path` and verifies them. Throws ToolError naming the
// problem (cannot write the file, the recorder dropped frames, frame N differs at pixel (x,y) ...).
RecordReport record_oni(const SourceFactory& reopen, bool replayable, const std::string& out_path,
                        const RecordOptions& options);

// Zeroes the outermost pixel ring of a width × height frame.
void zero_frame_border(uint16_t* depth, int width, int height);

}  // namespace dp::platform
