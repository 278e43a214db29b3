// Method specs of mrt-compare (method_spec.h): parsing, refusals, the default runs and their
// budgets, all against the one table of methods and their options (trace/render/method.h).

#include "trace/results/method_spec.h"
#include "tests/support/test_support.h"
#include "trace/render/method.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace {

using mrt::testing::contains;
using mrt::testing::error_message;
using Args = std::vector<std::string>;

TEST(MethodSpec, NameAloneIsTheMethod) {
    const mrt::MethodSpec spec = mrt::parse_method_spec("whitted");
    EXPECT_EQ(spec.method, mrt::Method::Whitted);
    EXPECT_TRUE(spec.options.empty());
    EXPECT_EQ(mrt::trace_arguments(spec), (Args{"--method", "whitted"}));
}

TEST(MethodSpec, ValuesAndFlagsBecomeLongOptionsInOrder) {
    const mrt::MethodSpec spec =
        mrt::parse_method_spec("distributed:spp-max=16,no-dof,time-budget=2.5");
    EXPECT_EQ(spec.method, mrt::Method::Distributed);
    ASSERT_EQ(spec.options.size(), 3u);
    EXPECT_EQ(spec.options[0], (mrt::MethodOption{"spp-max", "16"}));
    EXPECT_EQ(spec.options[1], (mrt::MethodOption{"no-dof", std::nullopt}));
    EXPECT_EQ(mrt::trace_arguments(spec), (Args{"--method", "distributed", "--spp-max", "16",
                                                "--no-dof", "--time-budget", "2.5"}));
}

TEST(MethodSpec, ValuesKeepEveryCharacterAfterTheFirstEquals) {
    const mrt::MethodSpec spec = mrt::parse_method_spec("whitted:tag=a=b:c");
    EXPECT_EQ(mrt::trace_arguments(spec), (Args{"--method", "whitted", "--tag", "a=b:c"}));
}

TEST(MethodSpec, RefusesEveryKeyCompareSetsItself) {
    for (const std::string key : {"output", "stats", "quiet", "width", "height", "filter",
                                  "reference", "threads", "method", "seed"}) {
        for (const std::string& spec : {"distributed:" + key + "=1", "distributed:" + key}) {
            const std::string message = error_message([&] { mrt::parse_method_spec(spec); });
            EXPECT_TRUE(contains(message, "\"" + spec + "\"")) << message;
            EXPECT_TRUE(contains(message, "\"" + key + "\" is set by mrt-compare")) << message;
        }
    }
}

TEST(MethodSpec, MalformedSpecsSayWhatIsWrong) {
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"distributed:", "nothing follows ':'"},
        {":x=1", "the method name is empty"},
        {"", "the method name is empty"},
        {"a:b=", "option \"b\" has an empty value"},
        {"a:=3", "option \"=3\" has no key"},
        {"a:x=1,,y=2", "an empty option between commas"},
        {"a:x=1,", "an empty option between commas"},
        {"a:--spp=3", "write option \"--spp\" without dashes"},
        {"a:spp=1,spp=2", "option \"spp\" is given twice"},
        {"white space", "\"white space\" is not a method name"},
        {"a:sp p=1", "\"sp p\" is not an option name"},
    };
    for (const auto& [spec, problem] : cases) {
        const std::string message = error_message([&] { mrt::parse_method_spec(spec); });
        EXPECT_TRUE(contains(message, "method spec \"" + spec + "\": " + problem))
            << spec << " → " << message;
        EXPECT_TRUE(contains(message, "expected NAME[:key=value,...]")) << message;
    }
}

TEST(MethodSpec, SlugKeepsOnlyFileNameSafeCharacters) {
    EXPECT_EQ(mrt::spec_slug("whitted"), "whitted");
    EXPECT_EQ(mrt::spec_slug("distributed:spp-max=16"), "distributed-spp-max-16");
    EXPECT_EQ(mrt::spec_slug("distributed:time-budget=0.25"), "distributed-time-budget-0.25");
    EXPECT_EQ(mrt::spec_slug("a:b=x/y z,c_d"), "a-b-x-y-z-c-d");
}

