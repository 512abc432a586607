// Debug checks of the runtime's preconditions (the contracts the headers state), in the manner of a
// DCHECK: compiled in when DP_DEBUG_CHECKS is 1 (`make DEBUG=1`), compiled away otherwise — the
// condition is then not evaluated, only type-checked, so a release build pays nothing.
// A failed check prints "depthpose: debug check failed: <condition> at <file>:<line>" to stderr
// and aborts: a broken precondition is a bug in the caller or the runtime, never a status to return.
#pragma once

#ifndef DP_DEBUG_CHECKS
#define DP_DEBUG_CHECKS 0
#endif

namespace dp {
[[noreturn]] void debug_check_failed(const char* condition, const char* file, int line);
}  // namespace dp

#if DP_DEBUG_CHECKS
#define DP_DCHECK(condition) \
  ((condition) ? static_cast<void>(0) : ::dp::debug_check_failed(#condition, __FILE__, __LINE__))
#else
#define DP_DCHECK(condition) static_cast<void>(sizeof(static_cast<bool>(condition)))
#endif
