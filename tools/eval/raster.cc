#include "tools/eval/raster.h"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace dp::tools {
namespace {

// Glyph rows top to bottom; bit 4 is the leftmost of the 5 columns.
struct Glyph {
  char ch;
  uint8_t rows[7];
};
constexpr Glyph kFont[] = {
    {' ', {0, 0, 0, 0, 0, 0, 0}},        {'0', {14, 17, 19, 21, 25, 17, 14}}, {'1', {4, 12, 4, 4, 4, 4, 14}},
    {'2', {14, 17, 1, 2, 4, 8, 31}},     {'3', {31, 2, 4, 2, 1, 17, 14}},     {'4', {2, 6, 10, 18, 31, 2, 2}},
    {'5', {31, 16, 30, 1, 1, 17, 14}},   {'6', {6, 8, 16, 30, 17, 17, 14}},   {'7', {31, 1, 2, 4, 8, 8, 8}},
    {'8', {14, 17, 17, 14, 17, 17, 14}}, {'9', {14, 17, 17, 15, 1, 2, 12}},   {'A', {14, 17, 17, 31, 17, 17, 17}},
    {'B', {30, 17, 17, 30, 17, 17, 30}}, {'C', {14, 17, 16, 16, 16, 17, 14}}, {'D', {30, 17, 17, 17, 17, 17, 30}},
    {'E', {31, 16, 16, 30, 16, 16, 31}}, {'F', {31, 16, 16, 30, 16, 16, 16}}, {'G', {14, 17, 16, 23, 17, 17, 15}},
    {'H', {17, 17, 17, 31, 17, 17, 17}}, {'I', {14, 4, 4, 4, 4, 4, 14}},      {'J', {7, 2, 2, 2, 2, 18, 12}},
    {'K', {17, 18, 20, 24, 20, 18, 17}}, {'L', {16, 16, 16, 16, 16, 16, 31}}, {'M', {17, 27, 21, 21, 17, 17, 17}},
    {'N', {17, 17, 25, 21, 19, 17, 17}}, {'O', {14, 17, 17, 17, 17, 17, 14}}, {'P', {30, 17, 17, 30, 16, 16, 16}},
    {'Q', {14, 17, 17, 17, 21, 18, 13}}, {'R', {30, 17, 17, 30, 20, 18, 17}}, {'S', {15, 16, 16, 14, 1, 1, 30}},
    {'T', {31, 4, 4, 4, 4, 4, 4}},       {'U', {17, 17, 17, 17, 17, 17, 14}}, {'V', {17, 17, 17, 17, 17, 10, 4}},
    {'W', {17, 17, 17, 21, 21, 21, 10}}, {'X', {17, 17, 10, 4, 10, 17, 17}},  {'Y', {17, 17, 10, 4, 4, 4, 4}},
    {'Z', {31, 1, 2, 4, 8, 16, 31}},     {'.', {0, 0, 0, 0, 0, 12, 12}},      {',', {0, 0, 0, 0, 12, 4, 8}},
    {'-', {0, 0, 0, 14, 0, 0, 0}},       {'_', {0, 0, 0, 0, 0, 0, 31}},       {'=', {0, 0, 31, 0, 31, 0, 0}},
    {'(', {2, 4, 8, 8, 8, 4, 2}},        {')', {8, 4, 2, 2, 2, 4, 8}},        {':', {0, 12, 12, 0, 12, 12, 0}},
    {'/', {0, 1, 2, 4, 8, 16, 0}},       {'%', {24, 25, 2, 4, 8, 19, 3}},     {'+', {0, 4, 4, 31, 4, 4, 0}},
    {'<', {2, 4, 8, 16, 8, 4, 2}},       {'>', {8, 4, 2, 1, 2, 4, 8}},        {'\'', {4, 4, 8, 0, 0, 0, 0}},
    {'?', {14, 17, 1, 2, 4, 0, 4}},      {'[', {14, 8, 8, 8, 8, 8, 14}},      {']', {14, 2, 2, 2, 2, 2, 14}},
    {';', {0, 12, 12, 0, 12, 4, 8}},     {'~', {0, 0, 8, 21, 2, 0, 0}},       {'!', {4, 4, 4, 4, 4, 0, 4}},
    {'#', {10, 10, 31, 10, 31, 10, 10}}, {'*', {0, 4, 21, 14, 21, 4, 0}},     {'|', {4, 4, 4, 4, 4, 4, 4}},
};
constexpr uint8_t kUnknownGlyph[7] = {31, 17, 17, 17, 17, 17, 31};

const uint8_t* glyph_rows(char ch) {
  const char up = char(std::toupper(static_cast<unsigned char>(ch)));
  for (const Glyph& g : kFont)
    if (g.ch == up) return g.rows;
  return kUnknownGlyph;
}

}  // namespace

Canvas::Canvas(int width, int height, Rgb bg) {
  image_.resize(width, height);
  for (size_t i = 0; i < image_.pixels.size(); i += 3) {
    image_.pixels[i] = bg.r;
    image_.pixels[i + 1] = bg.g;
    image_.pixels[i + 2] = bg.b;
  }
}

