// The pose cache (`synth --pose-cache FILE`): the real poses of a pose pool (pose_pool.h
// RealPoses: the clips loaded, stride-sampled and retargeted) in a file, so that the shards of a
// corpus, which differ only in their seeds, read the clips and retarget them once. What depends
// on the seed (the variation) and the pruning of the varied pool are computed on every run, so a
// dataset rendered with the cache is byte-identical to one rendered without it.
//
// File layout (version 1; numbers little-endian, as written on x86-64 and aarch64):
//   8 bytes  "DPPOSES\n"
//   u32      format version (kPoseCacheVersion)
//   u64 n, n bytes   the key (text, below)
//   u64 n, n bytes   the payload: clips (name, category row), categories (name, clips, source
//                    frames, sampled), retarget seconds (f64), bone count, per pose its origin
//                    and clip, then every pose's bone rotations (pose × bone × 9 f64)
//   u32      CRC-32 (zlib) of the payload
// Strings are u64 length + bytes, counts u64, clip/category indices i32.
//
// The key is one line per input of the real poses: the format version, the CRC-32 and size of
// the running executable (any change of the code that loads or retargets clips changes it), the
// frame stride, every selected clip (id, subject, format, declared frames, category and each of
// its files with size and modification time in ns), and every file under the assets' makehuman/
// folder (size and modification time). A cache is used only when its key equals the run's key
// byte for byte; otherwise it is refused (read_pose_cache says which line differs) and the
// caller builds the poses and writes the file again. The file is written atomically (a
// temporary file renamed over it), so a killed run never leaves half a cache.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "tools/synth/clip_index.h"
#include "tools/synth/pose_pool.h"

namespace dp::synth {

constexpr uint32_t kPoseCacheVersion = 1;

// The key of the real poses of `entries` sampled every `frame_stride` frames on the human assets
// of `assets_dir`. Throws ToolError when a clip file or the executable cannot be read.
std::string pose_cache_key(const std::string& assets_dir, const std::vector<ClipEntry>& entries, int frame_stride);

// Reads `path`. True with `real` and `clip_names` (one per clip, in clip order) filled when the
// file holds a complete cache made for `key` with `bone_count` rig bones. False with `why` set
// (naming the file and the reason: missing, not a pose cache, another version, made for other
// inputs — with the first differing key line —, truncated or corrupt) otherwise.
bool read_pose_cache(const std::string& path, const std::string& key, size_t bone_count, RealPoses* real,
                     std::vector<std::string>* clip_names, std::string* why);

// Writes the cache atomically. Throws ToolError naming the file when it cannot be written.
void write_pose_cache(const std::string& path, const std::string& key, const RealPoses& real,
                      const std::vector<std::string>& clip_names);

}  // namespace dp::synth
