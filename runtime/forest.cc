#include "runtime/forest.h"

#include "runtime/debug_check.h"
#include "runtime/fixed_point.h"

namespace dp {

void build_forest_tables(const blob::LoadedBlob& blob, kernels::SplitNode* nodes, uint32_t* leaf_index) {
  for (int t = 0; t < blob.tree_count(); ++t) {
    const size_t first = blob.tree_first[t];
    blob::for_each_tree_node(blob, t, [&](uint32_t m, const blob::TreeNode& node, uint32_t left, uint32_t record) {
      nodes[first + m - 1] = kernels::split_node_of(node, left);
      leaf_index[first + m - 1] = record;
    });
  }
}

void evaluate_forest(kernels::ForestTreesKernelFn kernel, const blob::LoadedBlob& blob,
                     const kernels::SplitNode* split_nodes, const uint32_t* leaf_index, const uint16_t* probe_image,
                     int32_t w, int32_t h, float focal_px,
                     const EvaluatedPixel* pixels, int32_t n, uint32_t* leaves, int32_t leaf_stride) {
  DP_DCHECK(kernel != nullptr && split_nodes != nullptr && leaf_index != nullptr && n >= 1 && n <= leaf_stride);
  const int32_t focal = focal_factor_mm(focal_px, blob.meta->reference_focal_px);
  kernels::ForestKernelArgs per_tree[blob::kMaxTrees];
  kernels::SplitTree split[blob::kMaxTrees];
  for (int t = 0; t < blob.tree_count(); ++t) {
    const size_t first = blob.tree_first[t];
    split[t] = kernels::SplitTree{split_nodes + first};
    per_tree[t] = kernels::ForestKernelArgs{probe_image, w + 2, w, h, focal, pixels, n, nullptr,
                                            nullptr, nullptr, leaf_index + first, blob.depth(),
                                            blob.tree_node_count(t), leaves + size_t(t) * leaf_stride,
                                            &split[t], nullptr};
  }
  kernel(per_tree, blob.tree_count());
}

}  // namespace dp
