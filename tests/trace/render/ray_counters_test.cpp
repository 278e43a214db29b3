// RayCounters' field list: += adds every kind, << and the total show them all.

#include "trace/render/render.h"

#include <gtest/gtest.h>

#include <sstream>

namespace {

TEST(RayCounters, AddingSumsEachKindAsByHand) {
    mrt::RayCounters a{1, 20, 300};
    const mrt::RayCounters b{4000, 50000, 600000};
    a += b;
    EXPECT_EQ(a.primary, 4001u);
    EXPECT_EQ(a.secondary, 50020u);
    EXPECT_EQ(a.shadow, 600300u);
    EXPECT_EQ(a.total(), 654321u);
}

TEST(RayCounters, PrintsEveryKindAndTheTotal) {
    std::ostringstream os;
    os << mrt::RayCounters{1, 2, 3};
    EXPECT_EQ(os.str(), "RayCounters{primary_rays 1, secondary_rays 2, shadow_rays 3, rays 6}");
}

}  // namespace
