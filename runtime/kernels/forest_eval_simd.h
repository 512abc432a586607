// Shared body of the per-ISA forest kernels (avx2/forest_eval.cc, avx512/forest_eval.cc include it
// once each, compiled with their ISA flags). Everything here has internal linkage, so the two
// compilations never mix. Same results as ref/forest_eval.cc bit for bit; the exactness argument:
//   probe offset  (δ·s + 4096) >> 13  ==  pmulhrsw(4δ, s) = (4δ·s + 2^14) >> 15   (|4δ| ≤ 16384)
//   off-image     padded coordinates (u + 1 + offset, v + 1 + offset) are clamped as unsigned int16 to
//                 [0, width + 1] × [0, height + 1]: a negative coordinate wraps above 32767 and
//                 clamps to the far border. Every border pixel holds kBackgroundDepthMm — the value
//                 the rule gives any off-image probe, on whichever side it left the image;
//                 |u + 1 + offset| ≤ 4096 + 16384 keeps every coordinate inside int16.
//   address       (v + 1)·stride + (u + 1) by pmaddwd, stride ≤ 4098.
// Speed (docs/runtime_speed.md): pixels are evaluated breadth-first, one tree level at a time over
// a chunk of pixels, so the visits of a level are independent and their node fetches overlap;
// from kPrefetchFromLevel on, a pixel's next node is prefetched as soon as the visit has chosen it, a
// whole pass over the chunk (kChunkPixels visits) before it is read. That costs one instruction per
// visit; reading the index of a pixel some positions ahead and prefetching its node cost two, and
// measured 5–7 % slower (tests/bench/runtime_bench.cc, docs/runtime_speed.md).
#pragma once
#include <immintrin.h>
#include <stdint.h>

#include "runtime/kernels/forest_kernel.h"

