// AVX-512 (F/BW/VL/DQ) forest kernel. Bit-exact with ref/forest_eval.cc: the probe arithmetic is
// the shared one (forest_eval_simd.h, whose header states why it is exact), done on 8 pixels per
// 512-bit register for packed nodes; unpacked nodes use the shared pair loop.
//
// Why 8 pixels per register and not the pair loop (docs/runtime_speed.md, measured side by side):
// a visit's chain — node index, node, probe arithmetic, probe loads, next index — is ~60 cycles,
// so speed is how many visits are in flight, and that is capped by the core's window: ~320 ops in
// the reorder buffer and ~88 loads in the load queue. The pair loop spends ~23 ops and 5 loads
// per visit (two GPR↔vector crossings per pair); here the 8 nodes are loaded straight into vector
// lanes, the arithmetic and the thresholds are shared by 8 visits, and the addresses come back by
// lane extracts (no store and reload), ~15 ops and ~4.3 loads per visit: ~11 % faster. A gather
// for the 8 nodes (Zen 4: ~1 element per 2 cycles, microcoded) made it 20 % slower than the pair
// loop; extracting the addresses through a stack buffer added two loads per visit and gained
// nothing.
#include "runtime/kernels/forest_eval_simd.h"

namespace dp::kernels::avx512 {
namespace {

// GCC 12 reports the intrinsics' own undefined pass-through operands (srli, cvtepi64_epi32,
// extracti32x4) as maybe-uninitialized once inlined here; no value of ours is uninitialized.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
template <bool kPrefetchChildren>
void level_of_chunk(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t padded) {
  const __m512i lane_mask = _mm512_set1_epi16(int16_t(0xFFF0));
  const __m512i nibble_mask = _mm512_set1_epi16(0x000F);
  const __m512i high = _mm512_set1_epi32(int32_t(uint32_t(a.width + 1) | (uint32_t(a.height + 1) << 16)));
  const __m512i row_madd = _mm512_set1_epi32(int32_t(1u | (uint32_t(a.probe_stride) << 16)));
  const __m512i nibble_madd = _mm512_set1_epi32(int32_t(1u | (16u << 16)));
  const __m512i low_byte = _mm512_set1_epi64(0xFF);
  const uint16_t* image = a.probe_image;
  const long long* nodes = reinterpret_cast<const long long*>(a.packed_nodes);
  for (int32_t i = 0; i < padded; i += 8) {
    const __m512i raw = _mm512_set_epi64(nodes[node[i + 7]], nodes[node[i + 6]], nodes[node[i + 5]], nodes[node[i + 4]],
                                         nodes[node[i + 3]], nodes[node[i + 2]], nodes[node[i + 1]], nodes[node[i]]);
    // Offsets: as load_offsets4<true>, 8 nodes at once.
    const __m512i offsets4 = _mm512_srai_epi16(_mm512_and_si512(raw, lane_mask), 2);
    __m512i xy = _mm512_mulhrs_epi16(offsets4, _mm512_load_si512(setup.scale_q13[i]));
    xy = _mm512_add_epi16(xy, _mm512_load_si512(setup.origin[i]));
    xy = _mm512_min_epu16(xy, high);
    const __m512i addresses = _mm512_madd_epi16(xy, row_madd);  // pixel j: dwords 2j (probe 1), 2j + 1 (probe 2)
    const __m128i address_pairs[4] = {_mm512_castsi512_si128(addresses), _mm512_extracti32x4_epi32(addresses, 1),
                                      _mm512_extracti32x4_epi32(addresses, 2), _mm512_extracti32x4_epi32(addresses, 3)};
    // Thresholds: the 4 nibbles of each node (pext in the pair loop) → n0 + 16·n1 and n2 + 16·n3 by
    // one madd, then joined into 16 bits and sign-extended.
    const __m512i halves = _mm512_madd_epi16(_mm512_and_si512(raw, nibble_mask), nibble_madd);
    const __m512i joined = _mm512_or_si512(_mm512_and_si512(halves, low_byte), _mm512_srli_epi64(halves, 24));
    __m256i thresholds = _mm512_cvtepi64_epi32(joined);
    thresholds = _mm256_srai_epi32(_mm256_slli_epi32(thresholds, 16), 16);
    alignas(32) int32_t threshold[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(threshold), thresholds);
#pragma GCC unroll 8
    for (int j = 0; j < 8; ++j) {
      const __m128i pair = address_pairs[j >> 1];
      const uint64_t q = (j & 1) ? uint64_t(_mm_extract_epi64(pair, 1)) : uint64_t(_mm_cvtsi128_si64(pair));
      // f > t  ⇔  (t + p2) − p1 < 0, as in visit_pair.
      const int32_t d = threshold[j] + int32_t(image[q >> 32]) - int32_t(image[uint32_t(q)]);
      const uint32_t child = 2 * node[i + j] + 1 + (uint32_t(d) >> 31);
      node[i + j] = child;
      if constexpr (kPrefetchChildren) _mm_prefetch(reinterpret_cast<const char*>(nodes + child), _MM_HINT_T0);
    }
  }
}

#pragma GCC diagnostic pop

constexpr PackedChunkFn kPackedChunk = &evaluate_chunk_by_levels<&level_of_chunk<false>, &level_of_chunk<true>>;

}  // namespace

void evaluate_tree(const ForestKernelArgs& args) { evaluate_trees_simd<8>(&args, 1, kPackedChunk); }
void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count) {
  evaluate_trees_simd<8>(per_tree, tree_count, kPackedChunk);
}
}  // namespace dp::kernels::avx512
