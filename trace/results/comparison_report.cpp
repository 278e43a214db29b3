#include "trace/results/comparison_report.h"

#include "common/system/atomic_file.h"
#include "common/system/enum_names.h"
#include "trace/results/derived_figures.h"
#include "trace/results/headline_ratios.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <ostream>

namespace mrt {

namespace {

// Keys in the order the header documents them, for a reader of the file.
using json = nlohmann::ordered_json;

/// A number, or null when it is not finite (an infinite PSNR) or unknown.
json number_or_null(double v) {
    return std::isfinite(v) ? json(v) : json(nullptr);
}

template <typename T>
json number_or_null(const std::optional<T>& v) {
    return v ? json(*v) : json(nullptr);
}

/// What a headline ratio measures, for the printed table.
std::string headline_description(const HeadlineRatio& r) {
    if (r.key == "cone_over_whitted") {
        return "cone time / whitted time";
    }
    if (r.key == "distributed_to_cone_error") {
        return "distributed time to cone's RMSE / cone time";
    }
    if (r.key == "distributed_to_cone_display_error") {
        return "distributed time to cone's display RMSE / cone time";
    }
    if (r.key == "distributed_rmse_at_cone_time") {
        return "distributed RMSE at cone's time / cone RMSE";
    }
    if (r.key == "classic_over_cone_primary") {
        return "cone-classic time / cone time, primary rays";
    }
    return r.key;
}

std::string_view origin_name(ReferenceOrigin origin) {
    static constexpr EnumNames<ReferenceOrigin, 3> kNames{{{
        {ReferenceOrigin::Rendered, "rendered"},
        {ReferenceOrigin::Cached, "cached"},
        {ReferenceOrigin::Given, "given"},
    }}};
    return kNames.name(origin);
}

/// The reference's linear image: relative to DIR when it is the cached one, else as given.
std::string reference_exr_name(const ReferenceSummary& reference) {
    return reference.origin == ReferenceOrigin::Given ? reference.exr.string()
                                                      : reference.exr.filename().string();
}

/// RFC 4180 field: quoted when it holds a comma, a quote or a line break.
std::string csv_field(const std::string& s) {
    if (s.find_first_of(",\"\r\n") == std::string::npos) {
        return s;
    }
    std::string quoted = "\"";
    for (const char c : s) {
        quoted += c;
        if (c == '"') {
            quoted += '"';
        }
    }
    return quoted + "\"";
}

/// Shortest text that reads back as the same double, like the JSON; "inf" when infinite.
std::string csv_number(double v) {
    if (std::isinf(v)) {
        return v > 0 ? "inf" : "-inf";
    }
    if (std::isnan(v)) {
        return "";
    }
    return fmt::format("{}", v);
}

json indices(const std::vector<std::size_t>& v) {
    json a = json::array();
    for (const std::size_t i : v) {
        a.push_back(i);
    }
    return a;
}

/// A time to reach an error as the pages print it: the time or its bound, and how.
json time_to_error_json(const std::optional<TimeToError>& t) {
    if (!t) {
        return nullptr;
    }
    return {{"seconds", number_or_null(t->seconds)},
            {"relation", relation_name(relation_of(t->kind))},
            {"how", how_of(t->kind)}};
}

/// results.json's "derived" (the layout is in the header above); null without a usable run.
json derived_json(const std::vector<RunResult>& runs) {
    const std::optional<DerivedFigures> d = derived_figures(runs);
    if (!d) {
        return nullptr;
    }
    const RunResult& base = runs[d->baseline];
    json curves = json::array();
    json time_to = json::object();
    json equal_time = json::object();
    json ratio = json::object();
    json dominated = json::array();
    for (std::size_t c = 0; c < d->curves.size(); ++c) {
        const RunCurve& curve = d->curves[c];
        curves.push_back({{"label", curve.label},
                          {"runs", indices(curve.kept)},
                          {"dominated", indices(curve.dominated)}});
        json times = json::array();
        for (const auto& t : d->time_to_error[c]) {
            times.push_back(time_to_error_json(t));
        }
        time_to[curve.label] = times;
        const auto& at = d->equal_time[c];
        equal_time[curve.label] = at ? json(at->rmse) : json(nullptr);
        ratio[curve.label] = at ? json(at->rmse / base.rmse) : json(nullptr);
        for (const std::size_t i : curve.dominated) {
            dominated.push_back({{"method", to_string(runs[i].method)}, {"spec", runs[i].spec}});
        }
    }
    json speedups = json::array();
    for (const EqualErrorSpeedup& s : d->speedups) {
        speedups.push_back({{"faster", d->curves[s.faster].label},
                            {"slower", d->curves[s.slower].label},
                            {"error", s.error},
                            {"speedup", s.speedup},
                            {"faster_seconds", s.faster_seconds},
                            {"slower_seconds", s.slower_seconds}});
    }
    return {{"time", "render_seconds"},
            {"baseline",
             {{"run", d->baseline},
              {"method", to_string(base.method)},
              {"curve", d->curves[d->baseline_curve].label},
              {"spec", base.spec},
              {"seconds", base.render_seconds},
              {"rmse", base.rmse},
              {"chosen_as", d->chosen_as}}},
            {"levels", d->levels},
            {"curves", curves},
            {"time_to_error", time_to},
            {"equal_time", equal_time},
            {"error_ratio_at_equal_time", ratio},
            {"speedup_at_equal_error", speedups},
            {"dominated_runs", dominated}};
}

std::string seconds_text(double s) {
    return fmt::format("{:.3g} s", s);
}

}  // namespace

std::string results_json_text(const Comparison& c) {
    json runs = json::array();
    for (const RunResult& r : c.runs) {
        runs.push_back({{"method", to_string(r.method)},
                        {"spec", r.spec},
                        {"render_seconds", r.render_seconds},
                        {"total_seconds", r.total_seconds},
                        {"wall_seconds", r.wall_seconds},
                        {"rays", r.rays},
                        {"samples", number_or_null(r.samples)},
                        {"rmse", number_or_null(r.rmse)},
                        {"psnr", number_or_null(r.psnr)},
                        {"ssim", number_or_null(r.ssim)},
                        {"image", r.image},
                        {"error_image", r.error_image},
                        {"stats", r.stats},
                        {"stopped", r.stopped},
                        {"display_rmse", number_or_null(r.display_rmse)}});
    }
    json headline = json::object();
    for (const HeadlineRatio& r : headline_ratios(c.runs)) {
        headline[r.key] = {{"value", number_or_null(r.value)},
                           {"relation", relation_name(r.relation)},
                           {"numerator", r.numerator},
                           {"denominator", r.denominator},
                           {"numerator_value", number_or_null(r.numerator_value)},
                           {"denominator_value", number_or_null(r.denominator_value)},
                           {"how", r.how}};
    }
    const ReferenceSummary& ref = c.reference;
    const json j = {{"scene", c.scene},
                    {"width", c.width},
                    {"height", c.height},
                    {"filter", c.filter},
                    {"seed", c.seed},
                    {"error_scale", c.error_scale},
                    {"reference",
                     {{"spp", number_or_null(ref.info.spp)},
                      {"seconds", number_or_null(ref.info.seconds)},
                      {"std_error", number_or_null(ref.info.std_error)},
                      {"image", ref.image},
                      {"exr", reference_exr_name(ref)},
                      {"origin", origin_name(ref.origin)}}},
                    {"runs", runs},
                    {"headline", headline},
                    {"derived", derived_json(c.runs)}};
    return j.dump(2) + "\n";
}

std::string results_csv_text(const Comparison& c) {
    std::string csv =
        "method,spec,render_seconds,total_seconds,wall_seconds,rays,samples,rmse,psnr,ssim,"
        "image,error_image,stats,stopped,display_rmse\n";
    for (const RunResult& r : c.runs) {
        csv += fmt::format(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            csv_field(std::string(to_string(r.method))), csv_field(r.spec),
            csv_number(r.render_seconds), csv_number(r.total_seconds), csv_number(r.wall_seconds),
            r.rays, r.samples ? std::to_string(*r.samples) : std::string(), csv_number(r.rmse),
            csv_number(r.psnr), csv_number(r.ssim), csv_field(r.image), csv_field(r.error_image),
            csv_field(r.stats), r.stopped ? "true" : "false", csv_number(r.display_rmse));
    }
    return csv;
}

void write_results(const Comparison& comparison, const std::filesystem::path& dir) {
    write_file_atomically(dir / "results.json", results_json_text(comparison), "results file");
    write_file_atomically(dir / "results.csv", results_csv_text(comparison), "results file");
}

std::string format_psnr(double psnr) {
    if (std::isinf(psnr)) {
        return psnr > 0 ? "inf" : "-inf";
    }
    return fmt::format("{:.2f}", psnr);
}

namespace {

/// A time to an error as the console shows it: "6.25 s", "≤ 0.5 s", "≥ 16 s", "-".
std::string time_text(const std::optional<TimeToError>& t) {
    if (!t) {
        return "-";
    }
    return fmt::format("{}{:.3g} s", relation_prefix(relation_of(t->kind)), t->seconds);
}

/// The equal-time and equal-error figures results.json holds under "derived", one line each:
/// every curve's RMSE at the baseline's time, its time to each error level, and the speed-ups
/// of the baseline's curve over the others (or theirs over it) at equal error.
void print_derived_figures(std::ostream& os, const std::vector<RunResult>& runs,
                           const DerivedFigures& d) {
    const RunResult& base = runs[d.baseline];
    os << fmt::format("baseline: {} ({}), {:.3g} s, RMSE {:.4g}\n", base.spec, d.chosen_as,
                      base.render_seconds, base.rmse);
    std::vector<std::string> at_time;
    for (std::size_t i = 0; i < d.curves.size(); ++i) {
        if (const auto& at = d.equal_time[i]) {
            at_time.push_back(fmt::format("{} {:.4g} ({:.3g}×)", d.curves[i].label, at->rmse,
                                          at->rmse / base.rmse));
        }
    }
    if (!at_time.empty()) {
        os << fmt::format("RMSE at the baseline's time: {}\n", fmt::join(at_time, ", "));
    }
    for (std::size_t level = 0; level < d.levels.size(); ++level) {
        std::vector<std::string> times;
        for (std::size_t i = 0; i < d.curves.size(); ++i) {
            times.push_back(d.curves[i].label + " " + time_text(d.time_to_error[i][level]));
        }
        os << fmt::format("time to RMSE {:.4g}: {}\n", d.levels[level], fmt::join(times, ", "));
    }
    for (const EqualErrorSpeedup& s : d.speedups) {
        if (s.faster == d.baseline_curve || s.slower == d.baseline_curve) {
            os << fmt::format(
                "at RMSE {:.4g}: {} is {:.3g}× faster than {} ({:.3g} s against "
                "{:.3g} s)\n",
                s.error, d.curves[s.faster].label, s.speedup, d.curves[s.slower].label,
                s.faster_seconds, s.slower_seconds);
        }
    }
}

}  // namespace

void print_results_table(std::ostream& os, const Comparison& c) {
    std::size_t spec_width = 4;
    for (const RunResult& r : c.runs) {
        spec_width = std::max(spec_width, r.spec.size());
    }
    os << fmt::format("{:>3}  {:<{}}  {:>10}  {:>10}  {:>14}  {:>10}  {:>10}  {:>7}  {:>7}\n", "#",
                      "spec", spec_width, "render s", "total s", "rays", "RMSE", "disp.RMSE",
                      "PSNR", "SSIM");
    for (std::size_t i = 0; i < c.runs.size(); ++i) {
        const RunResult& r = c.runs[i];
        os << fmt::format(
            "{:>3}  {:<{}}  {:>10.3f}  {:>10.3f}  {:>14}  {:>10.6f}  {:>10.6f}  {:>7}  "
            "{:>7.4f}{}\n",
            i + 1, r.spec, spec_width, r.render_seconds, r.total_seconds, r.rays, r.rmse,
            r.display_rmse, format_psnr(r.psnr), r.ssim,
            r.stopped ? "  stopped: time budget spent" : "");
    }
    os << reference_line(c) << '\n';
    for (const HeadlineRatio& r : headline_ratios(c.runs)) {
        const std::string numerator = r.numerator.empty() ? "" : " (" + r.numerator + ")";
        os << fmt::format("{}: {}{:.3g}{}, {}\n", headline_description(r),
                          relation_prefix(r.relation), r.value, numerator, r.how);
    }
    if (const std::optional<DerivedFigures> d = derived_figures(c.runs)) {
        print_derived_figures(os, c.runs, *d);
    }
}

std::string reference_line(const Comparison& c) {
    const ReferenceInfo& info = c.reference.info;
    std::string line =
        fmt::format("reference: {}×{}, filter {}, seed {}", c.width, c.height, c.filter, c.seed);
    line += info.spp ? fmt::format(", {} spp", *info.spp) : ", spp unknown";
    if (info.seconds) {
        line += fmt::format(", {:.3f} s", *info.seconds);
    }
    if (info.std_error) {
        line += fmt::format(", std error {:.3g}", *info.std_error);
    }
    switch (c.reference.origin) {
        case ReferenceOrigin::Rendered:
            line += " (rendered: " + reference_exr_name(c.reference) + ")";
            break;
        case ReferenceOrigin::Cached:
            line += " (reused from cache: " + reference_exr_name(c.reference) + ")";
            break;
        case ReferenceOrigin::Given:
            line += " (given: " + reference_exr_name(c.reference) + ")";
            break;
    }
    return line;
}

std::string run_label(const RunResult& run) {
    return run.spec;
}

std::string error_label(const RunResult& run) {
    return fmt::format("{}  RMSE {:.4f}  SSIM {:.3f}{}", seconds_text(run.render_seconds), run.rmse,
                       run.ssim, run.stopped ? "  (stopped)" : "");
}

std::string reference_label(const ReferenceSummary& reference) {
    std::string label = "reference";
    if (reference.info.spp) {
        label += fmt::format("  {} spp", *reference.info.spp);
    }
    if (reference.info.seconds) {
        label += "  " + seconds_text(*reference.info.seconds);
    }
    return label;
}

}  // namespace mrt
