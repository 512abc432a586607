// Mean-shift kernel sums (stage 4), one entry point per ISA (ref = SSE4.1 baseline, AVX2, AVX-512).
//
// Contract: for one joint's kept votes as structure of arrays x, y, z (metres) and w (vote weight),
// padded with w = 0 (and x = y = z = 0) to `padded` entries, a multiple of kMeanShiftLanes, and one
// mode estimate m = (mx, my, mz), computes
//     k_i = w_i · exp_neg(((dx_i·dx_i + dy_i·dy_i) + dz_i·dz_i) · inv_b2),  d_i = (x_i, y_i, z_i) − m
//     out = { Σ k_i, Σ k_i·x_i, Σ k_i·y_i, Σ k_i·z_i }
// with exp_neg the polynomial of runtime/fast_math.h (0 for arguments ≥ 80) evaluated elementwise.
// The summation order is part of the definition, so every ISA gives the same bits: vote i goes to
// lane i mod 16 (kMeanShiftLanes), each lane adds its votes in increasing i, and the 16 lane sums
// are reduced by a fixed tree: s[l] + s[l+8] (l < 8), then + [l+4] (l < 4), + [l+2], + [l+1].
// SSE4.1 holds the 16 lanes in 4 registers, AVX2 in 2, AVX-512 in 1; every product and sum is a
// separately rounded IEEE single operation (the ISA files are compiled with -ffp-contract=off, so
// no multiply-add is ever fused). `out` is 4 floats. No allocation, no state.
#pragma once
#include <stdint.h>

#include "runtime/depthpose.h"

namespace dp::kernels {

constexpr int32_t kMeanShiftLanes = 16;

using MeanShiftSumsFn = void (*)(const float* x, const float* y, const float* z, const float* w, int32_t padded,
                                 float mx, float my, float mz, float inv_b2, float* out);

namespace ref { void mean_shift_sums(const float*, const float*, const float*, const float*, int32_t, float, float, float, float, float*); }
namespace avx2 { void mean_shift_sums(const float*, const float*, const float*, const float*, int32_t, float, float, float, float, float*); }
namespace avx512 { void mean_shift_sums(const float*, const float*, const float*, const float*, int32_t, float, float, float, float, float*); }

// nullptr when the CPU lacks the ISA (kBest: the widest available).
MeanShiftSumsFn mean_shift_sums_kernel(KernelIsa isa);

}  // namespace dp::kernels
