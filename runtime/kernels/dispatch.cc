#include <cpuid.h>

#include <atomic>

#include "runtime/kernels/forest_kernel.h"
#include "runtime/kernels/mean_shift_kernel.h"
#include "runtime/kernels/vote_kernel.h"

namespace dp {

namespace {
struct CpuFeatures {
  bool avx2 = false, avx512 = false;
};

CpuFeatures detect() {
  CpuFeatures f;
  unsigned a, b, c, d;
  if (!__get_cpuid(1, &a, &b, &c, &d)) return f;
  const bool osxsave = (c >> 27) & 1;
  if (!osxsave) return f;
  unsigned xcr0_lo, xcr0_hi;
  __asm__("xgetbv" : "=a"(xcr0_lo), "=d"(xcr0_hi) : "c"(0));
  const bool ymm = (xcr0_lo & 0x6) == 0x6;
  const bool zmm = (xcr0_lo & 0xE6) == 0xE6;
  if (!__get_cpuid_count(7, 0, &a, &b, &c, &d)) return f;
  f.avx2 = ymm && ((b >> 5) & 1) && ((b >> 3) & 1) && ((b >> 8) & 1);  // AVX2, BMI1, BMI2
  // AVX-512 F, DQ, BW, VL
  f.avx512 = f.avx2 && zmm && ((b >> 16) & 1) && ((b >> 17) & 1) && ((b >> 30) & 1) && ((b >> 31) & 1);
  return f;
}
// CPUID traps to the hypervisor on virtual machines (microseconds): detect once, then reuse.
CpuFeatures cached_features() {
  static std::atomic<int> bits{0};  // 0 = not yet detected; else 0x100 | avx2 | avx512 << 1
  int b = bits.load(std::memory_order_relaxed);
  if (b == 0) {
    const CpuFeatures f = detect();
    b = 0x100 | (f.avx2 ? 1 : 0) | (f.avx512 ? 2 : 0);
    bits.store(b, std::memory_order_relaxed);
  }
  CpuFeatures f;
  f.avx2 = (b & 1) != 0;
  f.avx512 = (b & 2) != 0;
  return f;
}
}  // namespace

bool kernel_isa_supported(KernelIsa isa) {
  return kernels::forest_kernel(isa) != nullptr;
}

KernelIsa widest_kernel_isa() {
  const CpuFeatures f = cached_features();
  return f.avx512 ? KernelIsa::kAvx512 : f.avx2 ? KernelIsa::kAvx2 : KernelIsa::kScalar;
}

KernelIsa best_forest_kernel_isa() {
  return cached_features().avx2 ? KernelIsa::kAvx2 : KernelIsa::kScalar;
}

const char* kernel_isa_name(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::kScalar: return "scalar";
    case KernelIsa::kAvx2: return "avx2";
    case KernelIsa::kAvx512: return "avx512";
    case KernelIsa::kBest: return "best";
  }
  return "?";
}

namespace kernels {
namespace {
// One choice rule for every kernel entry point: the reference, or an ISA's version when the CPU has it.
template <typename Fn>
Fn choose(KernelIsa isa, Fn scalar, Fn avx2_fn, Fn avx512_fn) {
  const CpuFeatures f = cached_features();
  switch (isa) {
    case KernelIsa::kScalar: return scalar;
    case KernelIsa::kAvx2: return f.avx2 ? avx2_fn : nullptr;
    case KernelIsa::kAvx512: return f.avx512 ? avx512_fn : nullptr;
    case KernelIsa::kBest: return choose(widest_kernel_isa(), scalar, avx2_fn, avx512_fn);
  }
  return nullptr;
}
}  // namespace

ForestKernelFn forest_kernel(KernelIsa isa) {
  if (isa == KernelIsa::kBest) isa = best_forest_kernel_isa();
  return choose<ForestKernelFn>(isa, &ref::evaluate_tree, &avx2::evaluate_tree, &avx512::evaluate_tree);
}

ForestTreesKernelFn forest_trees_kernel(KernelIsa isa) {
  if (isa == KernelIsa::kBest) isa = best_forest_kernel_isa();
  return choose<ForestTreesKernelFn>(isa, &ref::evaluate_trees, &avx2::evaluate_trees, &avx512::evaluate_trees);
}

BpcScanFn bpc_scan_kernel(KernelIsa isa) {
  return choose<BpcScanFn>(isa, &ref::bpc_scan, &avx2::bpc_scan, &avx512::bpc_scan);
}

MeanShiftSumsFn mean_shift_sums_kernel(KernelIsa isa) {
  return choose<MeanShiftSumsFn>(isa, &ref::mean_shift_sums, &avx2::mean_shift_sums, &avx512::mean_shift_sums);
}
}  // namespace kernels

}  // namespace dp
