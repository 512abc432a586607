// Reference BPC vote scan: vote_kernel.h's contract written as plain C++, one joint at a time.
// The specification the SIMD scans reproduce bit for bit.
#include "runtime/kernels/vote_kernel.h"

namespace dp::kernels::ref {

void bpc_scan(const BpcScanArgs& a) {
  float w[kMaxJoints];
  uint32_t mass[kMaxJoints];
  for (int32_t i = 0; i < a.count; ++i) {
    const EvaluatedPixel px = a.pixels[i];
    if (skipped(a, px)) continue;
    prefetch_mass_rows_ahead(a, i);
    for (int j = 0; j < kMaxJoints; ++j) mass[j] = 0;
    for (int t = 0; t < a.trees; ++t) {
      const uint16_t* m = mass_row(a, t, i);
      for (int j = 0; j < kMaxJoints; ++j) mass[j] += m[j];
    }
    const float z = float(px.z_mm) * 0.001f;
    uint32_t keep = 0;
    for (int j = 0; j < kMaxJoints; ++j) {
      if (mass[j] == 0) continue;
      ++a.candidates[j];
      w[j] = float(mass[j]) * a.inv_total * z * z;
      if (!(w[j] < a.floor[j])) keep |= 1u << j;
    }
    if (keep) append_bpc_survivors(a, i, px, z, keep, w, mass);
  }
}

}  // namespace dp::kernels::ref
