// Reading a validated blob back into dp::blob::BlobContents, so tools can change one part (tune:
// the runtime config) and write a new blob through write_blob (fresh CRCs, arena size).
// contents_from_blob(load(write_blob(c))) written again gives the same bytes.
#pragma once
#include <cstdint>
#include <vector>

#include "forest_blob/blob_loader.h"
#include "forest_blob/blob_writer.h"

namespace dp::tools {

blob::BlobContents contents_from_blob(const blob::LoadedBlob& blob);

// The bytes of `blob` with its runtime config replaced (ToolError when the config is invalid).
std::vector<uint8_t> blob_with_config(const blob::LoadedBlob& blob, const blob::RuntimeConfig& config);

}  // namespace dp::tools
