// Blob description and checked loading for the tools.
#pragma once
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"

namespace dp::tools {

// Prints header, sections, trees and runtime config.
void describe_blob(const blob::LoadedBlob& blob, FILE* out);
// Reads and validates `path` into `bytes` (which the view points into); throws ToolError naming
// the file and the loader's problem.
blob::LoadedBlob load_blob_file_checked(const std::string& path, std::vector<uint8_t>& bytes);

// `depthpose info` asks each registered describer in turn about a file that is not a blob; a
// describer returns true when it recognised and printed the file.
using InfoDescriber = bool (*)(const std::string& path, const std::vector<uint8_t>& bytes);
struct InfoDescriberRegistrar {
  explicit InfoDescriberRegistrar(InfoDescriber describer);
};

}  // namespace dp::tools
