// Budgets: saturating counts against exact 128-bit arithmetic, the NAME=VALUE assignments of the
// command line, and the refusal's one-line message.

#include "common/system/budgets.h"
#include "common/system/error.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <random>
#include <string>

namespace mrt {
namespace {

constexpr std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();
// The exact reference: 128-bit products never overflow 64-bit operands.
__extension__ typedef unsigned __int128 Exact;

TEST(Budgets, SaturatingArithmeticMatchesExactArithmeticClampedToTheLargestCount) {
    std::mt19937_64 rng(7);
    for (int i = 0; i < 100000; ++i) {
        // Operands of every magnitude, so products both fit and overflow.
        const std::uint64_t a = rng() >> (rng() % 64);
        const std::uint64_t b = rng() >> (rng() % 64);
        const Exact sum = static_cast<Exact>(a) + b;
        const Exact product = static_cast<Exact>(a) * b;
        EXPECT_EQ(saturating_add(a, b), sum > kMax ? kMax : static_cast<std::uint64_t>(sum));
        EXPECT_EQ(saturating_mul(a, b),
                  product > kMax ? kMax : static_cast<std::uint64_t>(product));
    }
    EXPECT_EQ(saturating_mul(0, kMax), 0u);
    EXPECT_EQ(saturating_mul(kMax, 1), kMax);
    EXPECT_EQ(saturating_add(kMax, 0), kMax);
    EXPECT_EQ(saturating_mul(saturating_mul(1ull << 40, 1ull << 40), 0), 0u);
}

TEST(Budgets, AssignmentsAcceptWholeNumbersInEitherNotation) {
    Budgets b;
    set_budget(b, "instances=12345");
    EXPECT_EQ(b.instances, 12345u);
    set_budget(b, "instanced-triangles=2e10");
    EXPECT_EQ(b.instanced_triangles, 20'000'000'000u);
    set_budget(b, "group-nesting=18446744073709551615");
    EXPECT_EQ(b.group_nesting, kMax);
    for (const std::string_view name : kBudgetNames) {
        set_budget(b, std::string(name) + "=3");
        EXPECT_EQ(budget(b, name), 3u) << name;
    }
}

TEST(Budgets, BadAssignmentsAreRefusedSayingWhatWasExpected) {
    Budgets b;
    const auto message = [&](const std::string& assignment) {
        try {
            set_budget(b, assignment);
        } catch (const Error& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    EXPECT_NE(message("instances").find("expected NAME=VALUE"), std::string::npos);
    EXPECT_NE(message("voxel=3").find("unknown budget 'voxel' (expected one of instanced-"),
              std::string::npos);
    for (const char* bad : {"instances=0", "instances=-1", "instances=1.5",
                            "instances=", "instances=1e30", "instances=nan", "instances=12x"}) {
        EXPECT_NE(message(bad).find("expected a whole number"), std::string::npos) << bad;
    }
    EXPECT_EQ(b.instances, Budgets{}.instances);
}

TEST(Budgets, ARefusalNamesTheFileWhatIsAskedTheLimitAndTheFlag) {
    Budgets b;
    b.instances = 1000;
    EXPECT_NO_THROW(check_budget(b, "instances", 1000, "instances", "s.json", "/objects/2"));
    try {
        check_budget(b, "instances", 4'500'000'000, "instances", "s.json", "/objects/2");
        FAIL() << "not refused";
    } catch (const Error& e) {
        EXPECT_STREQ(e.what(),
                     "s.json: /objects/2: the scene asks for 4.5e+09 instances, over the limit of "
                     "1000 (raise it with --budget instances=N)");
    }
    try {
        check_budget(b, "instances", kMax, "instances", "s.json", "");
        FAIL() << "not refused";
    } catch (const Error& e) {
        EXPECT_STREQ(e.what(),
                     "s.json: the scene asks for more than 1.8e19 instances, over the limit of "
                     "1000 (raise it with --budget instances=N)");
    }
}

}  // namespace
}  // namespace mrt
