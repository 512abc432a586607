// NEON forest kernel: 2 pixels per 128-bit register, breadth-first, the frame of
// forest_eval_common.h. Bit-exact with ref/forest_eval.cc by the probe arithmetic stated there
// (sqrdmulh in place of pmulhrsw, a widening multiply and a pairwise add in place of pmaddwd).
// A visit: the two nodes' offsets joined into one register, 5 vector ops for the four probe
// coordinates and the two addresses, two lane moves, then the scalar end — the two probe loads, the
// threshold load, one compare and the child index (the unsigned compare's carry, as on x86).
#include <arm_neon.h>

#include "runtime/kernels/forest_eval_common.h"

namespace dp::kernels::neon {
namespace {

// The scalar end of a visit (forest_eval_common.h: child = left_child[m − 1] + [t + e2 <u e1]).
template <bool kPrefetchChildren, class Nodes>
inline void finish_visit(const ForestKernelArgs& a, const Nodes& nodes, uint32_t* node, int32_t i, uint32_t m,
                         uint32_t probe1, uint32_t probe2) {
  const uint32_t lhs = uint32_t(nodes.threshold(m)) + a.probe_image[probe2], rhs = a.probe_image[probe1];
  const uint32_t child = nodes.left_child(m) + (lhs < rhs ? 1u : 0u);
  node[i] = child;
  if constexpr (kPrefetchChildren) nodes.prefetch(child);
}

template <bool kPrefetchChildren, class Nodes>
void level_of_chunk(const ForestKernelArgs& a, const ChunkSetup& setup, uint32_t* node, int32_t padded) {
  const Nodes nodes(a);
  const int16x8_t lane_mask = vdupq_n_s16(int16_t(0xFFF0));
  const uint16x8_t high = vreinterpretq_u16_u32(vdupq_n_u32(uint32_t(a.width + 1) | (uint32_t(a.height + 1) << 16)));
  const uint16x8_t row = vreinterpretq_u16_u32(vdupq_n_u32(1u | (uint32_t(a.probe_stride) << 16)));
  for (int32_t i = 0; i < padded; i += 2) {
    const uint32_t m0 = node[i], m1 = node[i + 1];
    const int16x8_t raw = vreinterpretq_s16_u64(
        vcombine_u64(vcreate_u64(uint64_t(nodes.bits(m0))), vcreate_u64(uint64_t(nodes.bits(m1)))));
    // 4·δ per lane: packed lanes hold δ·16 above a threshold nibble, split lanes 4·δ, blob lanes δ.
    const int16x8_t offsets4 = Nodes::kThresholdInLanes ? vshrq_n_s16(vandq_s16(raw, lane_mask), 2)
                               : Nodes::kOffsetsTimesFour ? raw
                                                          : vshlq_n_s16(raw, 2);
    int16x8_t xy = vqrdmulhq_s16(offsets4, vld1q_s16(setup.scale_q13[i]));
    xy = vaddq_s16(xy, vld1q_s16(setup.origin[i]));
    const uint16x8_t clamped = vminq_u16(vreinterpretq_u16_s16(xy), high);
    // (u, v) · (1, stride) summed in pairs: probe 1 and probe 2 of pixel i, then of pixel i + 1.
    const uint32x4_t addresses = vpaddq_u32(vmull_u16(vget_low_u16(clamped), vget_low_u16(row)),
                                            vmull_high_u16(clamped, row));
    finish_visit<kPrefetchChildren>(a, nodes, node, i, m0, vgetq_lane_u32(addresses, 0), vgetq_lane_u32(addresses, 1));
    finish_visit<kPrefetchChildren>(a, nodes, node, i + 1, m1, vgetq_lane_u32(addresses, 2),
                                    vgetq_lane_u32(addresses, 3));
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

}  // namespace dp::kernels::neon
