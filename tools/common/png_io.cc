#include "tools/common/png_io.h"

#include <png.h>

#include <cstdio>
#include <cstring>
#include <fstream>

#include "tools/common/error.h"
#include "tools/common/file_io.h"
#include "tools/common/limits.h"

namespace dp::tools {
namespace {

struct Reader {
  const std::vector<uint8_t>* data;
  size_t pos;
};

void read_callback(png_structp png, png_bytep out, png_size_t length) {
  auto* r = static_cast<Reader*>(png_get_io_ptr(png));
  if (r->pos + length > r->data->size()) png_error(png, "truncated PNG data");
  std::memcpy(out, r->data->data() + r->pos, length);
  r->pos += length;
}

// Decodes a greyscale PNG with the wanted bit depth into rows of `bytes_per_pixel`.
void decode_grey(const std::string& path, int want_depth, int& w, int& h, std::vector<uint8_t>& raw) {
  std::vector<uint8_t> data = read_file_bytes(path, "PNG");
  if (data.size() < 8 || png_sig_cmp(data.data(), 0, 8)) fail(path + ": not a PNG file");
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) fail("libpng could not start reading " + path);
  std::vector<png_bytep> rows;
  Reader reader{&data, 0};
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    fail(path + ": corrupt or truncated PNG");
  }
  png_set_read_fn(png, &reader, read_callback);
  // libpng refuses larger IHDR dimensions itself (in png_read_info, before any row is allocated);
  // the check below says which limit in words.
  png_set_user_limits(png, limits::kMaxImageDimension, limits::kMaxImageDimension);
  if (data.size() >= 24 && std::memcmp(data.data() + 12, "IHDR", 4) == 0) {
    const auto be32 = [&](size_t at) {
      return uint32_t(data[at]) << 24 | uint32_t(data[at + 1]) << 16 | uint32_t(data[at + 2]) << 8 | data[at + 3];
    };
    const uint32_t dw = be32(16), dh = be32(20);
    if (dw > uint32_t(limits::kMaxImageDimension) || dh > uint32_t(limits::kMaxImageDimension)) {
      png_destroy_read_struct(&png, &info, nullptr);
      fail(path + ": PNG header declares " + std::to_string(dw) + "x" + std::to_string(dh) +
           " pixels; images are limited to " + std::to_string(limits::kMaxImageDimension) + " per side (docs/limits.md)");
    }
  }
  png_read_info(png, info);
  int depth = png_get_bit_depth(png, info);
  int colour = png_get_color_type(png, info);
  w = static_cast<int>(png_get_image_width(png, info));
  h = static_cast<int>(png_get_image_height(png, info));
  if (colour != PNG_COLOR_TYPE_GRAY || depth != want_depth) {
    png_destroy_read_struct(&png, &info, nullptr);
    fail(path + ": expected " + std::to_string(want_depth) + "-bit greyscale PNG, got colour type " +
         std::to_string(colour) + " with " + std::to_string(depth) + "-bit samples");
  }
  if (want_depth == 16) png_set_swap(png);  // PNG is big endian; we want host (little) order
  size_t stride = size_t(w) * (want_depth / 8);
  raw.assign(stride * h, 0);
  rows.resize(h);
  for (int y = 0; y < h; ++y) rows[y] = raw.data() + stride * y;
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
}

void write_callback(png_structp png, png_bytep data, png_size_t length) {
  auto* out = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(png));
  out->insert(out->end(), data, data + length);
}
void flush_callback(png_structp) {}

std::vector<uint8_t> encode(const uint8_t* pixels, int w, int h, int depth, int colour, int channels) {
  std::vector<uint8_t> out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) fail("libpng could not start writing");
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    fail("libpng failed while encoding an image");
  }
  png_set_write_fn(png, &out, write_callback, flush_callback);
  png_set_compression_level(png, 3);  // fast; sizes stay reasonable for depth maps
  png_set_IHDR(png, info, w, h, depth, colour, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (depth == 16) png_set_swap(png);
  size_t stride = size_t(w) * channels * (depth / 8);
  for (int y = 0; y < h; ++y) png_write_row(png, const_cast<uint8_t*>(pixels + stride * y));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

void write_bytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  write_file_atomic(path, bytes.data(), bytes.size());  // never a half-written PNG
}

void check_size(int w, int h, size_t n, size_t channels) {
  if (w <= 0 || h <= 0 || n != size_t(w) * h * channels) fail("image buffer does not match its size");
}

}  // namespace

ImageU16 read_png_u16(const std::string& path) {
  ImageU16 img;
  std::vector<uint8_t> raw;
  decode_grey(path, 16, img.width, img.height, raw);
  img.pixels.resize(raw.size() / 2);
  std::memcpy(img.pixels.data(), raw.data(), raw.size());
  return img;
}

ImageU8 read_png_u8(const std::string& path) {
  ImageU8 img;
  decode_grey(path, 8, img.width, img.height, img.pixels);
  return img;
}

std::vector<uint8_t> encode_png_u16(const ImageU16& image) {
  check_size(image.width, image.height, image.pixels.size(), 1);
  return encode(reinterpret_cast<const uint8_t*>(image.pixels.data()), image.width, image.height, 16,
                PNG_COLOR_TYPE_GRAY, 1);
}
std::vector<uint8_t> encode_png_u8(const ImageU8& image) {
  check_size(image.width, image.height, image.pixels.size(), 1);
  return encode(image.pixels.data(), image.width, image.height, 8, PNG_COLOR_TYPE_GRAY, 1);
}
void write_png_u16(const std::string& path, const ImageU16& image) { write_bytes(path, encode_png_u16(image)); }
void write_png_u8(const std::string& path, const ImageU8& image) { write_bytes(path, encode_png_u8(image)); }
void write_png_rgb(const std::string& path, const ImageRgb& image) {
  check_size(image.width, image.height, image.pixels.size(), 3);
  write_bytes(path, encode(image.pixels.data(), image.width, image.height, 8, PNG_COLOR_TYPE_RGB, 3));
}

}  // namespace dp::tools
