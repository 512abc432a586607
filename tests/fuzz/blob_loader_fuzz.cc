// libFuzzer target: the loader must refuse or accept any byte string without crashing, and an
// accepted blob must be internally consistent: every leaf index inside the leaf table, every leaf
// record's entries inside the entry table (read here, so ASan sees any read past it), no record
// above its capacity, every tag below it.
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
  const uint32_t capacity = uint32_t(dp::blob::max_entries_per_leaf(*b.meta));
  const size_t entry_bytes = dp::blob::leaf_entry_bytes(*b.meta);
  volatile uint32_t sink = 0;
  for (uint32_t l = 0; l < b.meta->leaf_count; ++l) {
    if (b.leaf_size(l) > capacity || b.leaf_first(l) + b.leaf_size(l) > b.meta->entry_count) __builtin_trap();
    for (uint32_t e = b.leaf_first(l); e < b.leaf_first(l) + b.leaf_size(l); ++e) {
      if (b.entry_tags[e] >= capacity) __builtin_trap();
      sink = sink + b.leaf_entries[e * entry_bytes] + b.leaf_entries[e * entry_bytes + entry_bytes - 1];
    }
  }
  return 0;
}
