// The field lists of common/system/fields.h on a record made for the test: adding, printing and
// visiting follow the list, derived values are shown but not added, embedded fields are inline.

#include "common/system/fields.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

namespace {

using mrt::Embedded;
using mrt::Field;

struct Inner {
    std::uint64_t count = 0;
    double weight = 0.0;

    static constexpr auto fields =
        std::tuple{Field{"count", &Inner::count}, Field{"weight", &Inner::weight}};
    Inner& operator+=(const Inner& o) { return mrt::add_fields(*this, o); }
};

struct Outer {
    int hits = 0;
    bool stopped = false;
    Inner inner;
    Inner nested;

    double twice_hits() const { return 2.0 * hits; }
    std::optional<double> weight_per_hit() const {
        return hits > 0 ? std::optional<double>(inner.weight / hits) : std::nullopt;
    }

    static constexpr auto fields = std::tuple{
        Field{"hits", &Outer::hits},
        Field{"stopped", &Outer::stopped},
        Embedded{&Outer::inner},
        Field{"nested", &Outer::nested},
        Field{"twice_hits", &Outer::twice_hits},
        Field{"weight_per_hit", &Outer::weight_per_hit},
    };
};

std::ostream& operator<<(std::ostream& os, const Inner& r) {
    return mrt::print_fields(os, "Inner", r);
}

std::ostream& operator<<(std::ostream& os, const Outer& r) {
    return mrt::print_fields(os, "Outer", r);
}

TEST(Fields, AddingFollowsTheListAsSummingByHand) {
    Outer a{3, false, {5, 0.25}, {7, 1.5}};
    const Outer b{4, true, {6, 0.5}, {8, 2.0}};
    mrt::add_fields(a, b);
    EXPECT_EQ(a.hits, 3 + 4);
    EXPECT_TRUE(a.stopped);  // a stop in either stops the sum
    EXPECT_EQ(a.inner.count, 5u + 6u);
    EXPECT_EQ(a.inner.weight, 0.25 + 0.5);
    EXPECT_EQ(a.nested.count, 7u + 8u);
    EXPECT_EQ(a.nested.weight, 1.5 + 2.0);
    EXPECT_EQ(a.twice_hits(), 14.0);  // derived from the sum, not summed
    Outer c;
    mrt::add_fields(c, Outer{});
    EXPECT_FALSE(c.stopped);
}

TEST(Fields, PrintingShowsEveryFieldInListOrder) {
    std::ostringstream os;
    os << Outer{2, true, {5, 0.5}, {1, 2.0}};
    EXPECT_EQ(os.str(),
              "Outer{hits 2, stopped true, count 5, weight 0.5, nested Inner{count 1, weight 2}, "
              "twice_hits 4, weight_per_hit 0.25}");
}

TEST(Fields, VisitingNamesEachFieldOnceWithEmbeddedFieldsInline) {
    std::vector<std::string> names;
    mrt::for_each_field(Outer{},
                        [&](std::string_view name, const auto&) { names.emplace_back(name); });
    EXPECT_EQ(names, (std::vector<std::string>{"hits", "stopped", "count", "weight", "nested",
                                               "twice_hits", "weight_per_hit"}));
}

}  // namespace
