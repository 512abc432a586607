// A GoogleTest binary that fails on purpose, in every way mk/test_summary.sh must count:
// a suite whose SetUpTestSuite fails (its tests are then skipped), a test that skips itself,
// a failing test and a passing one. mk/test_summary_selftest.sh runs it and checks the summary.
// Not part of the depthpose test binary (tests/probes/ is excluded from TEST_SRCS).
#include <gtest/gtest.h>

namespace {

class SuiteWhoseSetUpFails : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { FAIL() << "probe: suite-level set-up failure (as when ../shared is missing)"; }
};

TEST_F(SuiteWhoseSetUpFails, FirstTestIsSkipped) { EXPECT_TRUE(true); }
TEST_F(SuiteWhoseSetUpFails, SecondTestIsSkipped) { EXPECT_TRUE(true); }

TEST(ProbePasses, Passes) { EXPECT_EQ(2 + 2, 4); }
TEST(ProbeSkips, SkipsItself) { GTEST_SKIP() << "probe: a skipped test"; }
TEST(ProbeFails, Fails) { EXPECT_EQ(2 + 2, 5) << "probe: a failing test"; }

}  // namespace
