// AVX2 (+BMI2) forest kernel: 4 pixels per 256-bit register, breadth-first; the AVX-512 kernel's
// shape (avx512/forest_eval.cc says why) on half the width. Bit-exact with ref/forest_eval.cc by
// the probe arithmetic stated in forest_eval_simd.h. No gathers: they are slow on Zen 4.
#include "runtime/kernels/forest_eval_simd.h"

namespace dp::kernels::avx2 {
namespace {

template <bool kPrefetchChildren, class Nodes>
void level_of_chunk(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t padded) {
  constexpr bool kPacked = Nodes::kThresholdInLanes;
  const Nodes nodes(a);
  const __m256i lane_mask = _mm256_set1_epi16(int16_t(0xFFF0));
  const __m256i nibble_mask = _mm256_set1_epi16(0x000F);
  const __m256i high = _mm256_set1_epi32(int32_t(uint32_t(a.width + 1) | (uint32_t(a.height + 1) << 16)));
  const __m256i row_madd = _mm256_set1_epi32(int32_t(1u | (uint32_t(a.probe_stride) << 16)));
  const __m256i nibble_madd = _mm256_set1_epi32(int32_t(1u | (16u << 16)));
  const __m256i low_byte = _mm256_set1_epi64x(0xFF);
  const __m256i low_dwords = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
  for (int32_t i = 0; i < padded; i += 4) {
    // Four 8-byte loads joined by broadcasts and blends: shorter latency than vpinsrq + vinserti128.
    const __m256i raw = _mm256_blend_epi32(
        _mm256_blend_epi32(_mm256_castsi128_si256(_mm_cvtsi64_si128(nodes.bits(node[i]))),
                           _mm256_set1_epi64x(nodes.bits(node[i + 1])), 0x0C),
        _mm256_blend_epi32(_mm256_set1_epi64x(nodes.bits(node[i + 2])), _mm256_set1_epi64x(nodes.bits(node[i + 3])),
                           0xC0),
        0xF0);
    // 4·δ per lane: packed lanes hold δ·16 above a threshold nibble, split lanes 4·δ, blob lanes δ.
    const __m256i offsets4 =
        kPacked ? _mm256_srai_epi16(_mm256_and_si256(raw, lane_mask), 2)
                : Nodes::kOffsetsTimesFour ? raw : _mm256_slli_epi16(raw, 2);
    __m256i xy = _mm256_mulhrs_epi16(offsets4, _mm256_load_si256(reinterpret_cast<const __m256i*>(setup.scale_q13[i])));
    xy = _mm256_add_epi16(xy, _mm256_load_si256(reinterpret_cast<const __m256i*>(setup.origin[i])));
    xy = _mm256_min_epu16(xy, high);
    const __m256i addresses = _mm256_madd_epi16(xy, row_madd);  // pixel j: dwords 2j (probe 1), 2j + 1 (probe 2)
    const __m128i address_pairs[2] = {_mm256_castsi256_si128(addresses), _mm256_extracti128_si256(addresses, 1)};
    alignas(16) int32_t threshold[4];
    if constexpr (kPacked) {
      // The 4 nibbles of each node → n0 + 16·n1 and n2 + 16·n3 by one madd, joined into 16 bits,
      // the 4 low dwords brought into one lane and sign-extended (kernels::pack_node's layout).
      const __m256i halves = _mm256_madd_epi16(_mm256_and_si256(raw, nibble_mask), nibble_madd);
      const __m256i joined = _mm256_or_si256(_mm256_and_si256(halves, low_byte), _mm256_srli_epi64(halves, 24));
      __m128i thresholds = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(joined, low_dwords));
      thresholds = _mm_srai_epi32(_mm_slli_epi32(thresholds, 16), 16);
      _mm_store_si128(reinterpret_cast<__m128i*>(threshold), thresholds);
    }
#pragma GCC unroll 4
    for (int j = 0; j < 4; ++j) {
      const int32_t t = kPacked ? threshold[j] : nodes.threshold(node[i + j]);
      const __m128i pair = address_pairs[j >> 1];
      const uint64_t q = (j & 1) ? uint64_t(_mm_extract_epi64(pair, 1)) : uint64_t(_mm_cvtsi128_si64(pair));
      finish_visit<kPrefetchChildren>(a, nodes, node, i + j, t, q);
    }
  }
}

template <class Nodes>
struct Chunk {
  static constexpr ChunkFn kFn = &evaluate_chunk_by_levels<&level_of_chunk<false, Nodes>, &level_of_chunk<true, Nodes>>;
};

}  // namespace

void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count) {
  evaluate_trees_simd<4, Chunk<SplitNodes>::kFn, Chunk<PackedNodes>::kFn, Chunk<BlobNodes>::kFn>(per_tree, tree_count);
}
void evaluate_trees_study(const ForestKernelArgs* per_tree, int32_t tree_count, NodeLayout layout) {
  evaluate_trees_study_simd<4, Chunk>(per_tree, tree_count, layout);
}
void evaluate_tree(const ForestKernelArgs& args) { evaluate_trees(&args, 1); }
}  // namespace dp::kernels::avx2
