// AVX-512 (F/BW/VL/DQ) forest kernel: the shared breadth-first body compiled with EVEX encodings
// (32 vector registers). Bit-exact with ref/forest_eval.cc.
#include "runtime/kernels/forest_eval_simd.h"

namespace dp::kernels::avx512 {
void evaluate_tree(const ForestKernelArgs& args) { evaluate_tree_simd(args); }
void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count) { evaluate_trees_simd(per_tree, tree_count); }
}  // namespace dp::kernels::avx512
