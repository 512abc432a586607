// Limits on every size a file or an option can declare to the tools. Each reader checks the
// declared value against its limit *before* allocating or looping for it, and names the file, the
// field and the limit when refusing. docs/limits.md lists the same limits with their reasons; the
// runtime's own bounds (frame size, trees, depth, config fields) are in forest_blob/blob_format.h.
#pragma once
#include <cstdint>

namespace dp::tools::limits {

// Bytes of one input file read whole into memory (blob, trained .forest, PNG, .oni, JSON/JSONL,
// BVH/ASF/AMC). The largest file the project makes is a blob of 3 depth-20 PCL trees (≈ 44 MB:
// 3 · 2^20 nodes of 10 bytes and leaf-index entries of 4); 1 GiB leaves room for larger forests and
// still fits in memory on the machines the tools run on.
// Files that are not regular files (/dev/zero, pipes, directories) are refused outright: their
// size cannot be checked in advance.
constexpr uint64_t kMaxInputFileBytes = uint64_t(1) << 30;

// Pixels per side of an image a PNG header may declare (depth, part labels, plots). The runtime
// handles frames up to 4096 per side (blob::kMaxFrameDimension); datasets and plots stay within
// 8192, so a 16-bit image is at most 128 MiB.
constexpr int kMaxImageDimension = 8192;

// Focal lengths (fx, fy) a dataset's meta.json or --intrinsics may give, in pixels. Real depth
// cameras have 200..2000 px; below 1 px or above 10^5 px a back-projection is meaningless (and
// 1e-300 would become 0 when the runtime takes it as float).
constexpr double kMinFocalPx = 1.0;
constexpr double kMaxFocalPx = 1e5;
// Principal point (cx, cy), in pixels: within this many image sizes of the image.
constexpr double kMaxPrincipalPointPx = 1e5;

// |x|, |y|, |z| of a ground-truth joint in frames.jsonl, metres: 1 km is far beyond any depth
// camera's range (≈ 10 m), and keeps every derived pixel coordinate and distance finite.
constexpr double kMaxJointCoordinateM = 1000.0;

// `convert --check-frames N`: each sample frame holds ≤ 320×240 depth pixels (150 KiB) and costs a
// forest evaluation per pixel; 256 frames is ≈ 38 MiB and a few seconds.
constexpr long long kMaxCheckFrames = 256;

// Part labels in a dataset's parts/*.png: 0..(number of meta.json parts)−1 name a part, 255
// (kNotBodyLabel, body_model.h) means "not body"; any other value is refused.

}  // namespace dp::tools::limits
