// Forest blobs of older formats → the current one (v4: split flags and split nodes, compact leaves).
//   v1: dense leaves. Header, meta (ForestMeta up to kLegacyMetaBytes), config, complete heap-order
//       nodes (kind 3), leaf-slot index (kind 4), one dense leaf section (kind 5) of leaf_count
//       records of leaf_stride_bytes: BPC uint16 Q15 probability per part, OJR joints × K OjrVote
//       (weight 0 = no vote); the meta's entry_count field was leaf_stride_bytes.
//   v2: compact leaves (kinds 5..7 as in v3 and v4) with v1's complete heap-order nodes and leaf-slot index.
//   v3: v4's meta (node_count per tree) and leaves; every node stored breadth first (kind 3, leaf
//       nodes as pad nodes), with a leaf-record index (kind 4) and a left-child index (kind 8) per node.
// (docs/blob_format.md, revision history.) The upgrade is lossless and deterministic: every pixel
// reaches the same leaf record (blob::append_heap_tree), with the same leaves and config, written by
// write_blob (which validates the result with the current loader).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "forest_blob/blob_writer.h"

namespace dp::tools {

// The contents of a v1, v2 or v3 blob (trees sparse, leaves dense), and its major version in *version
// when given. Throws ToolError naming `what` and the problem when the bytes are not a v1, v2 or v3
// blob (magic, version, checksums, section table, sizes, leaf offsets and tags; write_blob checks
// a v3 tree's order and records).
blob::BlobContents read_old_blob(const std::vector<uint8_t>& bytes, const std::string& what, int* version = nullptr);

}  // namespace dp::tools
