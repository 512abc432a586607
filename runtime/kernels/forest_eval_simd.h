// The x86 end of a forest-kernel visit, shared by avx2/forest_eval.cc and avx512/forest_eval.cc
// (each includes it once, compiled with its ISA flags); the rest of the kernels' frame is the
// portable forest_eval_common.h. Internal linkage throughout, so the two compilations never mix.
#pragma once
#include <immintrin.h>
#include <stdint.h>

#include "runtime/kernels/forest_eval_common.h"

namespace dp::kernels {
namespace {

// The scalar end of a visit, after the vector step made its two probe addresses (`addresses`: probe 1
// in the low 32 bits, probe 2 in the high): the two probe loads, the child bit (the carry of
// t + e2 <u e1, above) and node[i]'s child (1-based: left_child[m − 1] + bit), prefetched when asked.
// `m` is node[i] as the caller holds it: the AVX2 kernel hands it over as uint32_t, the AVX-512 one as
// the 64-bit index it addressed the node with (each measured faster for its own kernel).
template <bool kPrefetchChildren, class Nodes, class Index>
inline void finish_visit(const ForestKernelArgs& a, const Nodes& nodes, uint32_t* node, int32_t i, Index m,
                         int32_t threshold, uint64_t addresses) {
  uint64_t probe1 = addresses, probe2 = addresses;
  // Two ops (mov r32 zero-extends; shr): GCC otherwise spends three on separating the pair.
  asm("movl %k1, %k0\n\tshrq $32, %1" : "=r"(probe1), "+r"(probe2));
  const uint32_t lhs = uint32_t(threshold) + a.probe_image[probe2], rhs = a.probe_image[probe1];
  // The left child's load depends on m only, so it overlaps the probe loads rather than lengthening the chain.
  Index child = nodes.left_child(uint32_t(m));
  // GCC makes the bit with setb and adds it (two ops and a zeroing); adc does both in one.
  asm("cmpl %2, %1\n\tadcl $0, %k0" : "+r"(child) : "r"(lhs), "r"(rhs) : "cc");
  node[i] = uint32_t(child);
  if constexpr (kPrefetchChildren) nodes.prefetch(uint32_t(child));
}

}  // namespace
}  // namespace dp::kernels
