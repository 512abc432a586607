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

// `c` keeping only its first `trees` trees (1..its tree count, else ToolError) and the leaf records
// they reach, renumbered in the order their leaf nodes come (tree by tree, breadth-first); config,
// names and everything else unchanged. Every pixel reaches the same record contents in the kept
// trees. (`convert --from-blob BLOB --trees N`: a tuned blob's forest with fewer trees, to be tuned again.)
void keep_first_trees(blob::BlobContents* c, int trees);

}  // namespace dp::tools
