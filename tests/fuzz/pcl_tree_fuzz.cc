// libFuzzer target: the PCL tree importer (tools/convert/pcl_import.h, read_pcl_tree) refuses
// malformed bzip2 text with a ToolError, never crashes; an accepted tree has the node and leaf
// counts its height implies and labels that name PCL parts.
#include <cstdint>

#include "forest_blob/blob_format.h"
#include "tests/fuzz/fuzz_files.h"
#include "tools/common/error.h"
#include "tools/convert/pcl_import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  dp::fuzz::MemFile tree(data, size);
  try {
    const dp::tools::PclTree t = dp::tools::read_pcl_tree(tree.path());
    if (t.nodes.size() != dp::blob::nodes_per_heap(t.depth) || t.leaf_labels.size() != dp::blob::leaves_per_tree(t.depth))
      __builtin_trap();
    for (uint8_t l : t.leaf_labels)
      if (l >= dp::tools::kPclPartCount) __builtin_trap();
  } catch (const dp::tools::ToolError&) {
  }
  return 0;
}
