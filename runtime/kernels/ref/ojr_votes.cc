// Reference OJR vote scan: vote_kernel.h's contract written as plain C++, one lane at a time.
// The specification the SIMD scan reproduces bit for bit.
#include "runtime/kernels/vote_kernel.h"

namespace dp::kernels::ref {

void ojr_scan(const OjrScanArgs& a) {
  for (int32_t i = 0; i < a.count; ++i) {
    const EvaluatedPixel px = a.pixels[i];
    if (skipped(a, px)) continue;
    const float z = float(px.z_mm) * 0.001f;
    const float z2 = z * z;
    const float x = (float(px.u) - a.cx) * z * a.inv_fx;
    const float y = -(float(px.v) - a.cy) * z * a.inv_fy;
    prefetch_ojr_leaves_ahead(a, i);
    for (int t = 0; t < a.trees; ++t) {
      const blob::OjrVote* leaf = ojr_leaf_of(a, t, i);
      for (int l = 0; l < a.lanes; ++l) scan_ojr_lane(a, i, t, l, x, y, z, z2, leaf[l]);
    }
  }
}

}  // namespace dp::kernels::ref
