#include "runtime/kernels/dispatch.h"

#if defined(__x86_64__)
#include <cpuid.h>
#endif

#include <atomic>

namespace dp {

namespace {
struct CpuFeatures {
  bool avx2 = false, avx512 = false, neon = false;
};

#if defined(__x86_64__)
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
#else
CpuFeatures detect() {
  CpuFeatures f;
#if defined(__aarch64__)
  f.neon = true;  // Advanced SIMD is part of the AArch64 base architecture
#endif
  return f;
}
#endif

// CPUID traps to the hypervisor on virtual machines (microseconds): detect once, then reuse.
CpuFeatures cached_features() {
  static std::atomic<int> bits{0};  // 0 = not yet detected; else 0x100 | avx2 | avx512 << 1 | neon << 2
  int b = bits.load(std::memory_order_relaxed);
  if (b == 0) {
    const CpuFeatures f = detect();
    b = 0x100 | (f.avx2 ? 1 : 0) | (f.avx512 ? 2 : 0) | (f.neon ? 4 : 0);
    bits.store(b, std::memory_order_relaxed);
  }
  CpuFeatures f;
  f.avx2 = (b & 1) != 0;
  f.avx512 = (b & 2) != 0;
  f.neon = (b & 4) != 0;
  return f;
}
}  // namespace

bool kernel_isa_supported(KernelIsa isa) {
  return kernels::forest_kernel(isa) != nullptr;
}

KernelIsa widest_kernel_isa() {
  const CpuFeatures f = cached_features();
  return f.avx512 ? KernelIsa::kAvx512 : f.avx2 ? KernelIsa::kAvx2 : f.neon ? KernelIsa::kNeon : KernelIsa::kScalar;
}

KernelIsa best_forest_kernel_isa() {
  const CpuFeatures f = cached_features();
  return f.avx2 ? KernelIsa::kAvx2 : f.neon ? KernelIsa::kNeon : KernelIsa::kScalar;
}

const char* kernel_isa_name(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::kScalar: return "scalar";
    case KernelIsa::kAvx2: return "avx2";
    case KernelIsa::kAvx512: return "avx512";
    case KernelIsa::kBest: return "best";
    case KernelIsa::kNeon: return "neon";
  }
  return "?";
}

namespace kernels {
namespace {
// One choice rule for every kernel entry point: the reference, or an ISA's version when this build
// has it and the CPU runs it.
template <typename Fn>
Fn choose(KernelIsa isa, Fn scalar, Fn avx2_fn, Fn avx512_fn, Fn neon_fn) {
  const CpuFeatures f = cached_features();
  switch (isa) {
    case KernelIsa::kScalar: return scalar;
    case KernelIsa::kAvx2: return f.avx2 ? avx2_fn : nullptr;
    case KernelIsa::kAvx512: return f.avx512 ? avx512_fn : nullptr;
    case KernelIsa::kNeon: return f.neon ? neon_fn : nullptr;
    case KernelIsa::kBest: return choose(widest_kernel_isa(), scalar, avx2_fn, avx512_fn, neon_fn);
  }
  return nullptr;
}
}  // namespace

#if defined(__x86_64__)
#define DP_X86(fn) &fn
#else
#define DP_X86(fn) nullptr
#endif
#if defined(__aarch64__)
#define DP_NEON(fn) &fn
#else
#define DP_NEON(fn) nullptr
#endif

ForestKernelFn forest_kernel(KernelIsa isa) {
  if (isa == KernelIsa::kBest) isa = best_forest_kernel_isa();
  return choose<ForestKernelFn>(isa, &ref::evaluate_tree, DP_X86(avx2::evaluate_tree), DP_X86(avx512::evaluate_tree),
                                DP_NEON(neon::evaluate_tree));
}

ForestTreesKernelFn forest_trees_kernel(KernelIsa isa) {
  if (isa == KernelIsa::kBest) isa = best_forest_kernel_isa();
  return choose<ForestTreesKernelFn>(isa, &ref::evaluate_trees, DP_X86(avx2::evaluate_trees),
                                     DP_X86(avx512::evaluate_trees), DP_NEON(neon::evaluate_trees));
}

BpcScanFn bpc_scan_kernel(KernelIsa isa) {
  return choose<BpcScanFn>(isa, &ref::bpc_scan, DP_X86(avx2::bpc_scan), DP_X86(avx512::bpc_scan),
                           DP_NEON(neon::bpc_scan));
}

MeanShiftSumsFn mean_shift_sums_kernel(KernelIsa isa) {
  return choose<MeanShiftSumsFn>(isa, &ref::mean_shift_sums, DP_X86(avx2::mean_shift_sums),
                                 DP_X86(avx512::mean_shift_sums), DP_NEON(neon::mean_shift_sums));
}

KernelSet kernel_set(KernelIsa isa, KernelIsa forest_isa) {
  KernelSet k{};
  k.forest = forest_trees_kernel(forest_isa);
  k.mean_shift_sums = mean_shift_sums_kernel(isa);
  if (isa == KernelIsa::kScalar) {
    k.foreground = &ref::foreground_scan;
    k.mode_weights = &ref::mode_weights;
    return k;  // reference casters
  }
  k.bpc_scan = bpc_scan_kernel(isa);
#if defined(__x86_64__)
  k.foreground = &sse41::foreground_scan;
  k.ojr_scan = &sse41::ojr_scan;
  k.mode_weights = &sse41::mode_weights;
#else
  k.foreground = &ref::foreground_scan;
  k.ojr_scan = &ref::ojr_scan;
  k.mode_weights = &ref::mode_weights;
#endif
  return k;
}

#undef DP_X86
#undef DP_NEON
}  // namespace kernels

}  // namespace dp
