#include "runtime/forest.h"

#include "runtime/debug_check.h"
#include "runtime/fixed_point.h"

namespace dp {

void copy_split_nodes(const blob::LoadedBlob& blob, kernels::SplitNode* nodes) {
  for (size_t i = 0; i < blob.total_nodes; ++i) nodes[i] = kernels::split_node_of(blob.nodes[i], blob.left_child[i]);
}

void evaluate_forest(kernels::ForestTreesKernelFn kernel, const blob::LoadedBlob& blob,
                     const kernels::SplitNode* split_nodes, const uint16_t* probe_image, int32_t w, int32_t h, float focal_px,
                     const EvaluatedPixel* pixels, int32_t n, uint32_t* leaves, int32_t leaf_stride) {
  DP_DCHECK(kernel != nullptr && n >= 1 && n <= leaf_stride);
  const int32_t focal = focal_factor_mm(focal_px, blob.meta->reference_focal_px);
  kernels::ForestKernelArgs per_tree[blob::kMaxTrees];
  kernels::SplitTree split[blob::kMaxTrees];
  for (int t = 0; t < blob.tree_count(); ++t) {
    const size_t first = blob.tree_first[t];
    if (split_nodes) split[t] = kernels::SplitTree{split_nodes + first};
    per_tree[t] = kernels::ForestKernelArgs{probe_image, w + 2, w, h, focal, pixels, n, blob.tree_nodes(t),
                                            nullptr, blob.tree_left_child(t), blob.tree_leaf_index(t), blob.depth(),
                                            blob.tree_node_count(t), leaves + size_t(t) * leaf_stride,
                                            split_nodes ? &split[t] : nullptr, nullptr};
  }
  kernel(per_tree, blob.tree_count());
}

}  // namespace dp
