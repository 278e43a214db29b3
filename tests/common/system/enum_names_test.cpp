// One table of names per enum (enum_names.h): names and values read back to each other, and
// the lists a command line and a message show come from the same table.

#include "common/system/enum_names.h"

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <string_view>

namespace mrt {
namespace {

enum class Colour { Red, Green, Blue };

constexpr EnumNames<Colour, 3> kColourNames{{{
    {Colour::Red, "red"},
    {Colour::Green, "green"},
    {Colour::Blue, "blue"},
}}};

TEST(EnumNames, EveryValueReadsBackFromItsName) {
    std::set<std::string_view> seen;
    for (const auto& [value, name] : kColourNames) {
        EXPECT_EQ(kColourNames.name(value), name);
        EXPECT_EQ(kColourNames.find(name), value) << name;
        EXPECT_TRUE(seen.insert(name).second) << name << " is listed twice";
    }
    EXPECT_EQ(seen.size(), kColourNames.size());
}

TEST(EnumNames, UnknownNamesAndValuesAreSaidSo) {
    EXPECT_FALSE(kColourNames.find("Red").has_value());  // names are case-sensitive
    EXPECT_FALSE(kColourNames.find("").has_value());
    EXPECT_FALSE(kColourNames.find("red ").has_value());
    const auto corrupt = static_cast<Colour>(7);
    EXPECT_EQ(kColourNames.name(corrupt), "unknown");
    EXPECT_EQ(kColourNames.name(corrupt, "colour"), "colour");
}

TEST(EnumNames, ListsKeepTheTablesOrder) {
    EXPECT_EQ(kColourNames.names(), (std::vector<std::string>{"red", "green", "blue"}));
    EXPECT_EQ(kColourNames.choices(), "red, green or blue");
    EXPECT_EQ(kColourNames.choices(" and "), "red, green and blue");
    constexpr EnumNames<Colour, 1> one{{{{Colour::Blue, "blue"}}}};
    EXPECT_EQ(one.choices(), "blue");
}

TEST(EnumNames, LookupsWorkAtCompileTime) {
    static_assert(kColourNames.name(Colour::Green) == "green");
    static_assert(*kColourNames.find("blue") == Colour::Blue);
    static_assert(!kColourNames.find("purple"));
}

}  // namespace
}  // namespace mrt
