#pragma once
// Method specs of mrt-compare: "NAME[:key=value,...]" names one mrt-trace run. Keys are
// mrt-trace long option names without the dashes; a key without "=value" is a flag.
//
//   whitted                        → --method whitted
//   whitted:spp=4                  → --method whitted --spp 4
//   distributed:spp-max=16,spp-initial=4
//                                  → --method distributed --spp-max 16 --spp-initial 4
//   distributed:reference          → refused (mrt-compare controls --reference)
//
// The methods and the options each takes are mrt-trace's own table (trace/render/method.h); the
// runs mrt-compare makes when no spec is given are default_runs() in method_spec.cpp.

#include "trace/render/method.h"
#include "trace/results/equal_error.h"

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace mrt {

/// One "key" or "key=value" of a method spec.
struct MethodOption {
    std::string key;                   ///< mrt-trace long option name, without dashes.
    std::optional<std::string> value;  ///< Empty optional: a flag (passed as "--key" alone).

    bool operator==(const MethodOption&) const = default;
};

/// A parsed method spec.
struct MethodSpec {
    std::string text;                   ///< The spec as written.
    Method method = Method::Whitted;    ///< The tracer, passed as --method.
    std::vector<MethodOption> options;  ///< In the order written.
};

/// Parses "NAME[:key[=value],...]". Throws mrt::Error quoting the spec for an empty name, an
/// empty option list after ':', an empty key or value, a key written with dashes, a repeated
/// key, characters outside [A-Za-z0-9_-] in a name or key, keys mrt-compare sets itself
/// (refused_option_keys()), a name that is not a method, and an option that only other methods
/// take (method_only_options()). Other keys unknown to mrt-trace pass through; it refuses them.
MethodSpec parse_method_spec(const std::string& text);

/// The option keys mrt-compare sets for every run itself, refused inside a spec: output, stats,
/// quiet, width, height, filter, reference, threads, and also method (the spec's NAME) and seed
/// (part of the reference's key, so the same for the reference and every run).
const std::vector<std::string>& refused_option_keys();

/// mrt-trace arguments for the spec: "--method NAME" then "--key [value]" per option.
std::vector<std::string> trace_arguments(const MethodSpec& spec);

/// File-name form of a spec: every character outside [A-Za-z0-9.-] becomes '-'
/// ("distributed:spp-max=16" → "distributed-spp-max-16").
std::string spec_slug(const std::string& spec_text);

/// One run of the default comparison (used when no --method is given).
struct DefaultRun {
    Method method = Method::Whitted;  ///< The tracer.
    std::string options;              ///< "key=value,..." after the ':' (empty: none).
    /// 0: a fixed run. > 0: a time-budget run whose budget is this factor times the render
    /// time of the run `budget_of`, so it is only known once that has run; with
    /// `to_equal_error`, the largest budget the search may give.
    double budget_factor = 0.0;
    /// The spec whose render time scales the budget; empty: baseline_spec() ("whitted").
    std::string budget_of{};
    /// A search rather than one run: time budgets rendered until one reaches the error
    /// (`measure`) of `budget_of`'s run within kEqualErrorTolerance (equal_error.h), at most
    /// kMaxEqualErrorRenders of them.
    bool to_equal_error = false;
    /// The error the search equals.
    ErrorMeasure measure = ErrorMeasure::Rmse;

    /// budget_of, or baseline_spec() when it is empty.
    const std::string& budget_base() const;
};

/// The most renders one equal-error search makes.
inline constexpr int kMaxEqualErrorRenders = 4;

/// Every run of the default comparison, in order, for every method.
const std::vector<DefaultRun>& default_runs();

/// The spec whose measured render_seconds sets the time-budget runs' budgets ("whitted").
const std::string& baseline_spec();

/// The spec of a fixed default run ("method" or "method:options").
std::string default_run_spec(const DefaultRun& run);

/// Baseline times below this count as this, so the smallest default factor (4) gives the
/// 0.05 s minimum budget and the larger factors stay distinct from it.
inline constexpr double kMinimumBudgetBaseSeconds = 0.0125;

/// The spec of a time-budget run with `baseline_seconds` measured: budget = factor ×
/// max(baseline, kMinimumBudgetBaseSeconds), rounded to 3 significant digits and at least
/// 0.05 s ("distributed:time-budget=0.246").
std::string budget_run_spec(const DefaultRun& run, double baseline_seconds);

/// The spec of `run` with a budget of `seconds` (rounded as format_budget_seconds does).
std::string spec_with_budget(const DefaultRun& run, double seconds);

/// The time budget of `spec_text` when it is `run`'s method and options with a time budget
/// added last (as spec_with_budget writes it), else empty.
std::optional<double> time_budget_of(const std::string& spec_text, const DefaultRun& run);

/// The smallest budget a run is given (format_budget_seconds' floor).
inline constexpr double kMinimumBudgetSeconds = 0.05;

/// The budget in seconds, formatted as budget_run_spec writes it ("0.246", "12.3", "0.05").
std::string format_budget_seconds(double seconds);

std::ostream& operator<<(std::ostream& os, const MethodOption& o);
std::ostream& operator<<(std::ostream& os, const MethodSpec& s);

}  // namespace mrt
