// AVX2 (+BMI2) forest kernel: 128-bit VEX probe arithmetic, scalar probe loads (gathers are slow
// on Zen 4: docs/runtime_speed.md). Bit-exact with ref/forest_eval.cc.
#include "runtime/kernels/forest_eval_simd.h"

namespace dp::kernels::avx2 {
void evaluate_tree(const ForestKernelArgs& args) { evaluate_tree_simd(args); }
void evaluate_trees(const ForestKernelArgs* per_tree, int32_t tree_count) { evaluate_trees_simd(per_tree, tree_count); }
}  // namespace dp::kernels::avx2
