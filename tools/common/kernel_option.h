// The `--kernel K` option of `run`, `eval` and `tune`: which kernels the pipeline runs.
//   scalar  the plain-C++ reference kernels (the specification)
//   avx2 / avx512 (x86-64), neon (aarch64)  that instruction set's kernels
//   best    the fastest this machine runs (the default)
// Every choice gives the same bits; the option exists to compare speeds and to prove that.
#pragma once
#include <string>

#include "runtime/depthpose.h"

namespace dp::tools {

extern const char* const kKernelOptionUsage;  // one usage line: "  --kernel K  ..."

// The kernel named `name`. Throws ToolError for an unknown name (listing the known ones) and for
// an instruction set this build or CPU cannot run (naming the machine's architecture and the
// kernels it does run), so a request is never silently replaced by another kernel.
KernelIsa parse_kernel_option(const std::string& name);

// "scalar, avx2, best": the choices this build and CPU run, in the order of the list above.
std::string runnable_kernel_names();

}  // namespace dp::tools
