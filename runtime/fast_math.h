// Small, deterministic float helpers for aggregation, so the runtime needs no libm.
#pragma once
#include <stdint.h>
#include <string.h>

namespace dp {

// e^(−t) for t ≥ 0 with relative error < 2e-4; returns 0 for t > 80.
inline float exp_neg(float t) {
  if (!(t < 80.0f)) return 0.0f;
  const float y = -t * 1.44269504f;  // log2(e)
  const float fi = static_cast<float>(static_cast<int32_t>(y)) - (y < 0.0f && static_cast<float>(static_cast<int32_t>(y)) != y ? 1.0f : 0.0f);
  const float f = y - fi;  // [0, 1)
  // 2^f on [0,1): degree-4 minimax-style polynomial.
  const float p = 1.0f + f * (0.69314718f + f * (0.24022650f + f * (0.05550411f + f * 0.00961813f)));
  const int32_t e = static_cast<int32_t>(fi) + 127;
  if (e <= 0) return 0.0f;
  const uint32_t bits = static_cast<uint32_t>(e) << 23;
  float scale;
  memcpy(&scale, &bits, sizeof scale);
  return p * scale;
}

}  // namespace dp
