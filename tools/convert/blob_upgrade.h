// Forest blob v1 (dense leaves) → the current format. v1 is the same header, meta, config, nodes
// and leaf index, with one dense leaf section (kind 5) of leaf_count records of leaf_stride_bytes:
// BPC uint16 Q15 probability per part, OJR joints × K OjrVote (weight 0 = no vote); the meta's
// entry_count field was leaf_stride_bytes (docs/blob_format.md, revision history). The upgrade is
// lossless and deterministic: the same leaves, trees and config, written compactly by write_blob
// (which validates the result with the current loader).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "forest_blob/blob_writer.h"

namespace dp::tools {

// The dense contents of a v1 blob. Throws ToolError naming `what` and the problem when the bytes
// are not a v1 blob (magic, version, checksums, section table, sizes).
blob::BlobContents read_v1_blob(const std::vector<uint8_t>& bytes, const std::string& what);

}  // namespace dp::tools
