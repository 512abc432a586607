// platform::ArenaMemory: alignment, zero fill, ownership, huge-page advice only for large arenas, and
// clear errors for sizes that cannot be mapped.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <utility>

#include "platform/arena_memory.h"
#include "tools/common/error.h"

using dp::platform::ArenaMemory;

namespace {

bool all_zero(const uint8_t* p, size_t n) {
  for (size_t i = 0; i < n; ++i)
    if (p[i]) return false;
  return true;
}

TEST(ArenaMemory, LargeArenaIsHugePageAlignedZeroedAndWritable) {
  const size_t bytes = 5 * ArenaMemory::kHugePageBytes + 12345;
  ArenaMemory a(bytes);
  ASSERT_NE(a.data(), nullptr);
  EXPECT_EQ(a.size(), bytes);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(a.data()) % ArenaMemory::kHugePageBytes, 0u);
  EXPECT_TRUE(all_zero(a.data(), bytes));
  a.data()[0] = 1;
  a.data()[bytes - 1] = 2;
  EXPECT_EQ(a.data()[0] + a.data()[bytes - 1], 3);
}

TEST(ArenaMemory, SmallArenaIsPageAlignedAndNotAdvised) {
  ArenaMemory a(1000);
  ASSERT_NE(a.data(), nullptr);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(a.data()) % 4096, 0u);
  EXPECT_FALSE(a.huge_page_advice());
  EXPECT_TRUE(all_zero(a.data(), 1000));
}

TEST(ArenaMemory, MovesOwnership) {
  ArenaMemory a(3 * ArenaMemory::kHugePageBytes);
  uint8_t* p = a.data();
  const bool advised = a.huge_page_advice();
  ArenaMemory b(std::move(a));
  EXPECT_EQ(a.data(), nullptr);
  EXPECT_EQ(a.size(), 0u);
  EXPECT_EQ(b.data(), p);
  EXPECT_EQ(b.huge_page_advice(), advised);
  ArenaMemory c(64);
  c = std::move(b);  // c's own mapping is released, b's is taken over
  EXPECT_EQ(c.data(), p);
  EXPECT_EQ(b.data(), nullptr);
  c.data()[3 * ArenaMemory::kHugePageBytes - 1] = 7;
}

TEST(ArenaMemory, RefusedSizesNameTheProblem) {
  try {
    ArenaMemory a(0);
    FAIL() << "zero bytes accepted";
  } catch (const dp::tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("zero bytes"), std::string::npos) << e.what();
  }
  const size_t absurd = size_t(1) << 62;
  try {
    ArenaMemory a(absurd);
    FAIL() << "a 4 EiB mapping succeeded";
  } catch (const dp::tools::ToolError& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(absurd) + "-byte arena"), std::string::npos) << e.what();
  }
}

}  // namespace
