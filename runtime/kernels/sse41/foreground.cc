// SSE4.1 foreground scan: eight pixels at a time, unsigned 16-bit range tests as min/max equalities,
// then ref/foreground.cc's test for a row's last pixels. Same output as the reference
// (foreground_kernel.h).
#include <smmintrin.h>

#include "runtime/fixed_point.h"
#include "runtime/kernels/foreground_kernel.h"
#include "runtime/kernels/forest_kernel.h"

namespace dp::kernels::sse41 {

ForegroundScanResult foreground_scan(const ForegroundScanArgs& a) {
  const int32_t w = a.width, probe_stride = a.width + 2;
  int32_t fg = 0, listed = 0;
  const __m128i zero = _mm_setzero_si128(), bg = _mm_set1_epi16(int16_t(kBackgroundDepthMm));
  const __m128i bias = _mm_set1_epi16(int16_t(kProbeBias));  // probe_element
  const __m128i below_bg = _mm_set1_epi16(int16_t(kBackgroundDepthMm - 1));
  const __m128i near = _mm_set1_epi16(int16_t(a.near_mm)), far = _mm_set1_epi16(int16_t(a.far_mm));
  for (int32_t v = 0; v < a.height; ++v) {
    const uint16_t* row = a.depth_mm + size_t(v) * size_t(a.stride_px);
    const uint8_t* mrow = a.mask ? a.mask + size_t(v) * size_t(a.stride_px) : nullptr;
    uint16_t* out = a.probe_image + size_t(v + 1) * size_t(probe_stride) + 1;
    // Foreground lanes are −1: subtracting them counts the row in 8 lanes (≤ 512 each), summed once
    // per row. (popcount would be a libgcc call at SSE4.1, which has no POPCNT.)
    __m128i row_count = zero;
    int32_t u = 0;
    for (; u + 8 <= w; u += 8) {
      const __m128i z = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + u));
      __m128i in = _mm_andnot_si128(_mm_cmpeq_epi16(z, zero), _mm_cmpeq_epi16(_mm_min_epu16(z, below_bg), z));
      if (mrow) {
        const __m128i m = _mm_cvtepu8_epi16(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(mrow + u)));
        in = _mm_andnot_si128(_mm_cmpeq_epi16(m, zero), in);
      } else {
        in = _mm_and_si128(in, _mm_and_si128(_mm_cmpeq_epi16(_mm_max_epu16(z, near), z),
                                             _mm_cmpeq_epi16(_mm_min_epu16(z, far), z)));
      }
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out + u), _mm_or_si128(_mm_blendv_epi8(bg, z, in), bias));
      row_count = _mm_sub_epi16(row_count, in);
      uint32_t bits = uint32_t(_mm_movemask_epi8(_mm_packs_epi16(in, zero)));
      for (; bits && listed < a.pixel_cap; bits &= bits - 1) {
        const int32_t x = u + __builtin_ctz(bits);
        a.pixels[listed++] = EvaluatedPixel{uint16_t(x), uint16_t(v), row[x], 0};
      }
    }
    const __m128i pairs = _mm_madd_epi16(row_count, _mm_set1_epi16(1));
    const __m128i sum2 = _mm_add_epi32(pairs, _mm_shuffle_epi32(pairs, _MM_SHUFFLE(1, 0, 3, 2)));
    fg += _mm_cvtsi128_si32(_mm_add_epi32(sum2, _mm_shuffle_epi32(sum2, _MM_SHUFFLE(2, 3, 0, 1))));
    for (; u < w; ++u) {
      const uint16_t z = row[u];
      const bool is_fg = z != 0 && z < kBackgroundDepthMm && (mrow ? mrow[u] != 0 : (z >= a.near_mm && z <= a.far_mm));
      out[u] = probe_element(is_fg ? z : kBackgroundDepthMm);
      fg += is_fg;
      if (is_fg && listed < a.pixel_cap) a.pixels[listed++] = EvaluatedPixel{uint16_t(u), uint16_t(v), z, 0};
    }
  }
  return ForegroundScanResult{fg, listed};
}

}  // namespace dp::kernels::sse41
