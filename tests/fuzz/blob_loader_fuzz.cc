// libFuzzer target: the loader must refuse or accept any byte string without crashing, and an
// accepted blob must be internally consistent: the tables derived from its split flags
// (blob::expand_tree_tables) give every split node children inside its tree and after it, and a walk
// of `depth` steps from every tree's root, along either child, ends on a leaf node whose record is
// inside the leaf table; every leaf record's entries inside the entry table (read here, so ASan sees
// any read past it), no record above its capacity, every tag below it.
#include <stdint.h>
#include <string.h>

#include "forest_blob/blob_loader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static uint64_t storage[1 << 14];
  // A blob of ≤ 128 KiB holds fewer nodes than this: ≥ 4 bytes of leaf offsets per leaf node.
  static uint32_t left_table[1 << 16], record_table[1 << 16];
  if (size > sizeof storage) return 0;
  memcpy(storage, data, size);
  dp::blob::LoadedBlob b;
  if (dp::blob::load_blob(storage, size, &b) != dp::blob::BlobStatus::kOk) return 0;
  if (b.total_nodes > (1u << 16)) __builtin_trap();
  dp::blob::expand_tree_tables(b, nullptr, left_table, record_table);
  for (int t = 0; t < b.tree_count(); ++t) {
    const uint32_t count = b.tree_node_count(t);
    const uint32_t* left = left_table + b.tree_first[t];
    const uint32_t* record = record_table + b.tree_first[t];
    for (uint32_t m = 1; m <= count; ++m) {
      if (left[m - 1] == m) {  // a leaf node: its record in the table
        if (record[m - 1] >= b.meta->leaf_count) __builtin_trap();
        continue;
      }
      if (left[m - 1] <= m || left[m - 1] + 1 > count) __builtin_trap();
    }
    // Alternating walks (all-left, all-right, zig-zag) of depth steps end on leaf nodes.
    const uint32_t patterns[4] = {0u, 0xFFFFFFFFu, 0x55555555u, 0xAAAAAAAAu};
    for (uint32_t pattern : patterns) {
      uint32_t m = 1;
      for (int level = 0; level < b.depth(); ++level) m = left[m - 1] + (left[m - 1] == m ? 0 : (pattern >> level) & 1u);
      if (m < 1 || m > count || left[m - 1] != m) __builtin_trap();
    }
  }
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
