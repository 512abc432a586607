#include "tools/eval/blob_rebuild.h"

#include <cstring>
#include <string>

#include "tools/common/error.h"
#include "tools/common/blob_error.h"

namespace dp::tools {

blob::BlobContents contents_from_blob(const blob::LoadedBlob& b) { return blob::dense_contents(b); }

std::vector<uint8_t> blob_with_config(const blob::LoadedBlob& b, const blob::RuntimeConfig& config) {
  blob::BlobProblem problem;
  if (blob::BlobStatus s = blob::validate_config(*b.meta, config, &problem); s != blob::BlobStatus::kOk)
    fail("runtime config refused: " + blob_error_message(s, problem));
  blob::BlobContents c = contents_from_blob(b);
  c.config = config;
  return blob::write_blob(c);
}

}  // namespace dp::tools
