// The kernels one pipeline configuration runs, chosen in one place (dispatch.cc) from the KernelIsa
// of the vote and mean-shift kernels and that of the forest kernel (they differ under kBest).
//   kScalar  every stage's ref/ kernel (plain C++) and the reference vote casters: the specification.
//   kAvx2 / kAvx512 (x86-64)  that ISA's forest kernel, BPC vote scan and mean-shift sums; the SSE4.1
//            foreground scan, OJR vote scan and mode weights (every AVX2 CPU has SSE4.1).
//   kNeon (aarch64)  the NEON forest kernel, BPC vote scan and mean-shift sums; ref/ for the rest.
// Every choice gives the same bits (tests/runtime_kernel_test.cc).
#pragma once

#include "runtime/depthpose.h"
#include "runtime/kernels/foreground_kernel.h"
#include "runtime/kernels/forest_kernel.h"
#include "runtime/kernels/mean_shift_kernel.h"
#include "runtime/kernels/vote_kernel.h"

namespace dp::kernels {

struct KernelSet {
  ForegroundScanFn foreground;
  ForestTreesKernelFn forest;
  BpcScanFn bpc_scan;            // nullptr: the reference casters (kScalar)
  OjrScanFn ojr_scan;            // nullptr exactly when bpc_scan is
  MeanShiftSumsFn mean_shift_sums;
  ModeWeightsFn mode_weights;
};

// The set for `isa` (vote, mean-shift and foreground kernels) and `forest_isa` (forest kernel); both
// must be kernel_isa_supported and not kBest (resolve kBest with widest_kernel_isa() and
// best_forest_kernel_isa()). Every field is then non-null except as noted.
KernelSet kernel_set(KernelIsa isa, KernelIsa forest_isa);

}  // namespace dp::kernels
