// MRT_CHECK: a failed internal invariant names the file, the line and the condition, then aborts;
// a true one does nothing and evaluates its condition once. MRT_DCHECK is the same in Debug and
// not evaluated at all with NDEBUG.

#include "common/system/check.h"

#include <gtest/gtest.h>

#include <string>

namespace mrt {
namespace {

TEST(CheckDeathTest, FailedCheckAbortsNamingFileLineAndCondition) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    const int index = 3;
    const int size = 3;
    // The message's line is the one of the MRT_CHECK below.
    const std::string expected = std::string("check_test\\.cpp:") + std::to_string(__LINE__ + 2) +
                                 ": check failed: index < size";
    EXPECT_DEATH(MRT_CHECK(index < size), expected);
}

TEST(Check, PassingCheckEvaluatesItsConditionOnce) {
    int evaluations = 0;
    MRT_CHECK(++evaluations == 1);
    EXPECT_EQ(evaluations, 1);
}

TEST(CheckDeathTest, DebugCheckAbortsOnlyInDebugBuilds) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    int evaluations = 0;
#ifdef NDEBUG
    MRT_DCHECK(++evaluations == 0);
    EXPECT_EQ(evaluations, 0);  // compiled, never evaluated
#else
    EXPECT_DEATH(MRT_DCHECK(++evaluations == 0), "check failed: \\+\\+evaluations == 0");
#endif
}

}  // namespace
}  // namespace mrt
