#include "trace/results/equal_error.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mrt {

namespace {

// Noise can make two runs' curve flat or rising; extrapolating that would aim at no time at all,
// so such a pair is read as the square-root law of independent samples instead.
constexpr double kSquareRootLaw = -0.5;

bool usable(const CurvePoint& p) {
    return std::isfinite(p.seconds) && p.seconds > 0.0 && std::isfinite(p.rmse) && p.rmse > 0.0;
}

std::vector<CurvePoint> sorted_usable(std::span<const CurvePoint> curve) {
    std::vector<CurvePoint> points;
    std::copy_if(curve.begin(), curve.end(), std::back_inserter(points), usable);
    std::stable_sort(points.begin(), points.end(), [](const CurvePoint& a, const CurvePoint& b) {
        return a.seconds < b.seconds;
    });
    return points;
}

/// How far a run's RMSE is from the target, as a factor ≥ 1.
double miss(double rmse, double target) {
    return std::max(rmse / target, target / rmse);
}

/// The log–log slope between two runs, or kSquareRootLaw when they say nothing sensible.
double slope_between(const CurvePoint& a, const CurvePoint& b) {
    if (a.seconds == b.seconds) {
        return kSquareRootLaw;
    }
    const double s = std::log(b.rmse / a.rmse) / std::log(b.seconds / a.seconds);
    return s <= -0.25 && s >= -3.0 ? s : kSquareRootLaw;
}

/// The time at which the line through `p` with log–log slope `slope` has RMSE `target`.
double along_slope(const CurvePoint& p, double slope, double target) {
    return p.seconds * std::pow(target / p.rmse, 1.0 / slope);
}

}  // namespace

std::optional<TimeToError> time_to_error(std::span<const CurvePoint> curve, double target_rmse,
                                         double tolerance) {
    if (!(target_rmse > 0.0) || !std::isfinite(target_rmse)) {
        return std::nullopt;
    }
    const std::vector<CurvePoint> points = sorted_usable(curve);
    if (points.empty()) {
        return std::nullopt;
    }
    // The run nearest the target, the fastest of equals: a measurement beats any line.
    const auto nearest = std::min_element(
        points.begin(), points.end(), [&](const CurvePoint& a, const CurvePoint& b) {
            return miss(a.rmse, target_rmse) < miss(b.rmse, target_rmse);
        });
    if (miss(nearest->rmse, target_rmse) <= tolerance) {
        return TimeToError{TimeToErrorKind::Measured, nearest->seconds, nearest->rmse};
    }
    // Noise can make the curve rise between runs; the answer is where it first reaches the
    // target, so the bracket is the fastest accurate run and the slowest inaccurate one before it.
    const auto accurate = std::find_if(points.begin(), points.end(),
                                       [&](const CurvePoint& p) { return p.rmse <= target_rmse; });
    if (accurate == points.end()) {
        return TimeToError{TimeToErrorKind::AtLeast, points.back().seconds, points.back().rmse};
    }
    if (accurate == points.begin()) {
        return TimeToError{TimeToErrorKind::AtMost, accurate->seconds, accurate->rmse};
    }
    const CurvePoint& lower = *std::prev(accurate);
    const CurvePoint& upper = *accurate;
    const double t = std::log(target_rmse / lower.rmse) / std::log(upper.rmse / lower.rmse);
    const double seconds = lower.seconds * std::pow(upper.seconds / lower.seconds, t);
    return TimeToError{TimeToErrorKind::Interpolated, seconds, target_rmse};
}

std::optional<TimeToError> rmse_at_time(std::span<const CurvePoint> curve, double seconds,
                                        double tolerance) {
    if (!(seconds > 0.0) || !std::isfinite(seconds)) {
        return std::nullopt;
    }
    const std::vector<CurvePoint> points = sorted_usable(curve);
    const auto nearest = std::min_element(
        points.begin(), points.end(), [&](const CurvePoint& a, const CurvePoint& b) {
            return miss(a.seconds, seconds) < miss(b.seconds, seconds);
        });
    if (nearest == points.end()) {
        return std::nullopt;
    }
    if (miss(nearest->seconds, seconds) <= tolerance) {
        return TimeToError{TimeToErrorKind::Measured, nearest->seconds, nearest->rmse};
    }
    const auto after = std::find_if(points.begin(), points.end(),
                                    [&](const CurvePoint& p) { return p.seconds > seconds; });
    if (after == points.begin() || after == points.end()) {
        return std::nullopt;
    }
    const CurvePoint& before = *std::prev(after);
    const double t = std::log(seconds / before.seconds) / std::log(after->seconds / before.seconds);
    const double rmse = before.rmse * std::pow(after->rmse / before.rmse, t);
    return TimeToError{TimeToErrorKind::Interpolated, seconds, rmse};
}

std::optional<double> next_equal_error_budget(std::span<const CurvePoint> curve, double target_rmse,
                                              double min_budget, double max_budget,
                                              double tolerance) {
    const std::optional<TimeToError> known = time_to_error(curve, target_rmse, tolerance);
    if (!known || known->kind == TimeToErrorKind::Measured || !(min_budget <= max_budget)) {
        return std::nullopt;
    }
    const std::vector<CurvePoint> points = sorted_usable(curve);
    double budget = known->seconds;
    if (known->kind == TimeToErrorKind::AtMost) {
        const CurvePoint& fastest = points.front();
        if (fastest.seconds <= min_budget * 1.02 ||
            (fastest.budget > 0.0 && fastest.seconds > fastest.budget * 1.1)) {
            // Already as fast as a budget may be, or as fast as the tracer can be: its first
            // pass took longer than the budget (beyond the last tile's overrun), and a smaller
            // one would take as long again.
            return std::nullopt;
        }
        const double slope =
            points.size() > 1 ? slope_between(points[0], points[1]) : kSquareRootLaw;
        budget = along_slope(points.front(), slope, target_rmse);
    } else if (known->kind == TimeToErrorKind::AtLeast) {
        if (points.back().seconds >= max_budget * 0.98) {
            return std::nullopt;  // the target lies beyond the largest budget allowed
        }
        const std::size_t n = points.size();
        const double slope = n > 1 ? slope_between(points[n - 2], points[n - 1]) : kSquareRootLaw;
        budget = along_slope(points.back(), slope, target_rmse);
    }
    budget = std::clamp(budget, min_budget, max_budget);
    const bool measured_there = std::any_of(points.begin(), points.end(), [&](const CurvePoint& p) {
        return std::abs(p.seconds - budget) <= 0.02 * budget ||
               std::abs(p.budget - budget) <= 0.02 * budget;
    });
    if (measured_there) {
        return std::nullopt;
    }
    return budget;
}

}  // namespace mrt
