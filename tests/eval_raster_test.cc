// The plot raster (tools/eval/raster.h): primitives land on the expected pixels, text uses the
// built-in font, drawing off the canvas is clipped.
#include <gtest/gtest.h>

#include "tools/eval/raster.h"

using namespace dp::tools;

namespace {
bool is(const Canvas& c, int x, int y, Rgb col) {
  const Rgb p = c.at(x, y);
  return p.r == col.r && p.g == col.g && p.b == col.b;
}
int count(const Canvas& c, Rgb col) {
  int n = 0;
  for (int y = 0; y < c.height(); ++y)
    for (int x = 0; x < c.width(); ++x) n += is(c, x, y, col);
  return n;
}
const Rgb kInk{10, 20, 30};
}  // namespace

TEST(EvalRaster, LinesRectanglesAndClipping) {
  Canvas c(20, 10);
  EXPECT_EQ(count(c, Rgb{255, 255, 255}), 200);
  c.line(0, 0, 19, 9, kInk);
  EXPECT_TRUE(is(c, 0, 0, kInk));
  EXPECT_TRUE(is(c, 19, 9, kInk));
  EXPECT_EQ(count(c, kInk), 20);  // one pixel per column for a shallow line
  Canvas r(10, 10);
  r.fill_rect(-5, -5, 2, 2, kInk);  // partly off the canvas
  EXPECT_EQ(count(r, kInk), 9);
  r.line(-100, 5, 100, 5, kInk);
  EXPECT_TRUE(is(r, 9, 5, kInk));
}

TEST(EvalRaster, CircleHasItsRadius) {
  Canvas c(41, 41);
  c.circle(20, 20, 10, kInk);
  EXPECT_TRUE(is(c, 30, 20, kInk));
  EXPECT_TRUE(is(c, 20, 10, kInk));
  EXPECT_FALSE(is(c, 20, 20, kInk));  // outline only
  EXPECT_FALSE(is(c, 35, 20, kInk));
}

TEST(EvalRaster, TextUsesTheBitmapFont) {
  Canvas c(12, 7);
  c.text(0, 0, "1L", kInk);
  // '1': rows 4,12,4,4,4,4,14 (bit 4 = leftmost column); 'L' starts at x = 6: rows 16 ×6, 31.
  EXPECT_TRUE(is(c, 2, 0, kInk));
  EXPECT_FALSE(is(c, 0, 0, kInk));
  EXPECT_TRUE(is(c, 1, 1, kInk));
  EXPECT_TRUE(is(c, 3, 6, kInk));
  EXPECT_TRUE(is(c, 6, 0, kInk));
  EXPECT_FALSE(is(c, 7, 0, kInk));
  EXPECT_TRUE(is(c, 10, 6, kInk));
  EXPECT_EQ(count(c, kInk), (1 + 2 + 1 + 1 + 1 + 1 + 3) + (6 + 5));
  EXPECT_EQ(Canvas::text_width("abc"), 18);
  Canvas l(6, 7), u(6, 7);
  l.text(0, 0, "q", kInk);
  u.text(0, 0, "Q", kInk);
  EXPECT_EQ(l.image().pixels, u.image().pixels);  // lower case drawn as upper case
}