TEST(MethodSpec, DefaultRunsAreTheDocumentedSet) {
    std::vector<std::string> fixed;
    std::vector<std::pair<double, std::string>> budgets;
    std::vector<std::string> searches;
    for (const mrt::DefaultRun& run : mrt::default_runs()) {
        if (run.to_equal_error) {
            searches.push_back(
                mrt::default_run_spec(run) + " to " + run.budget_base() +
                (run.measure == mrt::ErrorMeasure::DisplayRmse ? " display RMSE" : " RMSE"));
        } else if (run.budget_factor > 0.0) {
            EXPECT_TRUE(run.method == mrt::Method::Distributed ||
                        run.method == mrt::Method::ConeClassic)
                << run.method;
            budgets.emplace_back(run.budget_factor, run.budget_base());
        } else {
            fixed.push_back(mrt::default_run_spec(run));
        }
        mrt::parse_method_spec(mrt::default_run_spec(run));  // every entry is a valid spec
    }
    EXPECT_EQ(fixed,
              (Args{"whitted", "whitted:spp=4", "distributed:spp-max=4", "distributed:spp-max=16",
                    "distributed:spp-max=64", "cone", "cone:max-depth=0"}));
    // Distributed at 4×, 16×, 64× whitted's time; cone-classic stopped at 64×; primary rays of
    // cone-classic stopped at 16× cone's; distributed at cone's time.
    using Budgets = std::vector<std::pair<double, std::string>>;
    EXPECT_EQ(budgets, (Budgets{{4.0, "whitted"},
                                {16.0, "whitted"},
                                {64.0, "whitted"},
                                {64.0, "whitted"},
                                {16.0, "cone:max-depth=0"},
                                {1.0, "cone"}}));
    EXPECT_EQ(searches, (Args{"distributed to cone RMSE", "distributed to cone display RMSE"}));
    EXPECT_EQ(mrt::baseline_spec(), "whitted");
    EXPECT_EQ(mrt::default_run_spec(mrt::default_runs().front()), mrt::baseline_spec());
    // A run's budget is measured against a fixed run that comes before it.
    for (std::size_t i = 0; i < mrt::default_runs().size(); ++i) {
        const mrt::DefaultRun& run = mrt::default_runs()[i];
        if (run.budget_factor > 0.0) {
            const bool before = std::any_of(
                mrt::default_runs().begin(), mrt::default_runs().begin() + static_cast<long>(i),
                [&](const mrt::DefaultRun& r) {
                    return r.budget_factor == 0.0 && mrt::default_run_spec(r) == run.budget_base();
                });
            EXPECT_TRUE(before) << mrt::default_run_spec(run);
        }
    }
}

TEST(MethodSpec, TimeBudgetsAreReadBackOnlyFromTheirOwnKindOfSpec) {
    mrt::DefaultRun distributed;
    distributed.method = mrt::Method::Distributed;
    EXPECT_EQ(mrt::time_budget_of(mrt::spec_with_budget(distributed, 0.1234), distributed), 0.123);
    EXPECT_EQ(mrt::time_budget_of("distributed:time-budget=2", distributed), 2.0);
    EXPECT_FALSE(mrt::time_budget_of("distributed:spp-max=4", distributed));
    EXPECT_FALSE(mrt::time_budget_of("distributed:time-budget=2,spp-max=4", distributed));
    EXPECT_FALSE(mrt::time_budget_of("distributed:time-budget=", distributed));
    EXPECT_FALSE(mrt::time_budget_of("cone-classic:time-budget=2", distributed));
    mrt::DefaultRun classic;
    classic.method = mrt::Method::ConeClassic;
    classic.options = "max-depth=0";
    EXPECT_EQ(mrt::time_budget_of("cone-classic:max-depth=0,time-budget=1.5", classic), 1.5);
    EXPECT_FALSE(mrt::time_budget_of("cone-classic:time-budget=1.5", classic));
}

