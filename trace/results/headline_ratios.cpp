#include "trace/results/headline_ratios.h"
#include "common/system/enum_names.h"
#include "trace/render/method.h"

#include <algorithm>

namespace mrt {

namespace {

bool has_only(const MethodSpec& spec, std::initializer_list<const char*> allowed) {
    return std::all_of(spec.options.begin(), spec.options.end(), [&](const MethodOption& o) {
        return std::any_of(allowed.begin(), allowed.end(),
                           [&](const char* key) { return o.key == key; });
    });
}

std::optional<std::string> option_value(const MethodSpec& spec, const std::string& key) {
    for (const MethodOption& o : spec.options) {
        if (o.key == key) {
            return o.value;
        }
    }
    return std::nullopt;
}

bool is_primary_only(const MethodSpec& spec) {
    return option_value(spec, "max-depth") == "0";
}

/// The time the curve needs to reach `target`, over `cone`'s time.
std::optional<HeadlineRatio> reach_ratio(const char* key, const BudgetCurve& curve, double target,
                                         const RunResult& cone) {
    const auto reach = time_to_error(curve.points, target);
    if (!reach) {
        return std::nullopt;
    }
    HeadlineRatio r;
    r.key = key;
    r.denominator = cone.spec;
    r.denominator_value = cone.render_seconds;
    r.numerator_value = reach->seconds;
    r.value = reach->seconds / cone.render_seconds;
    const RunResult* run = curve.run_at(reach->seconds, reach->rmse);
    r.numerator = run != nullptr ? run->spec : "";
    r.relation = relation_of(reach->kind);
    r.how = how_of(reach->kind);
    return r;
}

const RunResult* find_run(const std::vector<RunResult>& runs, bool (*wanted)(const MethodSpec&)) {
    for (const RunResult& run : runs) {
        if (wanted(parse_method_spec(run.spec))) {
            return &run;
        }
    }
    return nullptr;
}

HeadlineRatio time_ratio(const char* key, const RunResult& numerator,
                         const RunResult& denominator) {
    HeadlineRatio r;
    r.key = key;
    r.numerator = numerator.spec;
    r.denominator = denominator.spec;
    r.numerator_value = numerator.render_seconds;
    r.denominator_value = denominator.render_seconds;
    r.value = numerator.render_seconds / denominator.render_seconds;
    r.how = "measured";
    if (numerator.stopped) {
        // The numerator would have taken longer still had it been let finish.
        r.relation = RatioRelation::AtLeast;
        r.how = "stopped at its time guard";
    }
    return r;
}

}  // namespace

double error_of(const RunResult& run, ErrorMeasure measure) {
    return measure == ErrorMeasure::DisplayRmse ? run.display_rmse : run.rmse;
}

const RunResult* BudgetCurve::run_at(double seconds, double error) const {
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (points[i].seconds == seconds && points[i].rmse == error) {
            return runs[i];
        }
    }
    return nullptr;
}

BudgetCurve budget_curve(const std::vector<RunResult>& runs, const DefaultRun& kind,
                         ErrorMeasure measure) {
    BudgetCurve curve;
    for (const RunResult& run : runs) {
        if (const auto budget = time_budget_of(run.spec, kind)) {
            curve.points.push_back({run.render_seconds, error_of(run, measure), *budget});
            curve.runs.push_back(&run);
        }
    }
    return curve;
}

std::vector<HeadlineRatio> headline_ratios(const std::vector<RunResult>& runs) {
    std::vector<HeadlineRatio> ratios;
    const RunResult* whitted = find_run(
        runs, [](const MethodSpec& s) { return s.method == Method::Whitted && s.options.empty(); });
    const RunResult* cone = find_run(
        runs, [](const MethodSpec& s) { return s.method == Method::Cone && s.options.empty(); });
    const RunResult* cone_primary = find_run(runs, [](const MethodSpec& s) {
        return s.method == Method::Cone && s.options.size() == 1 && is_primary_only(s);
    });
    const RunResult* classic_primary = find_run(runs, [](const MethodSpec& s) {
        return s.method == Method::ConeClassic && is_primary_only(s) &&
               has_only(s, {"max-depth", "time-budget"});
    });

    if (cone != nullptr && whitted != nullptr && whitted->render_seconds > 0.0) {
        ratios.push_back(time_ratio("cone_over_whitted", *cone, *whitted));
    }
    DefaultRun distributed;
    distributed.method = Method::Distributed;
    const BudgetCurve curve = budget_curve(runs, distributed, ErrorMeasure::Rmse);
    const BudgetCurve display_curve = budget_curve(runs, distributed, ErrorMeasure::DisplayRmse);
    if (cone != nullptr && cone->render_seconds > 0.0) {
        if (auto r = reach_ratio("distributed_to_cone_error", curve, cone->rmse, *cone)) {
            ratios.push_back(*r);
        }
        if (auto r = reach_ratio("distributed_to_cone_display_error", display_curve,
                                 cone->display_rmse, *cone)) {
            ratios.push_back(*r);
        }
        if (const auto at = rmse_at_time(curve.points, cone->render_seconds);
            at && cone->rmse > 0.0) {
            HeadlineRatio r;
            r.key = "distributed_rmse_at_cone_time";
            r.denominator = cone->spec;
            r.denominator_value = cone->rmse;
            r.numerator_value = at->rmse;
            r.value = at->rmse / cone->rmse;
            const RunResult* run = curve.run_at(at->seconds, at->rmse);
            r.numerator = run != nullptr ? run->spec : "";
            r.how = how_of(at->kind);
            ratios.push_back(r);
        }
    }
    if (classic_primary != nullptr && cone_primary != nullptr &&
        cone_primary->render_seconds > 0.0) {
        ratios.push_back(time_ratio("classic_over_cone_primary", *classic_primary, *cone_primary));
    }
    return ratios;
}

RatioRelation relation_of(TimeToErrorKind kind) {
    switch (kind) {
        case TimeToErrorKind::AtMost:
            return RatioRelation::AtMost;
        case TimeToErrorKind::AtLeast:
            return RatioRelation::AtLeast;
        case TimeToErrorKind::Measured:
        case TimeToErrorKind::Interpolated:
            break;
    }
    return RatioRelation::Equal;
}

std::string_view how_of(TimeToErrorKind kind) {
    static constexpr EnumNames<TimeToErrorKind, 4> kHow{{{
        {TimeToErrorKind::Measured, "measured"},
        {TimeToErrorKind::Interpolated, "interpolated between two runs"},
        {TimeToErrorKind::AtMost, "even its fastest run is more accurate"},
        {TimeToErrorKind::AtLeast, "no run reaches it"},
    }}};
    return kHow.name(kind, "");
}

std::string_view relation_prefix(RatioRelation relation) {
    static constexpr EnumNames<RatioRelation, 3> kPrefixes{{{
        {RatioRelation::Equal, ""},
        {RatioRelation::AtMost, "≤ "},
        {RatioRelation::AtLeast, "≥ "},
    }}};
    return kPrefixes.name(relation, "");
}

std::string_view relation_name(RatioRelation relation) {
    static constexpr EnumNames<RatioRelation, 3> kNames{{{
        {RatioRelation::Equal, "equal"},
        {RatioRelation::AtMost, "at most"},
        {RatioRelation::AtLeast, "at least"},
    }}};
    return kNames.name(relation);
}

}  // namespace mrt
