// Scalar reference kernel: the specification every SIMD kernel must reproduce bit for bit.
#include "runtime/fixed_point.h"
#include "runtime/kernels/forest_kernel.h"

namespace dp::kernels::ref {

void evaluate_tree(const ForestKernelArgs& a) {
  const uint32_t first_leaf = (1u << a.depth) - 1;
  for (int32_t i = 0; i < a.pixel_count; ++i) {
    const EvaluatedPixel p = a.pixels[i];
    const int32_t s = scale_q13(a.focal_factor, p.z_mm);
    uint32_t n = 0;
    for (int32_t level = 0; level < a.depth; ++level) {
      const blob::TreeNode& node = a.nodes[n];
      const int32_t d1 = probe_depth(a.probe_image, a.width, a.height, p.u + probe_offset_px(node.du1, s),
                                     p.v + probe_offset_px(node.dv1, s));
      const int32_t d2 = probe_depth(a.probe_image, a.width, a.height, p.u + probe_offset_px(node.du2, s),
                                     p.v + probe_offset_px(node.dv2, s));
      n = 2 * n + 1 + ((d1 - d2) > node.threshold_mm ? 1u : 0u);
    }
    a.leaf_out[i] = a.leaf_index[n - first_leaf];
  }
}

}  // namespace dp::kernels::ref
