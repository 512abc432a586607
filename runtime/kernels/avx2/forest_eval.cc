// AVX2 (+BMI2) forest kernel: 2 pixels per 128-bit register, breadth-first. Bit-exact with
// ref/forest_eval.cc by the probe arithmetic stated in forest_eval_simd.h. No gathers: they are
// slow on Zen 4 and on Intel. Two pixels per step, not four per 256-bit register: the extra vector
// ops per visit cost less than the lane crossings (vinserti128, vextracti128) and the deeper blend
// did on a visit's chain (docs/runtime_speed.md: 2-4 % faster on the Intel host).
#include "runtime/kernels/forest_eval_simd.h"

namespace dp::kernels::avx2 {
namespace {

template <bool kPrefetchChildren, class Nodes>
void level_of_chunk(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t padded) {
  const Nodes nodes(a);
  const __m128i lane_mask = _mm_set1_epi16(int16_t(0xFFF0));
  const __m128i high = _mm_set1_epi32(int32_t(uint32_t(a.width + 1) | (uint32_t(a.height + 1) << 16)));
  const __m128i row_madd = _mm_set1_epi32(int32_t(1u | (uint32_t(a.probe_stride) << 16)));
#pragma GCC unroll 2
  for (int32_t i = 0; i < padded; i += 2) {
    // The two nodes by a load and a broadcast joined by a blend (one cycle; vpinsrq takes longer).
    const __m128i raw =
        _mm_blend_epi32(_mm_cvtsi64_si128(nodes.bits(node[i])), _mm_set1_epi64x(nodes.bits(node[i + 1])), 0x0C);
    // 4·δ per lane: packed lanes hold δ·16 above a threshold nibble, split lanes 4·δ, blob lanes δ.
    const __m128i offsets4 = Nodes::kThresholdInLanes ? _mm_srai_epi16(_mm_and_si128(raw, lane_mask), 2)
                             : Nodes::kOffsetsTimesFour ? raw
                                                        : _mm_slli_epi16(raw, 2);
    __m128i xy = _mm_mulhrs_epi16(offsets4, _mm_load_si128(reinterpret_cast<const __m128i*>(setup.scale_q13[i])));
    xy = _mm_add_epi16(xy, _mm_load_si128(reinterpret_cast<const __m128i*>(setup.origin[i])));
    xy = _mm_min_epu16(xy, high);
    const __m128i addresses = _mm_madd_epi16(xy, row_madd);  // pixel i: dwords 0 (probe 1), 1 (probe 2)
    finish_visit<kPrefetchChildren>(a, nodes, node, i, node[i], nodes.threshold(node[i]),
                                    uint64_t(_mm_cvtsi128_si64(addresses)));
    finish_visit<kPrefetchChildren>(a, nodes, node, i + 1, node[i + 1], nodes.threshold(node[i + 1]),
                                    uint64_t(_mm_extract_epi64(addresses, 1)));
  }
}

template <class Nodes>
struct Chunk {
  static constexpr ChunkFn kFn = &evaluate_chunk_by_levels<&level_of_chunk<false, Nodes>, &level_of_chunk<true, Nodes>, Nodes::kBytes>;
};

}  // namespace

void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count) {
  evaluate_trees_simd<2, Chunk<SplitNodes>::kFn, Chunk<PackedNodes>::kFn, Chunk<BlobNodes>::kFn>(per_tree, tree_count);
}
void evaluate_trees_study(const ForestKernelArgs* per_tree, int32_t tree_count, NodeLayout layout) {
  evaluate_trees_study_simd<2, Chunk>(per_tree, tree_count, layout);
}
void evaluate_tree(const ForestKernelArgs& args) { evaluate_trees(&args, 1); }
}  // namespace dp::kernels::avx2
