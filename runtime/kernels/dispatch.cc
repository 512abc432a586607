#include <cpuid.h>

#include "runtime/kernels/forest_kernel.h"

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
}  // namespace

bool kernel_isa_supported(KernelIsa isa) {
  const CpuFeatures f = detect();
  switch (isa) {
    case KernelIsa::kScalar: return true;
    case KernelIsa::kAvx2: return f.avx2 && kernels::forest_kernel(isa) != nullptr;
    case KernelIsa::kAvx512: return f.avx512 && kernels::forest_kernel(isa) != nullptr;
    case KernelIsa::kBest: return true;
  }
  return false;
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
// Per-ISA kernels are linked in when their folders exist; until then only the reference runs.
ForestKernelFn forest_kernel(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::kScalar: return &ref::evaluate_tree;
    case KernelIsa::kAvx2: return nullptr;
    case KernelIsa::kAvx512: return nullptr;
    case KernelIsa::kBest: return &ref::evaluate_tree;
  }
  return nullptr;
}
}  // namespace kernels

}  // namespace dp
