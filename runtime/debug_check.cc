#include "runtime/debug_check.h"

#include <stdio.h>
#include <stdlib.h>

namespace dp {

// Reached only from DP_DCHECK in a debug build; a release build keeps the symbol but never calls it.
void debug_check_failed(const char* condition, const char* file, int line) {
  fprintf(stderr, "depthpose: debug check failed: %s at %s:%d\n", condition, file, line);
  abort();
}

}  // namespace dp
