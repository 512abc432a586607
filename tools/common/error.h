// Tools (not the runtime) report failures by throwing ToolError with a message that names the
// problem and the file; the CLI prints it as one line. The runtime never throws.
#pragma once
#include <stdexcept>
#include <string>

namespace dp::tools {

struct ToolError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] inline void fail(const std::string& message) { throw ToolError(message); }

}  // namespace dp::tools
