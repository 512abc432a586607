// The platform counter behind the runtime's per-stage costs and cycle budgets: one read, one unit
// per platform, chosen at compile time.
//
// Unit ("counter ticks"; FrameResult::stage_cycles, total_cycles, predicted_cycles and
// RuntimeConfig::cycle_budget are all in it):
//   x86-64   the time-stamp counter (rdtsc): cycles at the CPU's nominal (base) frequency, constant
//            whatever the current clock; not serialising (a stage's count may include the tail of
//            the work before it, a few tens of cycles).
//   aarch64  the generic timer's virtual count (CNTVCT_EL0), ticking at CNTFRQ_EL0 Hz (fixed by the
//            firmware: 54 MHz on a Raspberry Pi 5, 31.25 MHz on Jetson Orin; about 1 tick per
//            40–80 CPU cycles there).
//   other    nanoseconds of CLOCK_MONOTONIC.
// The counter is read only between stages, never inside a kernel. No allocation, no state.
#pragma once
#include <stdint.h>
#if !defined(__x86_64__) && !defined(__aarch64__)
#include <time.h>
#endif

namespace dp {

// The current counter value (monotonic on one core; see the unit above).
inline uint64_t cycle_count() {
#if defined(__x86_64__)
  return __builtin_ia32_rdtsc();
#elif defined(__aarch64__)
  uint64_t ticks;
  asm volatile("mrs %0, cntvct_el0" : "=r"(ticks));
  return ticks;
#else
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return uint64_t(ts.tv_sec) * 1000000000u + uint64_t(ts.tv_nsec);
#endif
}

// Counter ticks per second: CNTFRQ_EL0 on aarch64, 1e9 for the nanosecond fallback, 0 on x86-64
// (the TSC's rate is not architecturally readable; tools measure it against the wall clock).
inline uint64_t cycle_counter_hz() {
#if defined(__x86_64__)
  return 0;
#elif defined(__aarch64__)
  uint64_t hz;
  asm volatile("mrs %0, cntfrq_el0" : "=r"(hz));
  return hz;
#else
  return 1000000000u;
#endif
}

// The unit's name as the tools print it in JSON ("counter_unit"): "tsc_cycles", "cntvct_ticks" or "ns".
inline const char* cycle_counter_unit() {
#if defined(__x86_64__)
  return "tsc_cycles";
#elif defined(__aarch64__)
  return "cntvct_ticks";
#else
  return "ns";
#endif
}

}  // namespace dp
