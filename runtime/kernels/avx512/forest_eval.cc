// AVX-512 (F/BW/VL/DQ) forest kernel: 8 pixels per 512-bit register, breadth-first. Bit-exact with
// ref/forest_eval.cc by the probe arithmetic stated in forest_eval_simd.h.
//
// Why this shape (docs/runtime_speed.md, measured side by side): a visit's chain — node index,
// node, probe arithmetic, probe loads, child index — is ~40–70 cycles, so speed is how many visits
// are in flight, and the core's window caps that (~320 ops in the reorder buffer, ~88 loads in the
// load queue). Here the 8 nodes are loaded straight into vector lanes, the arithmetic (and for
// packed nodes the threshold decode) is shared by 8 visits, and the addresses come back by lane
// extracts rather than through memory: ~15 ops and ~4–5 loads per visit, against ~23 ops and 5
// loads for two pixels per 128-bit register with scalar decode — ~10 % faster. A gather for the 8
// nodes (microcoded on Zen 4) made it 20 % slower than that; addresses through a stack buffer (two
// more loads per visit) gained nothing.
#include "runtime/kernels/forest_eval_simd.h"

namespace dp::kernels::avx512 {
namespace {

// GCC 12 reports the intrinsics' own undefined carried-through operands (srli, cvtepi64_epi32,
// extracti32x4) as maybe-uninitialized once inlined here; no value of ours is uninitialized.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
template <bool kPrefetchChildren, class Nodes>
void level_of_chunk(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t padded) {
  constexpr bool kPacked = Nodes::kThresholdInLanes;
  const Nodes nodes(a);
  const __m512i lane_mask = _mm512_set1_epi16(int16_t(0xFFF0));
  const __m512i nibble_mask = _mm512_set1_epi16(0x000F);
  const __m512i high = _mm512_set1_epi32(int32_t(uint32_t(a.width + 1) | (uint32_t(a.height + 1) << 16)));
  const __m512i row_madd = _mm512_set1_epi32(int32_t(1u | (uint32_t(a.probe_stride) << 16)));
  const __m512i nibble_madd = _mm512_set1_epi32(int32_t(1u | (16u << 16)));
  const __m512i low_byte = _mm512_set1_epi64(0xFF);
  for (int32_t i = 0; i < padded; i += 8) {
    const __m512i raw = _mm512_set_epi64(
        nodes.bits(node[i + 7]), nodes.bits(node[i + 6]), nodes.bits(node[i + 5]),
        nodes.bits(node[i + 4]), nodes.bits(node[i + 3]), nodes.bits(node[i + 2]),
        nodes.bits(node[i + 1]), nodes.bits(node[i]));
    // 4·δ per lane: packed lanes hold δ·16 above a threshold nibble, split lanes 4·δ, blob lanes δ.
    const __m512i offsets4 =
        kPacked ? _mm512_srai_epi16(_mm512_and_si512(raw, lane_mask), 2)
                : Nodes::kOffsetsTimesFour ? raw : _mm512_slli_epi16(raw, 2);
    __m512i xy = _mm512_mulhrs_epi16(offsets4, _mm512_load_si512(setup.scale_q13[i]));
    xy = _mm512_add_epi16(xy, _mm512_load_si512(setup.origin[i]));
    xy = _mm512_min_epu16(xy, high);
    const __m512i addresses = _mm512_madd_epi16(xy, row_madd);  // pixel j: dwords 2j (probe 1), 2j + 1 (probe 2)
    const __m128i address_pairs[4] = {_mm512_castsi512_si128(addresses), _mm512_extracti32x4_epi32(addresses, 1),
                                      _mm512_extracti32x4_epi32(addresses, 2), _mm512_extracti32x4_epi32(addresses, 3)};
    alignas(32) int32_t threshold[8];
    if constexpr (kPacked) {
      // The 4 nibbles of each node → n0 + 16·n1 and n2 + 16·n3 by one madd, joined into 16 bits and
      // sign-extended (kernels::pack_node's layout).
      const __m512i halves = _mm512_madd_epi16(_mm512_and_si512(raw, nibble_mask), nibble_madd);
      const __m512i joined = _mm512_or_si512(_mm512_and_si512(halves, low_byte), _mm512_srli_epi64(halves, 24));
      __m256i thresholds = _mm512_cvtepi64_epi32(joined);
      thresholds = _mm256_srai_epi32(_mm256_slli_epi32(thresholds, 16), 16);
      _mm256_store_si256(reinterpret_cast<__m256i*>(threshold), thresholds);
    }
#pragma GCC unroll 8
    for (int j = 0; j < 8; ++j) {
      const int32_t t = kPacked ? threshold[j] : nodes.threshold(node[i + j]);
      const __m128i pair = address_pairs[j >> 1];
      const uint64_t q = (j & 1) ? uint64_t(_mm_extract_epi64(pair, 1)) : uint64_t(_mm_cvtsi128_si64(pair));
      finish_visit<kPrefetchChildren>(a, nodes, node, i + j, uint64_t(node[i + j]), t, q);
    }
  }
}
#pragma GCC diagnostic pop

template <class Nodes>
struct Chunk {
  static constexpr ChunkFn kFn = &evaluate_chunk_by_levels<&level_of_chunk<false, Nodes>, &level_of_chunk<true, Nodes>, Nodes::kBytes>;
};

}  // namespace

void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count) {
  evaluate_trees_simd<8, Chunk<SplitNodes>::kFn, Chunk<PackedNodes>::kFn, Chunk<BlobNodes>::kFn>(per_tree, tree_count);
}
void evaluate_trees_study(const ForestKernelArgs* per_tree, int32_t tree_count, NodeLayout layout) {
  evaluate_trees_study_simd<8, Chunk>(per_tree, tree_count, layout);
}
void evaluate_tree(const ForestKernelArgs& args) { evaluate_trees(&args, 1); }
}  // namespace dp::kernels::avx512
