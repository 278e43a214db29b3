// The table of methods (trace/render/method.h): names round-trip, and what the options table
// says is what mrt-trace and mrt-compare say when they refuse an option.

#include "trace/render/method.h"
#include "common/system/error.h"

#include <gtest/gtest.h>

#include <set>
#include <sstream>
#include <string>

namespace {

using mrt::Method;

TEST(Method, EveryMethodParsesBackFromItsName) {
    std::set<std::string> names;
    for (const Method method : mrt::kMethods) {
        const std::string name(mrt::to_string(method));
        EXPECT_EQ(mrt::parse_method(name), method) << name;
        EXPECT_EQ(mrt::find_method(name), method) << name;
        std::ostringstream printed;
        printed << method;
        EXPECT_EQ(printed.str(), name);
        names.insert(name);
    }
    EXPECT_EQ(names.size(), mrt::kMethods.size()) << "two methods share a name";
    EXPECT_EQ(mrt::method_names(),
              (std::vector<std::string>{"whitted", "distributed", "cone", "cone-classic"}));
}

TEST(Method, AnUnknownNameIsRefusedWithTheChoices) {
    EXPECT_FALSE(mrt::find_method("Whitted"));
    EXPECT_FALSE(mrt::find_method(""));
    try {
        mrt::parse_method("path");
        FAIL() << "no error";
    } catch (const mrt::Error& e) {
        EXPECT_STREQ(e.what(),
                     "method \"path\": no such method (expected whitted, distributed, "
                     "cone or cone-classic)");
    }
}

TEST(Method, OnlyTheConeMethodsAreCone) {
    EXPECT_FALSE(mrt::is_cone(Method::Whitted));
    EXPECT_FALSE(mrt::is_cone(Method::Distributed));
    EXPECT_TRUE(mrt::is_cone(Method::Cone));
    EXPECT_TRUE(mrt::is_cone(Method::ConeClassic));
}

TEST(MethodOptions, EachIsTakenBySomeButNotAllMethods) {
    std::set<std::string> keys;
    for (const mrt::MethodOnlyOption& option : mrt::method_only_options()) {
        int takers = 0;
        for (const Method method : mrt::kMethods) {
            takers += option.methods.contains(method) ? 1 : 0;
            EXPECT_EQ(mrt::takes_option(method, option.key), option.methods.contains(method));
        }
        EXPECT_GT(takers, 0) << option.key;
        EXPECT_LT(takers, static_cast<int>(mrt::kMethods.size())) << option.key;
        EXPECT_EQ(mrt::find_method_only_option(option.key), &option);
        EXPECT_TRUE(keys.insert(std::string(option.key)).second) << option.key << " twice";
    }
    // An option of every method (or of none) is not in the table.
    EXPECT_EQ(mrt::find_method_only_option("width"), nullptr);
    for (const Method method : mrt::kMethods) {
        EXPECT_TRUE(mrt::takes_option(method, "width"));
    }
}

TEST(MethodOptions, RefusalsNameTheMethodsThatTakeTheOption) {
    const auto refusal_of = [](std::string_view key) {
        return mrt::refusal(*mrt::find_method_only_option(key));
    };
    EXPECT_EQ(refusal_of("spp-max"), "only the distributed method takes it");
    EXPECT_EQ(refusal_of("max-anisotropy"), "only the cone methods take it");
    EXPECT_EQ(refusal_of("time-budget"), "only the distributed and the cone methods take it");
    EXPECT_EQ(refusal_of("spp"),
              "the cone methods trace one cone per pixel (more where --refine asks)");
    const mrt::MethodOnlyOption classic{"x", {Method::Whitted, Method::ConeClassic}};
    EXPECT_EQ(mrt::refusal(classic), "only the whitted and the cone-classic methods take it");
}

}  // namespace
