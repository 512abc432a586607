// Blob refusals as messages for users: the loader's status line plus, for a field refusal, the
// field, the value found and the accepted range (dp::blob::BlobProblem).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "forest_blob/blob_loader.h"

namespace dp::tools {

// "config.max_evaluated_pixels = 2147483648 is outside 1..16777216 (a runtime config value is
// outside its range)"; only the status line when the problem names no field.
std::string blob_error_message(blob::BlobStatus status, const blob::BlobProblem& problem);

// load_blob on `bytes`, or ToolError "<label>: <blob_error_message>". `bytes` must stay alive and
// unchanged while the returned view is used.
blob::LoadedBlob load_blob_or_fail(const std::vector<uint8_t>& bytes, const std::string& label);

}  // namespace dp::tools
