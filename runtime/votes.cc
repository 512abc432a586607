#include "runtime/votes.h"

#include "runtime/bpc_votes.h"
#include "runtime/debug_check.h"
#include "runtime/ojr_votes.h"

namespace dp {

uint32_t cast_votes(const CastInputs& in, const VoteScanKernels* scan, const VoteSets& sets) {
  DP_DCHECK(in.cap >= 1 && in.cap <= blob::kMaxVotesCap);
  DP_DCHECK(in.count >= 0 && in.leaf_stride >= in.count);
  DP_DCHECK(in.intrinsics.fx > 0.0f && in.intrinsics.fy > 0.0f);
  clear_votes(sets);
  const bool bpc = in.blob->method() == blob::Method::kBpc;
  if (!scan) return bpc ? cast_bpc_votes_reference(in, sets) : cast_ojr_votes_reference(in, sets);
  return bpc ? cast_bpc_votes_fast(in, scan->bpc_scan, sets) : cast_ojr_votes_fast(in, scan->ojr_scan, sets);
}

}  // namespace dp
