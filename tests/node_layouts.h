// A forest's trees in every node layout the forest kernels read (kernels::NodeLayout), for the
// kernel tests and `make bench`'s layout study; header-only, test and benchmark code (allocates).
#pragma once
#include <cstdint>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "platform/arena_memory.h"
#include "runtime/kernels/forest_kernel.h"

namespace dp::testing_support {

// The blob's trees expanded (blob::expand_tree_tables: TreeNodes, left children, leaf records per
// node), the copies, and the kernel arguments for tree t in one layout (kBlob10 reads the expanded
// TreeNodes). The copies live in one platform::ArenaMemory, as the pipeline's split nodes live in its
// arena (2 MiB pages advised), so the bench's kernel rows read nodes the way the pipeline does.
struct TreeCopies {
  const blob::LoadedBlob& b;
  std::vector<blob::TreeNode> nodes;
  std::vector<uint32_t> left_child, leaf_index;
  platform::ArenaMemory memory;
  kernels::PackedNode* packed = nullptr;
  kernels::WideNode* wide = nullptr;
  kernels::SplitNode* split_nodes = nullptr;
  std::vector<kernels::SplitTree> split;
  explicit TreeCopies(const blob::LoadedBlob& blob)
      : b(blob), nodes(blob.total_nodes), left_child(blob.total_nodes), leaf_index(blob.total_nodes) {
    blob::expand_tree_tables(b, nodes.data(), left_child.data(), leaf_index.data());
    const size_t count = b.total_nodes;
    const size_t bytes = count * (sizeof(kernels::WideNode) + sizeof(kernels::SplitNode) + sizeof(kernels::PackedNode));
    memory = platform::ArenaMemory(bytes);
    wide = reinterpret_cast<kernels::WideNode*>(memory.data());                // 16-byte aligned first
    split_nodes = reinterpret_cast<kernels::SplitNode*>(wide + count);
    packed = reinterpret_cast<kernels::PackedNode*>(split_nodes + count);
    for (size_t i = 0; i < count; ++i) {
      const blob::TreeNode& n = nodes[i];
      packed[i] = kernels::pack_node(n);
      wide[i] = kernels::WideNode{n.du1, n.dv1, n.du2, n.dv2, n.threshold_mm, {7, 7, 7}};
      split_nodes[i] = kernels::split_node_of(n, left_child[i]);
    }
    for (int t = 0; t < b.tree_count(); ++t)
      split.push_back(kernels::SplitTree{split_nodes + b.tree_first[t]});
  }
  // Tree t's expanded tables: node m at [m − 1].
  const blob::TreeNode* tree_nodes(int t) const { return nodes.data() + b.tree_first[t]; }
  const uint32_t* tree_left_child(int t) const { return left_child.data() + b.tree_first[t]; }
  const uint32_t* tree_leaf_index(int t) const { return leaf_index.data() + b.tree_first[t]; }
  kernels::ForestKernelArgs args(int t, kernels::NodeLayout layout, const uint16_t* probe, int32_t width,
                                 int32_t height, int32_t focal, const EvaluatedPixel* pixels, int32_t n,
                                 uint32_t* out) const {
    const size_t first = b.tree_first[t];
    using L = kernels::NodeLayout;
    return kernels::ForestKernelArgs{probe, width + 2, width, height, focal, pixels, n, tree_nodes(t),
                                     layout == L::kPacked8 ? packed + first : nullptr, tree_left_child(t),
                                     tree_leaf_index(t), b.depth(), b.tree_node_count(t), out,
                                     layout == L::kSplit ? &split[size_t(t)] : nullptr,
                                     layout == L::kWide16 ? wide + first : nullptr};
  }
};
}  // namespace dp::testing_support
