// Shared body of the per-ISA forest kernels (avx2/forest_eval.cc, avx512/forest_eval.cc include it
// once each, compiled with their ISA flags). Everything here has internal linkage, so the two
// compilations never mix. Same results as ref/forest_eval.cc bit for bit; the exactness argument:
//   probe offset  (δ·s + 4096) >> 13  ==  pmulhrsw(4δ, s) = (4δ·s + 2^14) >> 15   (|4δ| ≤ 16384)
//   off-image     coordinates clamped to [−1, width] × [−1, height] land on the padded border,
//                 which holds kBackgroundDepthMm — the value the rule gives any off-image probe;
//                 |u + offset| ≤ 4095 + 4·4096 keeps every coordinate inside int16.
//   address       (v + 1)·stride + (u + 1) by pmaddwd, stride ≤ 4098.
// Speed (docs/runtime_speed.md): pixels are evaluated breadth-first, one tree level at a time over
// a chunk of pixels, so the visits of a level are independent and their node fetches overlap;
// from kPrefetchFromLevel on, the node of the pixel kPrefetchAhead positions later is prefetched.
#pragma once
#include <immintrin.h>
#include <stdint.h>

#include "runtime/kernels/forest_kernel.h"

namespace dp::kernels {
namespace {

constexpr int32_t kChunkPixels = 2048;
constexpr int32_t kPrefetchAhead = 40;
constexpr int32_t kPrefetchFromLevel = 9;

struct alignas(16) ProbeSetup {
  int16_t scale_q13[4];  // s in every lane
  int16_t origin[4];     // u + 1, v + 1, u + 1, v + 1 (padded coordinates)
};

inline int32_t scale_q13_of(int32_t focal_factor, int32_t z_mm) {  // = dp::scale_q13
  const int32_t s = (focal_factor * 8192 + z_mm / 2) / z_mm;
  return s < 32767 ? s : 32767;
}

template <bool kPacked>
inline uint32_t visit(const ForestKernelArgs& a, uint32_t n, const ProbeSetup& p, __m128i low, __m128i high,
                      __m128i row_madd) {
  __m128i off4;
  int32_t threshold;
  if constexpr (kPacked) {
    const uint64_t bits = a.packed_nodes[n].bits;
    off4 = _mm_srai_epi16(_mm_and_si128(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(a.packed_nodes + n)),
                                        _mm_set1_epi16(int16_t(0xFFF0))),
                          2);
    threshold = int16_t(_pext_u64(bits, 0x000F000F000F000Full));
  } else {
    const blob::TreeNode* node = a.nodes + n;
    off4 = _mm_slli_epi16(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(node)), 2);
    threshold = node->threshold_mm;
  }
  __m128i xy = _mm_mulhrs_epi16(off4, _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p.scale_q13)));
  xy = _mm_add_epi16(xy, _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p.origin)));
  xy = _mm_min_epi16(_mm_max_epi16(xy, low), high);
  const uint64_t addresses = uint64_t(_mm_cvtsi128_si64(_mm_madd_epi16(xy, row_madd)));
  const int32_t d1 = a.probe_image[uint32_t(addresses)];
  const int32_t d2 = a.probe_image[addresses >> 32];
  return 2 * n + 1 + ((d1 - d2) > threshold ? 1u : 0u);
}

template <bool kPacked>
void evaluate_breadth_first(const ForestKernelArgs& a) {
  ProbeSetup setup[kChunkPixels];
  const __m128i low = _mm_setzero_si128();
  const __m128i high = _mm_setr_epi16(int16_t(a.width + 1), int16_t(a.height + 1), int16_t(a.width + 1),
                                      int16_t(a.height + 1), 0, 0, 0, 0);
  const __m128i row_madd = _mm_setr_epi16(1, int16_t(a.probe_stride), 1, int16_t(a.probe_stride), 0, 0, 0, 0);
  const uint32_t first_leaf = (1u << a.depth) - 1;
  for (int32_t base = 0; base < a.pixel_count; base += kChunkPixels) {
    const int32_t count = a.pixel_count - base < kChunkPixels ? a.pixel_count - base : kChunkPixels;
    uint32_t* node = a.leaf_out + base;  // holds node indices until the last level
    for (int32_t i = 0; i < count; ++i) {
      const EvaluatedPixel px = a.pixels[base + i];
      const int16_t s = int16_t(scale_q13_of(a.focal_factor, px.z_mm));
      const int16_t u = int16_t(px.u + 1), v = int16_t(px.v + 1);
      setup[i] = ProbeSetup{{s, s, s, s}, {u, v, u, v}};
      node[i] = 0;
    }
    for (int32_t level = 0; level < a.depth; ++level) {
      if (level >= kPrefetchFromLevel) {
        const int32_t ahead = count > kPrefetchAhead ? count - kPrefetchAhead : 0;
        int32_t i = 0;
        for (; i < ahead; ++i) {
          if constexpr (kPacked)
            _mm_prefetch(reinterpret_cast<const char*>(a.packed_nodes + node[i + kPrefetchAhead]), _MM_HINT_T0);
          else
            _mm_prefetch(reinterpret_cast<const char*>(a.nodes + node[i + kPrefetchAhead]), _MM_HINT_T0);
          node[i] = visit<kPacked>(a, node[i], setup[i], low, high, row_madd);
        }
        for (; i < count; ++i) node[i] = visit<kPacked>(a, node[i], setup[i], low, high, row_madd);
      } else {
        for (int32_t i = 0; i < count; ++i) node[i] = visit<kPacked>(a, node[i], setup[i], low, high, row_madd);
      }
    }
    for (int32_t i = 0; i < count; ++i) node[i] = a.leaf_index[node[i] - first_leaf];
  }
}

inline void evaluate_tree_simd(const ForestKernelArgs& a) {
  if (a.packed_nodes)
    evaluate_breadth_first<true>(a);
  else
    evaluate_breadth_first<false>(a);
}

}  // namespace
}  // namespace dp::kernels
