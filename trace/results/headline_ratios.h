#pragma once
// The headline ratios of a comparison, each from runs of one mrt-compare invocation (so that
// the machine's load is shared by numerator and denominator):
//   cone_over_whitted             cone's render time over whitted's (Wand & Straßer: ≈ 4);
//   distributed_to_cone_error     the time distributed with a time budget needs to reach cone's
//                                 RMSE, over cone's time (the paper: ≥ 10 on its Figure 7);
//   distributed_to_cone_display_error
//                                 the same for the RMSE of values clamped to [0, 1], where a
//                                 few highlights cannot outweigh the image;
//   distributed_rmse_at_cone_time distributed's RMSE at cone's render time over cone's RMSE;
//   classic_over_cone_primary     cone-classic's render time over cone's, primary rays only
//                                 (max-depth=0; the paper: 2.8 on its Figure 7).
// A ratio is missing when its runs are not in the comparison.

#include "trace/results/equal_error.h"
#include "trace/results/method_spec.h"
#include "trace/results/results.h"

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mrt {

/// Whether a ratio is a value or a bound (a run stopped at its guard, a target not bracketed).
enum class RatioRelation { Equal, AtMost, AtLeast };

struct HeadlineRatio {
    std::string key;     ///< "cone_over_whitted", ... (the list above)
    double value = 0.0;  ///< The ratio, or its bound.
    RatioRelation relation = RatioRelation::Equal;
    std::string numerator;         ///< The spec of the numerator's run ("" when interpolated).
    std::string denominator;       ///< The spec of the denominator's run.
    double numerator_value = 0.0;  ///< Seconds, or an RMSE for distributed_rmse_at_cone_time.
    double denominator_value = 0.0;
    /// How the numerator was obtained: "measured", "interpolated between two runs", "stopped
    /// at its time guard", "even its fastest run is more accurate", "no run reaches it".
    std::string how;
};

/// A run's error in `measure`.
double error_of(const RunResult& run, ErrorMeasure measure);

/// The runs of `kind` (its method and options) that differ only in their time budget: one curve
/// of `measure` against render time, as the headline reads it and mrt-compare's search extends it.
struct BudgetCurve {
    std::vector<CurvePoint> points;
    std::vector<const RunResult*> runs;  ///< The run of each point.

    /// The run whose point this is (a time_to_error or rmse_at_time answer that names one).
    const RunResult* run_at(double seconds, double error) const;
};
BudgetCurve budget_curve(const std::vector<RunResult>& runs, const DefaultRun& kind,
                         ErrorMeasure measure);

/// The ratios the runs allow, in the order listed above.
std::vector<HeadlineRatio> headline_ratios(const std::vector<RunResult>& runs);

/// A time_to_error answer's kind as a ratio's relation: a bound for AtMost and AtLeast.
RatioRelation relation_of(TimeToErrorKind kind);

/// How a time_to_error or rmse_at_time answer was obtained, in words: "measured",
/// "interpolated between two runs", "even its fastest run is more accurate", "no run reaches it".
std::string_view how_of(TimeToErrorKind kind);

/// What goes before the value: "" for a value, "≤ " or "≥ " for a bound.
std::string_view relation_prefix(RatioRelation relation);

/// The relation as results.json writes it: "equal", "at most" or "at least".
std::string_view relation_name(RatioRelation relation);

}  // namespace mrt
