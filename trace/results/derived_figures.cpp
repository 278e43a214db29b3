#include "trace/results/derived_figures.h"

#include "trace/render/method.h"
#include "trace/results/method_spec.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <tuple>
#include <utility>

namespace mrt {

namespace {

// Options that only say how many samples a run takes: runs differing in these alone are points
// on one curve.
constexpr std::array<const char*, 5> kSampleCountOptions = {"spp", "spp-max", "spp-initial",
                                                            "target-error", "time-budget"};

// A level or time this close to a run's (as a factor) is that run's: the figures then quote
// the measurement rather than a line through it, without snapping a nearby run onto the level.
constexpr double kAtARun = 1.0 + 1e-9;

bool usable(const RunResult& run) {
    return std::isfinite(run.render_seconds) && run.render_seconds > 0.0 &&
           std::isfinite(run.rmse) && run.rmse > 0.0;
}

/// The curves of the usable runs, in the order their first runs appear.
std::vector<RunCurve> build_curves(const std::vector<RunResult>& runs) {
    std::vector<RunCurve> curves;
    std::vector<std::vector<std::size_t>> members;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        if (!usable(runs[i])) {
            continue;
        }
        const std::string label = curve_label(runs[i].spec);
        const auto it = std::find_if(curves.begin(), curves.end(),
                                     [&](const RunCurve& c) { return c.label == label; });
        if (it == curves.end()) {
            curves.push_back({label, {}, {}, {}});
            members.push_back({i});
        } else {
            members[static_cast<std::size_t>(it - curves.begin())].push_back(i);
        }
    }
    for (std::size_t c = 0; c < curves.size(); ++c) {
        std::vector<std::size_t>& order = members[c];
        std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
            return std::pair(runs[a].render_seconds, runs[a].rmse) <
                   std::pair(runs[b].render_seconds, runs[b].rmse);
        });
        RunCurve& curve = curves[c];
        for (const std::size_t i : order) {
            if (!curve.kept.empty() && runs[i].rmse >= runs[curve.kept.back()].rmse) {
                curve.dominated.push_back(i);
            } else {
                curve.kept.push_back(i);
                curve.points.push_back({runs[i].render_seconds, runs[i].rmse, 0.0});
            }
        }
    }
    return curves;
}

/// The first usable run of `method`, else the fastest usable whitted run, else the fastest
/// usable run.
std::pair<std::size_t, std::string> choose_baseline(const std::vector<RunResult>& runs) {
    const auto fastest = [&](auto wanted) -> std::optional<std::size_t> {
        std::optional<std::size_t> best;
        for (std::size_t i = 0; i < runs.size(); ++i) {
            if (usable(runs[i]) && wanted(runs[i]) &&
                (!best || runs[i].render_seconds < runs[*best].render_seconds)) {
                best = i;
            }
        }
        return best;
    };
    for (std::size_t i = 0; i < runs.size(); ++i) {
        if (usable(runs[i]) && runs[i].method == Method::Cone) {
            return {i, "first cone run"};
        }
    }
    if (const auto w = fastest([](const RunResult& r) { return r.method == Method::Whitted; })) {
        return {*w, "fastest whitted run"};
    }
    return {*fastest([](const RunResult&) { return true; }),
            "fastest run (no cone or whitted run)"};
}

bool is_value(const std::optional<TimeToError>& t) {
    return t && (t->kind == TimeToErrorKind::Measured || t->kind == TimeToErrorKind::Interpolated);
}

}  // namespace

std::string curve_label(const std::string& spec) {
    const MethodSpec parsed = parse_method_spec(spec);
    std::vector<std::string> labels;
    bool budget = false;
    for (const MethodOption& o : parsed.options) {
        if (o.key == "time-budget") {
            budget = true;
        } else if (std::find(kSampleCountOptions.begin(), kSampleCountOptions.end(), o.key) ==
                   kSampleCountOptions.end()) {
            labels.push_back(o.value ? o.key + "=" + *o.value : o.key);
        }
    }
    if (budget) {
        labels.insert(labels.begin(), "time budget");
    }
    if (labels.empty()) {
        return std::string(to_string(parsed.method));
    }
    std::string label = std::string(to_string(parsed.method)) + " (";
    for (std::size_t i = 0; i < labels.size(); ++i) {
        label += (i > 0 ? ", " : "") + labels[i];
    }
    return label + ")";
}

std::optional<DerivedFigures> derived_figures(const std::vector<RunResult>& runs) {
    if (std::none_of(runs.begin(), runs.end(), usable)) {
        return std::nullopt;
    }
    DerivedFigures d;
    std::tie(d.baseline, d.chosen_as) = choose_baseline(runs);
    d.curves = build_curves(runs);
    const RunResult& base = runs[d.baseline];
    const std::string base_label = curve_label(base.spec);
    d.baseline_curve = static_cast<std::size_t>(
        std::find_if(d.curves.begin(), d.curves.end(),
                     [&](const RunCurve& c) { return c.label == base_label; }) -
        d.curves.begin());

    double lowest = base.rmse;
    double highest = base.rmse;
    for (const RunCurve& c : d.curves) {
        for (const CurvePoint& p : c.points) {
            lowest = std::min(lowest, p.rmse);
            highest = std::max(highest, p.rmse);
        }
    }
    d.levels.push_back(base.rmse);
    for (const double level : kErrorLevels) {
        if (level * kAtARun >= lowest && level <= highest * kAtARun && level != base.rmse) {
            d.levels.push_back(level);
        }
    }
    std::sort(d.levels.begin(), d.levels.end(), std::greater<>());

    for (const RunCurve& c : d.curves) {
        std::vector<std::optional<TimeToError>> times;
        for (const double level : d.levels) {
            times.push_back(time_to_error(c.points, level, kAtARun));
        }
        d.time_to_error.push_back(std::move(times));
        d.equal_time.push_back(rmse_at_time(c.points, base.render_seconds, kAtARun));
    }
    for (std::size_t a = 0; a < d.curves.size(); ++a) {
        for (std::size_t b = a + 1; b < d.curves.size(); ++b) {
            for (std::size_t l = 0; l < d.levels.size(); ++l) {
                const auto& ta = d.time_to_error[a][l];
                const auto& tb = d.time_to_error[b][l];
                if (!is_value(ta) || !is_value(tb)) {
                    continue;
                }
                const bool a_faster = ta->seconds <= tb->seconds;
                EqualErrorSpeedup s;
                s.faster = a_faster ? a : b;
                s.slower = a_faster ? b : a;
                s.error = d.levels[l];
                s.faster_seconds = std::min(ta->seconds, tb->seconds);
                s.slower_seconds = std::max(ta->seconds, tb->seconds);
                s.speedup = s.slower_seconds / s.faster_seconds;
                d.speedups.push_back(s);
            }
        }
    }
    return d;
}

}  // namespace mrt
