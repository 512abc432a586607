// Stage 2, the forest: every evaluated pixel descends every tree (paper Eq. 1 and 3, the exact
// integer rule of runtime/fixed_point.h) to a leaf record index. The traversal itself is a kernel
// (kernels/forest_kernel.h: ref, avx2, avx512, neon; the same leaves bit for bit).
#pragma once
#include <stdint.h>

#include "forest_blob/blob_loader.h"
#include "runtime/depthpose.h"
#include "runtime/kernels/forest_kernel.h"

namespace dp {

// The traversal tables, made once at init from the blob's split flags and split nodes
// (blob::for_each_tree_node): blob.total_nodes SplitNodes (kernels::SplitNode: offsets, left child
// and threshold in one 16-byte node; a leaf node loops on itself) and as many leaf-record indices (a
// leaf node's record, 0 for a split node), node m of tree t at [blob.tree_first[t] + m − 1].
void build_forest_tables(const blob::LoadedBlob& blob, kernels::SplitNode* nodes, uint32_t* leaf_index);

// Leaves of `count` (≥ 1) pixels in every tree: tree t's leaf for pixel i at leaves[t · leaf_stride + i].
// probe_image: the frame's padded probe image (stage 1); split_nodes, leaf_index: the tables of
// build_forest_tables. focal_px: the frame's focal length
// (finite, > 0), scaled to the blob's reference focal length by focal_factor_mm.
void evaluate_forest(kernels::ForestTreesKernelFn kernel, const blob::LoadedBlob& blob,
                     const kernels::SplitNode* split_nodes, const uint32_t* leaf_index, const uint16_t* probe_image,
                     int32_t width, int32_t height,
                     float focal_px, const EvaluatedPixel* pixels, int32_t count, uint32_t* leaves,
                     int32_t leaf_stride);

}  // namespace dp