namespace dp::kernels {
namespace {

constexpr int32_t kChunkPixels = 2048;
constexpr int32_t kPrefetchFromLevel = 6;  // levels above fit in L1/L2: no prefetch

// Per pixel of a chunk, kept in two arrays so the setups of two neighbouring pixels are one 16-byte
// load: scale_q13 (s in 4 int16 lanes) and origin (u + 1, v + 1, u + 1, v + 1, padded coordinates).
// 64-byte aligned: the AVX-512 kernel reads 8 pixels' setups (one cache line) at a time.
struct ChunkSetup {
  alignas(64) int16_t scale_q13[kChunkPixels][4];
  alignas(64) int16_t origin[kChunkPixels][4];
};

inline int32_t scale_q13_of(int32_t focal_factor, int32_t z_mm) {  // = dp::scale_q13
  const int32_t s = (focal_factor * 8192 + z_mm / 2) / z_mm;
  return s < 32767 ? s : 32767;
}

struct Consts {
  __m128i high, row_madd, lane_mask;
};

template <bool kPacked>
inline __m128i load_offsets4(const ForestKernelArgs& a, uint32_t n0, uint32_t n1, int32_t* t0, int32_t* t1,
                             const Consts& c) {
  if constexpr (kPacked) {
    const uint64_t b0 = a.packed_nodes[n0].bits, b1 = a.packed_nodes[n1].bits;
    *t0 = int16_t(_pext_u64(b0, 0x000F000F000F000Full));
    *t1 = int16_t(_pext_u64(b1, 0x000F000F000F000Full));
    const __m128i raw = _mm_set_epi64x(int64_t(b1), int64_t(b0));
    return _mm_srai_epi16(_mm_and_si128(raw, c.lane_mask), 2);
  } else {
    const blob::TreeNode* x0 = a.nodes + n0;
    const blob::TreeNode* x1 = a.nodes + n1;
    *t0 = x0->threshold_mm;
    *t1 = x1->threshold_mm;
    const __m128i lo = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(x0));
    const __m128i raw = _mm_castpd_si128(_mm_loadh_pd(_mm_castsi128_pd(lo), reinterpret_cast<const double*>(x1)));
    return _mm_slli_epi16(raw, 2);
  }
}

// Two visits (pixels i and i + 1) in the 8 int16 lanes of one register.
template <bool kPacked>
inline void visit_pair(const ForestKernelArgs& a, uint32_t* node, const ChunkSetup& setup, int32_t i,
                       const Consts& c) {
  const uint32_t n0 = node[i], n1 = node[i + 1];
  int32_t t0, t1;
  const __m128i off4 = load_offsets4<kPacked>(a, n0, n1, &t0, &t1, c);
  __m128i xy = _mm_mulhrs_epi16(off4, _mm_load_si128(reinterpret_cast<const __m128i*>(setup.scale_q13[i])));
  xy = _mm_add_epi16(xy, _mm_load_si128(reinterpret_cast<const __m128i*>(setup.origin[i])));
  xy = _mm_min_epu16(xy, c.high);  // unsigned: negative coordinates clamp to the far border
  const __m128i addr = _mm_madd_epi16(xy, c.row_madd);
  const uint64_t a0 = uint64_t(_mm_cvtsi128_si64(addr));
  const uint64_t a1 = uint64_t(_mm_extract_epi64(addr, 1));
  // f > t  ⇔  (t + p2) − p1 < 0: the sign bit is the child bit (|t + p2 − p1| < 2^17, no overflow).
  const int32_t d0 = t0 + int32_t(a.probe_image[a0 >> 32]) - int32_t(a.probe_image[uint32_t(a0)]);
  const int32_t d1 = t1 + int32_t(a.probe_image[a1 >> 32]) - int32_t(a.probe_image[uint32_t(a1)]);
  node[i] = 2 * n0 + 1 + (uint32_t(d0) >> 31);
  node[i + 1] = 2 * n1 + 1 + (uint32_t(d1) >> 31);
}

template <bool kPacked>
inline void prefetch_node(const ForestKernelArgs& a, uint32_t n) {
  if constexpr (kPacked)
    _mm_prefetch(reinterpret_cast<const char*>(a.packed_nodes + n), _MM_HINT_T0);
  else
    _mm_prefetch(reinterpret_cast<const char*>(a.nodes + n), _MM_HINT_T0);
}

// The levels of one tree over a chunk whose setup is filled; node[] holds the chunk's node indices
// (the first `count` leaf-record indices are written to a.leaf_out + base).
template <bool kPacked>
void evaluate_chunk(const ForestKernelArgs& a, const ChunkSetup& setup, const Consts& c, uint32_t* node, int32_t base,
                    int32_t count, int32_t even) {
  for (int32_t i = 0; i < even; ++i) node[i] = 0;
  for (int32_t level = 0; level < a.depth; ++level) {
    if (level + 1 >= kPrefetchFromLevel && level + 1 < a.depth) {
      for (int32_t i = 0; i < even; i += 2) {
        visit_pair<kPacked>(a, node, setup, i, c);
        prefetch_node<kPacked>(a, node[i]);
        prefetch_node<kPacked>(a, node[i + 1]);
      }
    } else {
      for (int32_t i = 0; i < even; i += 2) visit_pair<kPacked>(a, node, setup, i, c);
    }
  }
  const uint32_t first_leaf = (1u << a.depth) - 1;
  for (int32_t i = 0; i < count; ++i) a.leaf_out[base + i] = a.leaf_index[node[i] - first_leaf];
}

// A chunk evaluator for packed nodes that an ISA file may supply instead of the pair loop:
// same contract as evaluate_chunk<true>; `padded` (a multiple of kPixelsPerStep) setups are filled.
using PackedChunkFn = void (*)(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t base,
                               int32_t count, int32_t padded);

// The levels of one tree over a chunk, for an ISA file's packed-node level pass (one pass over
// `padded` pixels, prefetching each chosen child when kPrefetchChildren); a PackedChunkFn.
using LevelFn = void (*)(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t padded);
template <LevelFn kLevel, LevelFn kLevelPrefetchingChildren>
void evaluate_chunk_by_levels(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t base,
                              int32_t count, int32_t padded) {
  for (int32_t i = 0; i < padded; ++i) node[i] = 0;
  for (int32_t level = 0; level < a.depth; ++level) {
    if (level + 1 >= kPrefetchFromLevel && level + 1 < a.depth)
      kLevelPrefetchingChildren(a, setup, node, padded);
    else
      kLevel(a, setup, node, padded);
  }
  const uint32_t first_leaf = (1u << a.depth) - 1;
  for (int32_t i = 0; i < count; ++i) a.leaf_out[base + i] = a.leaf_index[node[i] - first_leaf];
}

// Every tree over the same pixels, chunk by chunk: a chunk's per-pixel setup (a division per pixel)
// is made once for all trees, then each tree runs its levels over it. A chunk is padded to a
// multiple of kPixelsPerStep with copies of its last pixel, whose results are discarded.
template <int32_t kPixelsPerStep = 2>
inline void evaluate_trees_simd(const ForestKernelArgs* per_tree, int32_t tree_count, PackedChunkFn packed_chunk = nullptr) {
  static_assert(kPixelsPerStep % 2 == 0 && kChunkPixels % kPixelsPerStep == 0, "steps tile the chunk");
  if (tree_count <= 0) return;
  const ForestKernelArgs& a = per_tree[0];
  ChunkSetup setup;
  Consts c;
  const int16_t w1 = int16_t(a.width + 1), h1 = int16_t(a.height + 1), st = int16_t(a.probe_stride);
  c.high = _mm_setr_epi16(w1, h1, w1, h1, w1, h1, w1, h1);
  c.row_madd = _mm_setr_epi16(1, st, 1, st, 1, st, 1, st);
  c.lane_mask = _mm_set1_epi16(int16_t(0xFFF0));
  alignas(64) uint32_t node[kChunkPixels];
  for (int32_t base = 0; base < a.pixel_count; base += kChunkPixels) {
    const int32_t count = a.pixel_count - base < kChunkPixels ? a.pixel_count - base : kChunkPixels;
    const int32_t even = (count + kPixelsPerStep - 1) / kPixelsPerStep * kPixelsPerStep;
    for (int32_t i = 0; i < even; ++i) {
      const EvaluatedPixel px = a.pixels[base + (i < count ? i : count - 1)];
      const int16_t s = int16_t(scale_q13_of(a.focal_factor, px.z_mm));
      const int16_t u = int16_t(px.u + 1), v = int16_t(px.v + 1);
      for (int k = 0; k < 4; ++k) setup.scale_q13[i][k] = s;
      setup.origin[i][0] = setup.origin[i][2] = u;
      setup.origin[i][1] = setup.origin[i][3] = v;
    }
    for (int32_t t = 0; t < tree_count; ++t) {
      if (per_tree[t].packed_nodes && packed_chunk)
        packed_chunk(per_tree[t], setup, node, base, count, even);
      else if (per_tree[t].packed_nodes)
        evaluate_chunk<true>(per_tree[t], setup, c, node, base, count, even);
      else
        evaluate_chunk<false>(per_tree[t], setup, c, node, base, count, even);
    }
  }
}

inline void evaluate_tree_simd(const ForestKernelArgs& a) { evaluate_trees_simd(&a, 1); }

}  // namespace
}  // namespace dp::kernels
