#include "tools/segeval/segmentation_digest.h"

#include <cstring>

namespace dp::tools {

namespace {

struct Fnv1a {
  uint64_t h = 0xcbf29ce484222325ull;
  void bytes(const void* p, size_t n) {
    const uint8_t* b = static_cast<const uint8_t*>(p);
    for (size_t i = 0; i < n; ++i) {
      h ^= b[i];
      h *= 0x100000001b3ull;
    }
  }
  // Little-endian bytes of each integer; floats by their bit pattern.
  void u64(uint64_t v) {
    uint8_t b[8];
    for (int i = 0; i < 8; ++i) b[i] = uint8_t(v >> (8 * i));
    bytes(b, 8);
  }
  void i32(int32_t v) { u64(uint64_t(uint32_t(v))); }
  void f32(float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    u64(bits);
  }
};

}  // namespace

uint64_t segmentation_digest(const SegmentationResult& r, int32_t width, int32_t height, int32_t stride_px) {
  Fnv1a f;
  f.i32(width);
  f.i32(height);
  for (int32_t v = 0; v < height; ++v) f.bytes(r.labels + size_t(v) * size_t(stride_px), size_t(width));
  f.i32(r.user_count);
  for (const UserInfo& u : r.users) {
    f.i32(u.id);
    f.i32(u.pixel_count);
    for (float c : u.centroid_m) f.f32(c);
    f.i32(u.u_min);
    f.i32(u.v_min);
    f.i32(u.u_max);
    f.i32(u.v_max);
    f.f32(u.top_height_m);
    f.i32(u.frames_tracked);
  }
  f.f32(r.floor.nx);
  f.f32(r.floor.ny);
  f.f32(r.floor.nz);
  f.f32(r.floor.d);
  f.i32(r.floor.valid);
  f.i32(r.floor.inliers);
  f.i32(r.floor.samples);
  f.i32(r.floor.held_frames);
  f.i32(r.candidate_pixels);
  f.i32(r.user_pixels);
  f.i32(r.component_count);
  f.u64(r.flags);
  return f.h;
}

}  // namespace dp::tools
