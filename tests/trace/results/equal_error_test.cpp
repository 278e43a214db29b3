// Reading a curve of error against time (equal_error.h), the search for the budget that reaches
// an error, and the headline ratios and equal-time and equal-error figures built on them
// (headline_ratios.h, derived_figures.h). The curves are power
// laws, on which the log–log line between two runs is exact, so every interpolation has an
// analytic answer.

#include "trace/results/equal_error.h"
#include "trace/results/derived_figures.h"
#include "trace/results/headline_ratios.h"
#include "trace/results/method_spec.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

namespace {

using mrt::CurvePoint;
using mrt::TimeToErrorKind;

/// RMSE = c · t^slope, sampled at `times`.
std::vector<CurvePoint> power_law(double c, double slope, const std::vector<double>& times) {
    std::vector<CurvePoint> points;
    for (const double t : times) {
        points.push_back({t, c * std::pow(t, slope), t});
    }
    return points;
}

TEST(EqualError, BetweenTwoRunsThePowerLawIsRecoveredExactly) {
    const std::vector<CurvePoint> curve = power_law(0.1, -0.7, {0.1, 0.4, 1.6, 6.4});
    for (const double t : {0.15, 1.0, 5.0}) {
        const auto at = mrt::time_to_error(curve, 0.1 * std::pow(t, -0.7), 1.0);
        ASSERT_TRUE(at);
        EXPECT_EQ(at->kind, TimeToErrorKind::Interpolated) << t;
        EXPECT_NEAR(at->seconds, t, 1e-12 * t);
        const auto back = mrt::rmse_at_time(curve, t, 1.0);
        ASSERT_TRUE(back);
        EXPECT_EQ(back->kind, TimeToErrorKind::Interpolated);
        EXPECT_NEAR(back->rmse, 0.1 * std::pow(t, -0.7), 1e-12);
    }
    // The order of the runs does not matter.
    std::vector<CurvePoint> shuffled = curve;
    std::reverse(shuffled.begin(), shuffled.end());
    EXPECT_NEAR(mrt::time_to_error(shuffled, 0.1, 1.0)->seconds, 1.0, 1e-12);
}

TEST(EqualError, ARunWithinTheToleranceIsTheAnswerAndBoundsAreSaid) {
    const std::vector<CurvePoint> curve = power_law(0.1, -0.5, {0.25, 1.0, 4.0});
    const auto measured = mrt::time_to_error(curve, 0.1 * 1.04);
    ASSERT_TRUE(measured);
    EXPECT_EQ(measured->kind, TimeToErrorKind::Measured);
    EXPECT_EQ(measured->seconds, 1.0);
    EXPECT_EQ(measured->rmse, 0.1);

    const auto at_most = mrt::time_to_error(curve, 1.0);  // far above the fastest run's 0.2
    ASSERT_TRUE(at_most);
    EXPECT_EQ(at_most->kind, TimeToErrorKind::AtMost);
    EXPECT_EQ(at_most->seconds, 0.25);
    const auto at_least = mrt::time_to_error(curve, 0.001);
    ASSERT_TRUE(at_least);
    EXPECT_EQ(at_least->kind, TimeToErrorKind::AtLeast);
    EXPECT_EQ(at_least->seconds, 4.0);

    EXPECT_FALSE(mrt::time_to_error({}, 0.1));
    EXPECT_FALSE(mrt::time_to_error(curve, 0.0));
    EXPECT_FALSE(mrt::time_to_error(curve, std::nan("")));
    // Unusable runs are skipped, not read as zero.
    const std::vector<CurvePoint> broken = {{0.0, 0.5, 0.0}, {1.0, std::nan(""), 1.0}};
    EXPECT_FALSE(mrt::time_to_error(broken, 0.1));

    EXPECT_EQ(mrt::rmse_at_time(curve, 1.05)->kind, TimeToErrorKind::Measured);
    EXPECT_EQ(mrt::rmse_at_time(curve, 1.05)->rmse, 0.1);
    EXPECT_FALSE(mrt::rmse_at_time(curve, 10.0)) << "beyond the slowest run: no answer";
    EXPECT_FALSE(mrt::rmse_at_time(curve, 0.1));
}

TEST(EqualError, ANoisyCurveIsReadWhereItFirstReachesTheTarget) {
    // The curve rises between 2 s and 4 s; the target 0.055 is first reached before 2 s.
    const std::vector<CurvePoint> curve = {{1, 0.1, 1}, {2, 0.05, 2}, {4, 0.06, 4}, {8, 0.02, 8}};
    const auto at = mrt::time_to_error(curve, 0.055, 1.0);
    ASSERT_TRUE(at);
    EXPECT_EQ(at->kind, TimeToErrorKind::Interpolated);
    const double expected = std::pow(2.0, std::log(0.055 / 0.1) / std::log(0.05 / 0.1));
    EXPECT_NEAR(at->seconds, expected, 1e-12);
    EXPECT_GT(at->seconds, 1.0);
    EXPECT_LT(at->seconds, 2.0);
}

/// Runs the search against a model tracer `rmse_of(budget)` taking `seconds_of(budget)`, from
/// the runs at `start`; returns the curve it measured and how many renders it asked for.
std::pair<std::vector<CurvePoint>, int> search(const std::function<double(double)>& seconds_of,
                                               const std::function<double(double)>& rmse_of,
                                               const std::vector<double>& start, double target,
                                               double min_budget, double max_budget) {
    std::vector<CurvePoint> curve;
    for (const double b : start) {
        curve.push_back({seconds_of(b), rmse_of(b), b});
    }
    int renders = 0;
    while (const auto budget =
               mrt::next_equal_error_budget(curve, target, min_budget, max_budget)) {
        EXPECT_GE(*budget, min_budget);
        EXPECT_LE(*budget, max_budget);
        curve.push_back({seconds_of(*budget), rmse_of(*budget), *budget});
        if (++renders > 20) {
            ADD_FAILURE() << "the search does not end";
            break;
        }
    }
    return {curve, renders};
}

TEST(EqualError, TheSearchMeasuresTheTargetWithinItsRenders) {
    // Power laws from a fast-converging adaptive sampler to a slow one, with a ±3 % ripple that
    // the log–log line does not know about, and targets inside and outside the first runs.
    for (const double slope : {-0.3, -0.5, -0.9, -1.5}) {
        const auto seconds_of = [](double b) { return b; };
        const auto rmse_of = [&](double b) {
            return 0.05 * std::pow(b, slope) * (1.0 + 0.03 * std::sin(7.0 * std::log(b)));
        };
        for (const double target_time : {0.07, 0.3, 0.9, 3.0, 11.0, 40.0}) {
            const double target = 0.05 * std::pow(target_time, slope);
            SCOPED_TRACE(::testing::Message() << "slope " << slope << ", time " << target_time);
            const auto [curve, renders] =
                search(seconds_of, rmse_of, {0.2, 0.8, 3.2}, target, 0.05, 64.0);
            EXPECT_LE(renders, mrt::kMaxEqualErrorRenders);
            const auto at = mrt::time_to_error(curve, target);
            ASSERT_TRUE(at);
            EXPECT_EQ(at->kind, TimeToErrorKind::Measured);
            // Within the tolerance in RMSE means within its power of 1/slope in time (plus the
            // ripple's share).
            EXPECT_LT(std::abs(std::log(at->seconds / target_time)),
                      (std::log(mrt::kEqualErrorTolerance) + 0.07) / std::abs(slope));
        }
    }
}

TEST(EqualError, TheSearchStopsAtItsLimitsAndAtAFirstPassLongerThanTheBudget) {
    const auto rmse_of = [](double b) { return 0.05 / std::sqrt(b); };
    // Below the smallest budget: the tracer's first pass takes 0.12 s whatever it is given.
    const auto with_first_pass = [](double b) { return std::max(b, 0.12); };
    const auto [fast, fast_renders] = search(
        with_first_pass, [&](double b) { return rmse_of(std::max(b, 0.12)); }, {0.2, 0.8, 3.2}, 1.0,
        0.05, 64.0);
    // One render at a smaller budget shows the first pass's floor; none after it.
    EXPECT_EQ(fast_renders, 1);
    const auto at_most = mrt::time_to_error(fast, 1.0);
    ASSERT_TRUE(at_most);
    EXPECT_EQ(at_most->kind, TimeToErrorKind::AtMost);
    EXPECT_EQ(at_most->seconds, 0.12);

    // Beyond the largest budget: one render at the cap, then a bound.
    const auto [slow, slow_renders] =
        search([](double b) { return b; }, rmse_of, {0.2, 0.8, 3.2}, 1e-4, 0.05, 8.0);
    EXPECT_LE(slow_renders, 2);
    const auto at_least = mrt::time_to_error(slow, 1e-4);
    ASSERT_TRUE(at_least);
    EXPECT_EQ(at_least->kind, TimeToErrorKind::AtLeast);
    EXPECT_NEAR(at_least->seconds, 8.0, 1e-12);
}

/// A run whose display RMSE is half its RMSE unless given.
mrt::RunResult run(const std::string& spec, double seconds, double rmse, bool stopped = false,
                   double display_rmse = 0.0) {
    mrt::RunResult r;
    r.spec = spec;
    r.method = mrt::parse_method_spec(spec).method;
    r.render_seconds = seconds;
    r.rmse = rmse;
    r.display_rmse = display_rmse > 0.0 ? display_rmse : rmse / 2;
    r.stopped = stopped;
    return r;
}

const mrt::HeadlineRatio* find(const std::vector<mrt::HeadlineRatio>& ratios,
                               const std::string& key) {
    const auto it = std::find_if(ratios.begin(), ratios.end(),
                                 [&](const mrt::HeadlineRatio& r) { return r.key == key; });
    return it != ratios.end() ? &*it : nullptr;
}

TEST(HeadlineRatios, EachIsTheQuotientOfTheRunsItNames) {
    const std::vector<mrt::RunResult> runs = {
        run("whitted", 0.1, 0.2),
        run("whitted:spp=4", 0.4, 0.15),
        run("distributed:spp-max=4", 0.5, 0.01),  // another curve: not read
        run("distributed:time-budget=0.4", 0.4, 0.08),
        run("distributed:time-budget=1.6", 1.6, 0.04),
        run("distributed:spp-initial=4,time-budget=2", 2.0, 0.001),  // not read either
        run("cone", 2.0, 0.05, false, 0.01),
        run("cone-classic:time-budget=6.4", 6.4, 0.3, true),
        run("cone:max-depth=0", 0.5, 0.1),
        run("cone-classic:max-depth=0,time-budget=8", 1.4, 0.1),
        run("distributed:time-budget=2", 2.0, 0.035),
        run("distributed:time-budget=1.1", 1.1, 0.051),
    };
    const std::vector<mrt::HeadlineRatio> ratios = mrt::headline_ratios(runs);
    ASSERT_EQ(ratios.size(), 5u);

    const auto* speed = find(ratios, "cone_over_whitted");
    ASSERT_NE(speed, nullptr);
    EXPECT_DOUBLE_EQ(speed->value, 20.0);
    EXPECT_EQ(speed->relation, mrt::RatioRelation::Equal);
    EXPECT_EQ(speed->numerator, "cone");
    EXPECT_EQ(speed->denominator, "whitted");

    const auto* reach = find(ratios, "distributed_to_cone_error");
    ASSERT_NE(reach, nullptr);
    EXPECT_EQ(reach->numerator, "distributed:time-budget=1.1");  // 0.051 is within 5 % of 0.05
    EXPECT_DOUBLE_EQ(reach->value, 0.55);
    EXPECT_EQ(reach->how, "measured");

    // In display RMSE the cone's 0.01 lies between the 2 s run's 0.0175 and the slowest, 2.0 s
    // spp-initial run that is not on the curve: no distributed run reaches it.
    const auto* display = find(ratios, "distributed_to_cone_display_error");
    ASSERT_NE(display, nullptr);
    EXPECT_EQ(display->relation, mrt::RatioRelation::AtLeast);
    EXPECT_EQ(display->numerator, "distributed:time-budget=2");
    EXPECT_DOUBLE_EQ(display->value, 1.0);

    const auto* equal_time = find(ratios, "distributed_rmse_at_cone_time");
    ASSERT_NE(equal_time, nullptr);
    EXPECT_EQ(equal_time->numerator, "distributed:time-budget=2");
    EXPECT_DOUBLE_EQ(equal_time->value, 0.035 / 0.05);

    const auto* primary = find(ratios, "classic_over_cone_primary");
    ASSERT_NE(primary, nullptr);
    EXPECT_DOUBLE_EQ(primary->value, 1.4 / 0.5);
    EXPECT_EQ(primary->relation, mrt::RatioRelation::Equal);
}

TEST(HeadlineRatios, BoundsAreSaidAndMissingRunsLeaveTheirRatioOut) {
    std::vector<mrt::RunResult> runs = {
        run("cone", 2.0, 0.5),
        run("distributed:time-budget=0.4", 0.4, 0.08),
        run("distributed:time-budget=1.6", 1.6, 0.04),
        run("cone:max-depth=0", 0.5, 0.1),
        run("cone-classic:max-depth=0,time-budget=8", 8.0, 0.3, true),
    };
    const std::vector<mrt::HeadlineRatio> ratios = mrt::headline_ratios(runs);
    EXPECT_EQ(find(ratios, "cone_over_whitted"), nullptr) << "no whitted run";
    const auto* reach = find(ratios, "distributed_to_cone_error");
    ASSERT_NE(reach, nullptr);
    EXPECT_EQ(reach->relation, mrt::RatioRelation::AtMost);
    EXPECT_DOUBLE_EQ(reach->value, 0.2);
    EXPECT_EQ(mrt::relation_prefix(reach->relation), "≤ ");
    EXPECT_EQ(find(ratios, "distributed_rmse_at_cone_time"), nullptr)
        << "no run near cone's 2 s, and 2 s is beyond the slowest";
    const auto* primary = find(ratios, "classic_over_cone_primary");
    ASSERT_NE(primary, nullptr);
    EXPECT_EQ(primary->relation, mrt::RatioRelation::AtLeast);
    EXPECT_DOUBLE_EQ(primary->value, 16.0);

    runs[0].rmse = 0.001;  // more accurate than any distributed run
    const auto* never = find(mrt::headline_ratios(runs), "distributed_to_cone_error");
    ASSERT_NE(never, nullptr);
    EXPECT_EQ(never->relation, mrt::RatioRelation::AtLeast);
    EXPECT_DOUBLE_EQ(never->value, 0.8);
    EXPECT_TRUE(mrt::headline_ratios({}).empty());
}

TEST(DerivedFigures, CurvesGroupTheRunsThatDifferOnlyInTheirSampleCounts) {
    EXPECT_EQ(mrt::curve_label("whitted"), "whitted");
    EXPECT_EQ(mrt::curve_label("whitted:spp=4"), "whitted");
    EXPECT_EQ(mrt::curve_label("distributed:spp-max=16,spp-initial=4"), "distributed");
    EXPECT_EQ(mrt::curve_label("whitted:spp=4,texture-filter=trilinear"),
              "whitted (texture-filter=trilinear)");
    EXPECT_EQ(mrt::curve_label("distributed:time-budget=2,texture-filter=none"),
              "distributed (time budget, texture-filter=none)");
    EXPECT_EQ(mrt::curve_label("whitted:differentials=always,spp=1"),
              "whitted (differentials=always)");
}

/// Distributed runs with RMSE = 0.1·t^-1/2 at t = 1, 4, 16.
std::vector<mrt::RunResult> distributed_power_law() {
    return {run("distributed:spp-max=16", 1.0, 0.1), run("distributed:spp-max=64", 4.0, 0.05),
            run("distributed:spp-max=256", 16.0, 0.025)};
}

// Three curves with closed forms, and the figures worked out by hand:
//   whitted      RMSE = 0.2·t^-1/4 at t = 0.25, 1
//   distributed  RMSE = 0.1·t^-1/2 at t = 1, 4, 16, and a dominated run at t = 8 (0.06 > 0.05)
//   cone         one run, t = 0.5, RMSE 0.04: the baseline.
// The curves span RMSE [0.025, 0.2·0.25^-1/4 = 0.283]: of the fixed levels only 0.05 is inside.
TEST(DerivedFigures, EqualTimeAndEqualErrorFromPowerLaws) {
    std::vector<mrt::RunResult> runs = {run("whitted:spp=4", 0.25, 0.2 * std::pow(0.25, -0.25)),
                                        run("whitted:spp=16", 1.0, 0.2)};
    for (const mrt::RunResult& r : distributed_power_law()) {
        runs.push_back(r);
    }
    runs.push_back(run("distributed:spp-max=999", 8.0, 0.06));
    runs.push_back(run("cone", 0.5, 0.04));
    const auto d = mrt::derived_figures(runs);
    ASSERT_TRUE(d);
    EXPECT_EQ(d->baseline, 6u);
    EXPECT_EQ(d->chosen_as, "first cone run");
    ASSERT_EQ(d->curves.size(), 3u);
    EXPECT_EQ(d->curves[1].label, "distributed");
    EXPECT_EQ(d->curves[1].kept, (std::vector<std::size_t>{2, 3, 4}));
    EXPECT_EQ(d->curves[1].dominated, (std::vector<std::size_t>{5}));
    EXPECT_EQ(d->baseline_curve, 2u);
    EXPECT_EQ(d->levels, (std::vector<double>{0.05, 0.04}));

    // Distributed reaches 0.05 at its 4 s run and 0.04 at (0.1 / 0.04)² = 6.25 s.
    const auto& distributed = d->time_to_error[1];
    EXPECT_EQ(distributed[0]->kind, TimeToErrorKind::Measured);
    EXPECT_EQ(distributed[0]->seconds, 4.0);
    EXPECT_EQ(distributed[1]->kind, TimeToErrorKind::Interpolated);
    EXPECT_NEAR(distributed[1]->seconds, 6.25, 1e-12);
    // Whitted never gets below 0.2: at least its slowest run's 1 s; cone is below 0.05 already.
    EXPECT_EQ(d->time_to_error[0][1]->kind, TimeToErrorKind::AtLeast);
    EXPECT_EQ(d->time_to_error[0][1]->seconds, 1.0);
    EXPECT_EQ(d->time_to_error[2][0]->kind, TimeToErrorKind::AtMost);
    EXPECT_EQ(d->time_to_error[2][0]->seconds, 0.5);
    EXPECT_EQ(d->time_to_error[2][1]->kind, TimeToErrorKind::Measured);

    // At cone's 0.5 s whitted has 0.2·0.5^-1/4; distributed has no run that fast.
    ASSERT_TRUE(d->equal_time[0]);
    EXPECT_NEAR(d->equal_time[0]->rmse, 0.2 * std::pow(0.5, -0.25), 1e-12);
    EXPECT_FALSE(d->equal_time[1]);
    EXPECT_EQ(d->equal_time[2]->rmse, 0.04);

    // The only level two curves both reach: 0.04, cone in 0.5 s, distributed in 6.25 s.
    ASSERT_EQ(d->speedups.size(), 1u);
    const mrt::EqualErrorSpeedup& s = d->speedups[0];
    EXPECT_EQ(s.faster, 2u);
    EXPECT_EQ(s.slower, 1u);
    EXPECT_EQ(s.error, 0.04);
    EXPECT_NEAR(s.speedup, 12.5, 1e-12);
}

TEST(DerivedFigures, WithoutConeTheFastestWhittedRunIsTheBaseline) {
    // Whitted RMSE = 0.4·t^-1/2, distributed 0.1·t^-1/2: at 0.05 whitted needs 64 s,
    // distributed 4 s; at the baseline's 1 s distributed has 0.1.
    std::vector<mrt::RunResult> runs = distributed_power_law();
    for (const double t : {64.0, 16.0, 4.0, 1.0}) {
        runs.push_back(
            run("whitted:spp=" + std::to_string(static_cast<int>(t)), t, 0.4 / std::sqrt(t)));
    }
    const auto d = mrt::derived_figures(runs);
    ASSERT_TRUE(d);
    EXPECT_EQ(runs[d->baseline].spec, "whitted:spp=1");
    EXPECT_EQ(d->chosen_as, "fastest whitted run");
    EXPECT_EQ(d->levels, (std::vector<double>{0.4, 0.05}));
    EXPECT_NEAR(d->equal_time[0]->rmse, 0.1, 1e-12);
    ASSERT_EQ(d->speedups.size(), 1u);
    EXPECT_EQ(d->curves[d->speedups[0].faster].label, "distributed");
    EXPECT_EQ(d->speedups[0].error, 0.05);
    EXPECT_NEAR(d->speedups[0].speedup, 16.0, 1e-12);

    EXPECT_FALSE(mrt::derived_figures({})) << "no runs";
    EXPECT_FALSE(mrt::derived_figures({run("whitted", 0.1, 0.0)})) << "no usable RMSE";
}

}  // namespace
