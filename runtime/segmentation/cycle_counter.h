// The cycle counter behind SegmentationResult::stage_cycles and total_cycles: the runtime's platform
// counter (runtime/cycle_counter.h: TSC cycles on x86-64, CNTVCT_EL0 ticks on aarch64). Every read
// in runtime/segmentation goes through segmentation_cycles_now().
#pragma once
#include <stdint.h>

#include "runtime/cycle_counter.h"

namespace dp::seg {

inline uint64_t segmentation_cycles_now() { return cycle_count(); }

}  // namespace dp::seg