Rgb Canvas::at(int x, int y) const {
  if (x < 0 || y < 0 || x >= width() || y >= height()) return Rgb{};
  const uint8_t* p = &image_.pixels[(size_t(y) * width() + x) * 3];
  return Rgb{p[0], p[1], p[2]};
}

void Canvas::line(double x0, double y0, double x1, double y1, Rgb c, int thickness) {
  // Non-finite or absurd coordinates (a far-off proposal or truth): nothing sensible to draw, and
  // converting them to int would overflow.
  constexpr double kFar = 1e6;
  if (!(std::fabs(x0) < kFar && std::fabs(y0) < kFar && std::fabs(x1) < kFar && std::fabs(y1) < kFar)) return;
  const double len = std::max(std::fabs(x1 - x0), std::fabs(y1 - y0));
  const int steps = std::max(1, int(std::ceil(len)));
  const int lo = -(thickness - 1) / 2, hi = thickness / 2;
  for (int s = 0; s <= steps; ++s) {
    const double t = double(s) / steps;
    const int x = int(std::lround(x0 + (x1 - x0) * t)), y = int(std::lround(y0 + (y1 - y0) * t));
    for (int dy = lo; dy <= hi; ++dy)
      for (int dx = lo; dx <= hi; ++dx) pixel(x + dx, y + dy, c);
  }
}

void Canvas::fill_rect(int x0, int y0, int x1, int y1, Rgb c) {
  for (int y = std::max(0, std::min(y0, y1)); y <= std::min(height() - 1, std::max(y0, y1)); ++y)
    for (int x = std::max(0, std::min(x0, x1)); x <= std::min(width() - 1, std::max(x0, x1)); ++x) pixel(x, y, c);
}

void Canvas::rect(int x0, int y0, int x1, int y1, Rgb c) {
  line(x0, y0, x1, y0, c);
  line(x1, y0, x1, y1, c);
  line(x1, y1, x0, y1, c);
  line(x0, y1, x0, y0, c);
}

void Canvas::circle(double cx, double cy, double r, Rgb c, int thickness) {
  if (!(r > 0) || !(r < 1e5)) return;
  const int n = std::max(16, int(2 * M_PI * r));
  for (int i = 0; i < n; ++i) {
    const double a0 = 2 * M_PI * i / n, a1 = 2 * M_PI * (i + 1) / n;
    line(cx + r * std::cos(a0), cy + r * std::sin(a0), cx + r * std::cos(a1), cy + r * std::sin(a1), c, thickness);
  }
}

void Canvas::cross(int cx, int cy, int half, Rgb c) {
  line(cx - half, cy - half, cx + half, cy + half, c, 2);
  line(cx - half, cy + half, cx + half, cy - half, c, 2);
}

void Canvas::text(int x, int y, const std::string& s, Rgb c, int scale) {
  for (size_t i = 0; i < s.size(); ++i) {
    const uint8_t* rows = glyph_rows(s[i]);
    const int gx = x + int(i) * 6 * scale;
    for (int r = 0; r < 7; ++r)
      for (int col = 0; col < 5; ++col)
        if (rows[r] & (16 >> col)) fill_rect(gx + col * scale, y + r * scale, gx + col * scale + scale - 1, y + r * scale + scale - 1, c);
  }
}

Rgb palette_colour(int i) {
  // 16 hand-picked colours that stay apart on white and on black (joints, the common case)...
  static constexpr Rgb kFixed[16] = {
      {230, 25, 75},  {60, 180, 75},   {255, 200, 25}, {0, 130, 200}, {245, 130, 48}, {145, 30, 180},
      {70, 200, 220}, {240, 50, 230},  {170, 110, 40}, {128, 128, 0}, {0, 128, 128}, {250, 150, 190},
      {120, 120, 255}, {150, 230, 60}, {128, 0, 0},   {128, 128, 128}};
  if (i >= 0 && i < 16) return kFixed[i];
  // ...then hues spread by the golden angle, two brightness levels.
  const double h = std::fmod(i * 137.508, 360.0) / 60.0;
  const double v = (i / 16) % 2 ? 0.7 : 0.95, s = 0.8;
  const double cc = v * s, x = cc * (1 - std::fabs(std::fmod(h, 2.0) - 1)), m = v - cc;
  double r = 0, g = 0, b = 0;
  switch (int(h)) {
    case 0: r = cc; g = x; break;
    case 1: r = x; g = cc; break;
    case 2: g = cc; b = x; break;
    case 3: g = x; b = cc; break;
    case 4: r = x; b = cc; break;
    default: r = cc; b = x; break;
  }
  return Rgb{uint8_t(255 * (r + m)), uint8_t(255 * (g + m)), uint8_t(255 * (b + m))};
}

Rgb heat_colour(double t) {
  t = std::clamp(t, 0.0, 1.0);
  if (t < 0.5) {
    const double u = t / 0.5;
    return Rgb{uint8_t(255 - 200 * u), uint8_t(255 - 135 * u), uint8_t(255 - 25 * u)};
  }
  const double u = (t - 0.5) / 0.5;
  return Rgb{uint8_t(55 - 45 * u), uint8_t(120 - 90 * u), uint8_t(230 - 110 * u)};
}

}  // namespace dp::tools
