#pragma once
// The equal-time and equal-error figures of a comparison, which the results pages print and
// the error-against-time plot marks (scripts/mrtrace/plot.py draws them; nothing recomputes
// them):
//   - the runs grouped into curves: a method's runs that differ only in how many samples they
//     take (curve_label), each curve's dominated runs left out (a run no faster than another of
//     its curve and no more accurate: nobody would choose it at any time);
//   - the baseline: the first cone run, else the fastest whitted run, else the fastest run;
//   - the error levels: the baseline's RMSE and those of kErrorLevels within the curves' range;
//   - each curve's time to reach each level and its RMSE at the baseline's time, read from the
//     curve as equal_error.h reads one (the log–log line between two runs, never extrapolated:
//     beyond its runs a curve gives a bound or nothing);
//   - the speed-up between every two curves at every level both reach.
// All in render seconds and RMSE of linear radiance.

#include "trace/results/equal_error.h"
#include "trace/results/results.h"

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace mrt {

/// RMSE levels reported besides the baseline's, when they lie within the curves' range.
inline constexpr std::array<double, 4> kErrorLevels = {0.05, 0.02, 0.01, 0.005};

/// The curve a spec's run belongs to: its method, with the options that change what is
/// computed rather than how many samples are taken, and "time budget" first for runs stopped
/// by a budget (they spend samples differently from fixed-count runs):
/// "whitted:spp=4" → "whitted"; "distributed:time-budget=2,texture-filter=none" →
/// "distributed (time budget, texture-filter=none)".
std::string curve_label(const std::string& spec);

/// One curve: indices into the comparison's runs.
struct RunCurve {
    std::string label;
    std::vector<std::size_t> kept;       ///< Faster and more accurate, one after another.
    std::vector<std::size_t> dominated;  ///< Left out of the curve (drawn, not read).
    std::vector<CurvePoint> points;      ///< The kept runs' (render seconds, RMSE).
};

/// A curve's speed-up over another at one error level: slower's time over faster's.
struct EqualErrorSpeedup {
    std::size_t faster = 0;  ///< Indices into DerivedFigures::curves.
    std::size_t slower = 0;
    double error = 0.0;
    double faster_seconds = 0.0;
    double slower_seconds = 0.0;
    double speedup = 0.0;
};

struct DerivedFigures {
    std::size_t baseline = 0;  ///< Index of the baseline run.
    std::string chosen_as;     ///< Why: "first cone run", "fastest whitted run", ...
    std::size_t baseline_curve = 0;
    std::vector<RunCurve> curves;  ///< In the order their first runs appear.
    std::vector<double> levels;    ///< Descending.
    /// [curve][level]: the time to reach the level; empty when the curve has no usable run.
    std::vector<std::vector<std::optional<TimeToError>>> time_to_error;
    /// [curve]: the RMSE at the baseline's time (a run within a hair of it, or between two).
    std::vector<std::optional<TimeToError>> equal_time;
    std::vector<EqualErrorSpeedup> speedups;
};

/// The figures of `runs`; empty when no run has a positive, finite time and RMSE.
std::optional<DerivedFigures> derived_figures(const std::vector<RunResult>& runs);

}  // namespace mrt
