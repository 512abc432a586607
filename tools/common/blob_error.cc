#include "tools/common/blob_error.h"

#include "tools/common/error.h"

namespace dp::tools {

std::string blob_error_message(blob::BlobStatus status, const blob::BlobProblem& problem) {
  const std::string line = blob::blob_status_message(status);
  if (!problem.field) return line;
  std::string field = problem.field;
  if (problem.joint >= 0) {
    // "config.joints[j].x" names the joint found.
    const auto at = field.find("[j]");
    if (at != std::string::npos) field.replace(at, 3, "[" + std::to_string(problem.joint) + "]");
  }
  return field + " = " + std::to_string(problem.value) + " is outside " + std::to_string(problem.min) + ".." +
         std::to_string(problem.max) + " (" + line + ")";
}

blob::LoadedBlob load_blob_or_fail(const std::vector<uint8_t>& bytes, const std::string& label) {
  blob::LoadedBlob b;
  blob::BlobProblem problem;
  const blob::BlobStatus s = blob::load_blob(bytes.data(), bytes.size(), &b, &problem);
  if (s != blob::BlobStatus::kOk) fail(label + ": not a usable blob: " + blob_error_message(s, problem));
  return b;
}

}  // namespace dp::tools
