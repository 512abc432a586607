// Mean-shift kernels (stage 4), one entry point per ISA folder (ref: plain C++, the specification;
// sse41, avx2, avx512, neon: the same bits).
//
// Sums contract: for one joint's kept votes as structure of arrays x, y, z (metres) and w (vote weight),
// padded with w = 0 (and x = y = z = 0) to `padded` entries, a multiple of kMeanShiftLanes, and one
// mode estimate m = (mx, my, mz), computes
//     k_i = w_i · exp_neg(((dx_i·dx_i + dy_i·dy_i) + dz_i·dz_i) · inv_b2),  d_i = (x_i, y_i, z_i) − m
//     out = { Σ k_i, Σ k_i·x_i, Σ k_i·y_i, Σ k_i·z_i }
// with exp_neg the polynomial of runtime/fast_math.h (0 for arguments ≥ 80) evaluated elementwise.
// The summation order is part of the definition, so every ISA gives the same bits: vote i goes to
// lane i mod 16 (kMeanShiftLanes), each lane adds its votes in increasing i, and the 16 lane sums
// are reduced by a fixed tree: s[l] + s[l+8] (l < 8), then + [l+4] (l < 4), + [l+2], + [l+1].
// The reference keeps 16 scalar lane sums, SSE4.1 and NEON 4 registers, AVX2 2, AVX-512 1; every product
// and sum is a separately rounded IEEE single operation (the runtime is compiled with
// -ffp-contract=off, so no multiply-add is ever fused). `out` is 4 floats. No allocation, no state.
//
// Mode-weights contract: for each vote i < count in increasing i, the mode m (of `mode_count`,
// `modes` as x, y, z, confidence quadruples) with the smallest d2 = (dx·dx + dy·dy) + dz·dz below
// reach2 (strict <; the first such mode on equal d2) gets w_i added to its confidence. x, y, z rows
// are readable up to count rounded up to a multiple of 4.
#pragma once
#include <stdint.h>

#include "runtime/depthpose.h"

namespace dp::kernels {

constexpr int32_t kMeanShiftLanes = 16;

using MeanShiftSumsFn = void (*)(const float* x, const float* y, const float* z, const float* w, int32_t padded,
                                 float mx, float my, float mz, float inv_b2, float* out);

using ModeWeightsFn = void (*)(const float* x, const float* y, const float* z, const float* w, int32_t count,
                              float* modes, int32_t mode_count, float reach2);

#define DP_MEAN_SHIFT_SUMS(ns)                                                                                  \
  namespace ns {                                                                                              \
  void mean_shift_sums(const float*, const float*, const float*, const float*, int32_t, float, float, float, float, \
                       float*);                                                                               \
  }
DP_MEAN_SHIFT_SUMS(ref)
DP_MEAN_SHIFT_SUMS(sse41)
DP_MEAN_SHIFT_SUMS(avx2)
DP_MEAN_SHIFT_SUMS(avx512)
DP_MEAN_SHIFT_SUMS(neon)
#undef DP_MEAN_SHIFT_SUMS
namespace ref { void mode_weights(const float*, const float*, const float*, const float*, int32_t, float*, int32_t, float); }
namespace sse41 { void mode_weights(const float*, const float*, const float*, const float*, int32_t, float*, int32_t, float); }

// nullptr when the CPU or this build lacks the ISA (kBest: the widest available).
MeanShiftSumsFn mean_shift_sums_kernel(KernelIsa isa);

}  // namespace dp::kernels
