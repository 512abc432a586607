// libFuzzer target: the loader must refuse or accept any byte string without crashing, and an
// accepted blob must be internally consistent (every leaf index inside the leaf table).
#include <stdint.h>
#include <string.h>

#include "forest_blob/blob_loader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static uint64_t storage[1 << 14];
  if (size > sizeof storage) return 0;
  memcpy(storage, data, size);
  dp::blob::LoadedBlob b;
  if (dp::blob::load_blob(storage, size, &b) != dp::blob::BlobStatus::kOk) return 0;
  const size_t slots = size_t(b.tree_count()) * dp::blob::leaves_per_tree(b.depth());
  for (size_t i = 0; i < slots; ++i)
    if (b.leaf_index[i] >= b.meta->leaf_count) __builtin_trap();
  return 0;
}
