#include "tools/common/kernel_option.h"

#include <sys/utsname.h>

#include "tools/common/error.h"

namespace dp::tools {

namespace {
// Every named choice, in the order the usage and the messages list them.
constexpr KernelIsa kKernelChoices[] = {KernelIsa::kScalar, KernelIsa::kAvx2, KernelIsa::kAvx512, KernelIsa::kNeon,
                                        KernelIsa::kBest};

bool runnable(KernelIsa isa) { return isa == KernelIsa::kBest || kernel_isa_supported(isa); }

std::string machine_name() {
  utsname u{};
  return uname(&u) == 0 ? std::string(u.machine) : std::string("this machine");
}
}  // namespace

const char* const kKernelOptionUsage =
    "  --kernel K           kernels to run: scalar (the reference), avx2, avx512 (x86-64), neon (aarch64)\n"
    "                       or best (default); all give the same results\n";

std::string runnable_kernel_names() {
  std::string names;
  for (KernelIsa isa : kKernelChoices)
    if (runnable(isa)) names += (names.empty() ? "" : ", ") + std::string(kernel_isa_name(isa));
  return names;
}

KernelIsa parse_kernel_option(const std::string& name) {
  for (KernelIsa isa : kKernelChoices) {
    if (name != kernel_isa_name(isa)) continue;
    if (!runnable(isa))
      fail("--kernel " + name + ": this build or CPU (" + machine_name() + ") cannot run it; it runs " +
           runnable_kernel_names());
    return isa;
  }
  fail("--kernel: unknown kernel '" + name + "' (scalar, avx2, avx512, neon or best)");
}

}  // namespace dp::tools
