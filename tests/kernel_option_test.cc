// `--kernel K` (tools/common/kernel_option.h): every kernel this machine runs is accepted by name,
// one it cannot run is refused naming the machine and the runnable ones, never silently replaced.
#include <gtest/gtest.h>

#include <string>

#include "runtime/depthpose.h"
#include "tools/common/error.h"
#include "tools/common/kernel_option.h"

using namespace dp;
using namespace dp::tools;

namespace {

std::string refusal(const std::string& name) {
  try {
    parse_kernel_option(name);
  } catch (const ToolError& e) {
    return e.what();
  }
  return "";
}

// What the CPU runs, read independently of the runtime's dispatch.
bool cpu_runs(KernelIsa isa) {
  switch (isa) {
#if defined(__x86_64__)
    case KernelIsa::kAvx2:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
    case KernelIsa::kAvx512:
      return cpu_runs(KernelIsa::kAvx2) && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
             __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq");
    case KernelIsa::kNeon: return false;
#elif defined(__aarch64__)
    case KernelIsa::kNeon: return true;
    case KernelIsa::kAvx2:
    case KernelIsa::kAvx512: return false;
#endif
    default: return true;
  }
}

}  // namespace

TEST(KernelOption, EveryNameIsAcceptedExactlyWhenThisMachineRunsIt) {
  for (KernelIsa isa : {KernelIsa::kScalar, KernelIsa::kAvx2, KernelIsa::kAvx512, KernelIsa::kNeon, KernelIsa::kBest}) {
    const std::string name = kernel_isa_name(isa);
    const std::string why = refusal(name);
    if (cpu_runs(isa)) {
      EXPECT_EQ(why, "") << name;
      EXPECT_EQ(parse_kernel_option(name), isa);
      EXPECT_NE(runnable_kernel_names().find(name), std::string::npos) << name;
    } else {
      EXPECT_NE(why.find("--kernel " + name + ": this build or CPU"), std::string::npos) << why;
      EXPECT_NE(why.find("it runs scalar"), std::string::npos) << why;
      EXPECT_EQ(runnable_kernel_names().find(name), std::string::npos) << name;
    }
  }
}

TEST(KernelOption, UnknownNamesAreRefusedWithTheList) {
  for (const char* bad : {"", "sse", "AVX2", "neon ", "fastest"}) {
    const std::string why = refusal(bad);
    EXPECT_NE(why.find("unknown kernel"), std::string::npos) << bad << ": " << why;
    EXPECT_NE(why.find("scalar, avx2, avx512, neon or best"), std::string::npos) << why;
  }
}
