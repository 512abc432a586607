// The cycle counter behind SegmentationResult::stage_cycles and total_cycles: the x86 time-stamp
// counter (TSC ticks, constant rate on current CPUs). Every read in runtime/segmentation goes
// through segmentation_cycles_now(), so another counter replaces it in this one place.
#pragma once
#include <stdint.h>
#include <x86intrin.h>

namespace dp::seg {

inline uint64_t segmentation_cycles_now() { return __rdtsc(); }

}  // namespace dp::seg
