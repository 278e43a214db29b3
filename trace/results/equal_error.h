#pragma once
// The time a method needs to reach a given error, read from its measured runs: one curve of
// (render seconds, RMSE) points, such as the runs of distributed with a time budget. Between
// two runs the curve is the straight line in log(time)–log(RMSE); it is never extrapolated for
// an answer, only to choose the next budget to measure. mrt-compare uses both halves: it renders
// budgets chosen by next_equal_error_budget until time_to_error can answer from a run within
// the tolerance (or the curve is bounded), so that the answer is a measurement, not a guess.

#include <optional>
#include <span>

namespace mrt {

/// Which error a curve measures: the RMSE of linear radiance, or of values clamped to [0, 1]
/// (display_rmse, image_metrics.h).
enum class ErrorMeasure { Rmse, DisplayRmse };

/// One measured run of a curve.
struct CurvePoint {
    double seconds = 0.0;  ///< Render seconds.
    double rmse = 0.0;
    double budget = 0.0;  ///< The time budget it was given, when it had one (0: none known).
};

/// How a time to an error was obtained from a curve.
enum class TimeToErrorKind {
    Measured,      ///< A run's RMSE is within the tolerance of the target: its time.
    Interpolated,  ///< Between the two runs that bracket the target most tightly.
    AtMost,        ///< Even the fastest run is more accurate: at most its time.
    AtLeast,       ///< No run is as accurate: more than the slowest run's time.
};

struct TimeToError {
    TimeToErrorKind kind = TimeToErrorKind::Measured;
    double seconds = 0.0;  ///< The time, or the bound.
    double rmse = 0.0;     ///< The RMSE of the run used (Measured, AtMost, AtLeast); the target
                           ///< when Interpolated.
};

/// A run whose RMSE is within this factor of the target counts as reaching it.
inline constexpr double kEqualErrorTolerance = 1.05;

/// The time the curve needs to reach `target_rmse`; empty for an empty curve or a target that
/// is not a positive number. Points with a non-positive or non-finite RMSE or time are ignored.
std::optional<TimeToError> time_to_error(std::span<const CurvePoint> curve, double target_rmse,
                                         double tolerance = kEqualErrorTolerance);

/// The curve's RMSE at `seconds`: the run within `tolerance` of that time nearest to it
/// (Measured), else the line between the runs either side (Interpolated; `rmse` is the value
/// and `seconds` the time asked). Empty when no run is that near and the time is not between two.
std::optional<TimeToError> rmse_at_time(std::span<const CurvePoint> curve, double seconds,
                                        double tolerance = 1.1);

/// The time budget to render next so that the curve reaches `target_rmse` within the
/// tolerance, kept within [min_budget, max_budget]; empty once no render is needed: a run is
/// within the tolerance, or the curve is already bounded by a run at the budget limit the
/// target lies beyond (or by a fastest run that overran its budget: the tracer's least time),
/// or the chosen budget is within 2 % of a run's time or budget already
/// measured (noise would make another render there no wiser; a render whose first pass takes
/// longer than its budget would only repeat itself).
std::optional<double> next_equal_error_budget(std::span<const CurvePoint> curve, double target_rmse,
                                              double min_budget, double max_budget,
                                              double tolerance = kEqualErrorTolerance);

}  // namespace mrt
