// PNG reading and writing through libpng for the tools (datasets, overlays, plots).
// All functions throw ToolError naming the file on any failure (missing, not a PNG, wrong bit
// depth or channel count, truncated).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace dp::tools {

struct ImageU16 {  // single channel, row-major, no padding
  int width = 0, height = 0;
  std::vector<uint16_t> pixels;
};
struct ImageU8 {
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;
};
struct ImageRgb {  // 3 bytes per pixel, r g b
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;
  void resize(int w, int h) { width = w; height = h; pixels.assign(size_t(w) * h * 3, 0); }
  void set(int x, int y, uint8_t r, uint8_t g, uint8_t b) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    uint8_t* p = &pixels[(size_t(y) * width + x) * 3];
    p[0] = r; p[1] = g; p[2] = b;
  }
};

// 16-bit greyscale (depth in millimetres by the dataset convention).
ImageU16 read_png_u16(const std::string& path);
void write_png_u16(const std::string& path, const ImageU16& image);
// 8-bit greyscale (part labels by the dataset convention).
ImageU8 read_png_u8(const std::string& path);
void write_png_u8(const std::string& path, const ImageU8& image);
void write_png_rgb(const std::string& path, const ImageRgb& image);

// In-memory encoders, for tests and for callers that write elsewhere. Deterministic output
// (no timestamps, fixed compression level).
std::vector<uint8_t> encode_png_u16(const ImageU16& image);
std::vector<uint8_t> encode_png_u8(const ImageU8& image);

}  // namespace dp::tools
