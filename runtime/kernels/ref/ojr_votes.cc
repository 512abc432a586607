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
      uint32_t first, end;
      ojr_leaf_range(a, t, i, &first, &end);
      for (uint32_t e = first; e < end; ++e) scan_ojr_lane(a, i, t, a.vote_lanes[e], x, y, z, z2, a.leaf_votes[e]);
    }
  }
}

}  // namespace dp::kernels::ref
