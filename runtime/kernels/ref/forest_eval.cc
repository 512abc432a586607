// Scalar reference kernel: the specification every SIMD kernel must reproduce bit for bit.
// It reads the tree's TreeNodes and left children, or its SplitNodes when given (the same values: a
// SplitNode holds 4·δ, which divides back exactly), and checks image bounds itself (it never relies
// on the border).
#include "runtime/debug_check.h"
#include "runtime/fixed_point.h"
#include "runtime/kernels/forest_kernel.h"

namespace dp::kernels::ref {

namespace {
struct NodeView {
  int16_t du1, dv1, du2, dv2, threshold_mm;
  uint32_t left_child;
};
inline NodeView node_at(const ForestKernelArgs& a, uint32_t m) {
  if (a.split) {
    const SplitNode& n = a.split->nodes[m - 1];
    auto delta = [&](int k) { return int16_t(int16_t(uint16_t(n.offsets >> (16 * k))) / 4); };
    return NodeView{delta(0), delta(1), delta(2), delta(3), n.threshold_mm, n.left_child};
  }
  const blob::TreeNode& n = a.nodes[m - 1];
  return NodeView{n.du1, n.dv1, n.du2, n.dv2, n.threshold_mm, a.left_child[m - 1]};
}

inline int32_t probe(const ForestKernelArgs& a, int32_t u, int32_t v) {
  if (static_cast<uint32_t>(u) >= static_cast<uint32_t>(a.width) ||
      static_cast<uint32_t>(v) >= static_cast<uint32_t>(a.height))
    return kBackgroundDepthMm;
  return probe_depth_of(a.probe_image[size_t(v + 1) * size_t(a.probe_stride) + size_t(u + 1)]);
}
}  // namespace

void evaluate_tree(const ForestKernelArgs& a) {
  DP_DCHECK(a.depth >= 1 && a.depth <= blob::kMaxDepth && a.probe_stride == a.width + 2);
  for (int32_t i = 0; i < a.pixel_count; ++i) {
    const EvaluatedPixel p = a.pixels[i];
    DP_DCHECK(p.z_mm > 0 && p.u < a.width && p.v < a.height);
    const int32_t s = scale_q13(a.focal_factor, p.z_mm);
    uint32_t m = 1;  // the root (1-based; node m at [m − 1])
    for (int32_t level = 0; level < a.depth; ++level) {
      const NodeView node = node_at(a, m);
      const int32_t d1 = probe(a, p.u + probe_offset_px(node.du1, s), p.v + probe_offset_px(node.dv1, s));
      const int32_t d2 = probe(a, p.u + probe_offset_px(node.du2, s), p.v + probe_offset_px(node.dv2, s));
      m = node.left_child + ((d1 - d2) > node.threshold_mm ? 1u : 0u);
    }
    a.leaf_out[i] = a.leaf_index[m - 1];
  }
}

void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count) {
  for (int32_t t = 0; t < tree_count; ++t) evaluate_tree(per_tree[t]);
}

}  // namespace dp::kernels::ref