TEST(MethodSpec, BudgetsHaveThreeSignificantDigitsAndAFloor) {
    EXPECT_EQ(mrt::format_budget_seconds(0.0), "0.05");
    EXPECT_EQ(mrt::format_budget_seconds(0.012), "0.05");
    EXPECT_EQ(mrt::format_budget_seconds(0.05), "0.05");
    EXPECT_EQ(mrt::format_budget_seconds(0.0512345), "0.0512");
    EXPECT_EQ(mrt::format_budget_seconds(0.123456), "0.123");
    EXPECT_EQ(mrt::format_budget_seconds(1.23456), "1.23");
    EXPECT_EQ(mrt::format_budget_seconds(2.0), "2");
    EXPECT_EQ(mrt::format_budget_seconds(9.996), "10");
    EXPECT_EQ(mrt::format_budget_seconds(12.3456), "12.3");
    EXPECT_EQ(mrt::format_budget_seconds(123.456), "123");
    EXPECT_EQ(mrt::format_budget_seconds(1234.5), "1230");
    EXPECT_EQ(mrt::format_budget_seconds(std::numeric_limits<double>::quiet_NaN()), "0.05");
    const mrt::DefaultRun twice{mrt::Method::Distributed, "", 2.0};
    EXPECT_EQ(mrt::budget_run_spec(twice, 0.1234), "distributed:time-budget=0.247");
    const mrt::DefaultRun with_options{mrt::Method::Distributed, "spp-initial=2", 8.0};
    EXPECT_EQ(mrt::budget_run_spec(with_options, 0.001),
              "distributed:spp-initial=2,time-budget=0.1");
    // Budgets of a tiny baseline stay distinct.
    const mrt::DefaultRun four{mrt::Method::Distributed, "", 4.0};
    const mrt::DefaultRun sixteen{mrt::Method::Distributed, "", 16.0};
    EXPECT_EQ(mrt::budget_run_spec(four, 0.001), "distributed:time-budget=0.05");
    EXPECT_EQ(mrt::budget_run_spec(sixteen, 0.001), "distributed:time-budget=0.2");
}

TEST(MethodSpec, EveryMethodsDefaultRunsAreMade) {
    for (const mrt::Method method : mrt::kMethods) {
        const bool has_runs =
            std::any_of(mrt::default_runs().begin(), mrt::default_runs().end(),
                        [&](const mrt::DefaultRun& run) { return run.method == method; });
        EXPECT_TRUE(has_runs) << method;
    }
}

TEST(MethodSpec, AnOptionOnlyOtherMethodsTakeIsRefusedUpFront) {
    const auto& set_by_compare = mrt::refused_option_keys();
    for (const mrt::MethodOnlyOption& option : mrt::method_only_options()) {
        if (std::find(set_by_compare.begin(), set_by_compare.end(), option.key) !=
            set_by_compare.end()) {
            continue;  // refused in every spec
        }
        for (const mrt::Method method : mrt::kMethods) {
            const std::string spec =
                std::string(mrt::to_string(method)) + ":" + std::string(option.key) + "=1";
            if (option.methods.contains(method)) {
                EXPECT_EQ(mrt::parse_method_spec(spec).options.size(), 1u) << spec;
                continue;
            }
            const std::string message = error_message([&] { mrt::parse_method_spec(spec); });
            EXPECT_TRUE(contains(message, "method spec \"" + spec + "\": the " +
                                              std::string(mrt::to_string(method)) +
                                              " method does not take option \"" +
                                              std::string(option.key) + "\""))
                << message;
            EXPECT_TRUE(contains(message, mrt::refusal(option))) << message;
        }
    }
    EXPECT_TRUE(contains(error_message([] { mrt::parse_method_spec("whitted:spp-max=4"); }),
                         "(only the distributed method takes it)"));
}

TEST(MethodSpec, ANameThatIsNoMethodIsRefusedWithTheChoices) {
    const std::string message = error_message([] { mrt::parse_method_spec("path:spp=4"); });
    EXPECT_TRUE(contains(message,
                         "\"path\" is not a method of mrt-trace (whitted, distributed, "
                         "cone or cone-classic)"))
        << message;
}

}  // namespace
