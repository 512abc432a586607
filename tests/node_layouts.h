// A forest's trees in every node layout the forest kernels read (kernels::NodeLayout), for the
// kernel tests and `make bench`'s layout study; header-only, test and benchmark code (allocates).
#pragma once
#include <cstdint>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "runtime/kernels/forest_kernel.h"

namespace dp::testing_support {

// The copies, and the kernel arguments for tree t in one layout (kBlob10 reads the blob in place).
struct TreeCopies {
  const blob::LoadedBlob& b;
  std::vector<kernels::PackedNode> packed;
  std::vector<kernels::WideNode> wide;
  std::vector<uint64_t> offsets;
  std::vector<int16_t> thresholds;
  std::vector<kernels::SplitTree> split;
  explicit TreeCopies(const blob::LoadedBlob& blob) : b(blob) {
    const size_t per_tree = blob::nodes_per_tree(b.depth());
    for (size_t i = 0; i < size_t(b.tree_count()) * per_tree; ++i) {
      const blob::TreeNode& n = b.nodes[i];
      packed.push_back(kernels::pack_node(n));
      wide.push_back(kernels::WideNode{n.du1, n.dv1, n.du2, n.dv2, n.threshold_mm, {7, 7, 7}});
      offsets.push_back(kernels::split_offsets_of(n));
      thresholds.push_back(n.threshold_mm);
    }
    for (int t = 0; t < b.tree_count(); ++t)
      split.push_back(kernels::SplitTree{offsets.data() + t * per_tree, thresholds.data() + t * per_tree});
  }
  kernels::ForestKernelArgs args(int t, kernels::NodeLayout layout, const uint16_t* probe, int32_t width,
                                 int32_t height, int32_t focal, const EvaluatedPixel* pixels, int32_t n,
                                 uint32_t* out) const {
    const size_t first = size_t(t) * blob::nodes_per_tree(b.depth());
    using L = kernels::NodeLayout;
    return kernels::ForestKernelArgs{probe, width + 2, width, height, focal, pixels, n, b.tree_nodes(t),
                                     layout == L::kPacked8 ? packed.data() + first : nullptr, b.tree_leaf_index(t),
                                     b.depth(), out, layout == L::kSplit ? &split[size_t(t)] : nullptr,
                                     layout == L::kWide16 ? wide.data() + first : nullptr};
  }
};
}  // namespace dp::testing_support
