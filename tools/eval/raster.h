// A tiny RGB raster for plots and overlays: pixels, lines, rectangles, circles, crosses and text in
// a built-in 5×7 bitmap font (digits, A–Z, common punctuation; lower case is drawn as upper case,
// unknown characters as a box). Drawing outside the canvas is clipped.
#pragma once
#include <cstdint>
#include <string>

#include "tools/common/png_io.h"

namespace dp::tools {

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
};

class Canvas {
 public:
  Canvas(int width, int height, Rgb background = Rgb{255, 255, 255});
  int width() const { return image_.width; }
  int height() const { return image_.height; }
  const ImageRgb& image() const { return image_; }
  Rgb at(int x, int y) const;

  void pixel(int x, int y, Rgb c) { image_.set(x, y, c.r, c.g, c.b); }
  void line(double x0, double y0, double x1, double y1, Rgb c, int thickness = 1);
  void fill_rect(int x0, int y0, int x1, int y1, Rgb c);  // inclusive corners
  void rect(int x0, int y0, int x1, int y1, Rgb c);
  void circle(double cx, double cy, double radius, Rgb c, int thickness = 1);
  void cross(int cx, int cy, int half, Rgb c);
  // Text with its top-left corner at (x, y); each glyph is 6·scale wide (5 + 1 spacing), 7·scale tall.
  void text(int x, int y, const std::string& s, Rgb c, int scale = 1);
  static int text_width(const std::string& s, int scale = 1) { return int(s.size()) * 6 * scale; }
  static constexpr int kGlyphHeight = 7;

 private:
  ImageRgb image_;
};

// Distinct colours for part / joint index i (cycles after 32).
Rgb palette_colour(int index);
// Colour map for t in [0, 1]: white → blue → dark blue (confusion-matrix cells).
Rgb heat_colour(double t);

}  // namespace dp::tools
