// The forest-evaluation seam. runtime/kernels/ref/ is the specification; per-ISA folders
// (runtime/kernels/avx2/, runtime/kernels/avx512/) hold files of the same names whose results
// must equal the reference bit for bit (tests/runtime_kernel_test.cc proves it).
#pragma once
#include <stdint.h>

#include "forest_blob/blob_format.h"
#include "runtime/depthpose.h"

namespace dp::kernels {

struct ForestKernelArgs {
  const uint16_t* probe_image;    // width × height, no stride: foreground depth or kBackgroundDepthMm
  int32_t width, height;
  int32_t focal_factor;           // runtime/fixed_point.h
  const EvaluatedPixel* pixels;   // pixels to classify; z_mm > 0 for each
  int32_t pixel_count;
  const blob::TreeNode* nodes;    // one tree: nodes_per_tree(depth) nodes in heap order
  const uint32_t* leaf_index;     // that tree's leaves_per_tree(depth) leaf-record indices
  int32_t depth;                  // validated 1..kMaxDepth
  uint32_t* leaf_out;             // pixel_count outputs: leaf-record index reached
};

using ForestKernelFn = void (*)(const ForestKernelArgs& args);

namespace ref { void evaluate_tree(const ForestKernelArgs& args); }
namespace avx2 { void evaluate_tree(const ForestKernelArgs& args); }
namespace avx512 { void evaluate_tree(const ForestKernelArgs& args); }

// The kernel for `isa`, or nullptr when this build or this CPU lacks it (kBest never nullptr).
ForestKernelFn forest_kernel(KernelIsa isa);

}  // namespace dp::kernels
