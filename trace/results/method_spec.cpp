#include "trace/results/method_spec.h"

#include "common/system/error.h"
#include "trace/render/method.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <ostream>

namespace mrt {

namespace {

bool is_name_char(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-';
}

bool is_name(const std::string& s) {
    return !s.empty() && std::all_of(s.begin(), s.end(), is_name_char);
}

Error spec_error(const std::string& text, const std::string& problem) {
    return Error(
        fmt::format("method spec \"{}\": {} (expected NAME[:key=value,...], e.g. "
                    "distributed:spp-max=16)",
                    text, problem));
}

std::vector<std::string> split(const std::string& s, char separator) {
    std::vector<std::string> parts;
    std::string::size_type start = 0;
    while (true) {
        const auto end = s.find(separator, start);
        parts.push_back(s.substr(start, end - start));
        if (end == std::string::npos) {
            return parts;
        }
        start = end + 1;
    }
}

/// The spec, once its syntax holds, with its method named `method_name`: refused when that is
/// no method or an option is other methods' only, which mrt-trace would refuse after the
/// comparison had spent time on the runs before it.
MethodSpec checked_against_method(MethodSpec spec, const std::string& method_name) {
    const std::optional<Method> method = find_method(method_name);
    if (!method) {
        throw spec_error(spec.text, fmt::format("\"{}\" is not a method of mrt-trace ({})",
                                                method_name, method_choices()));
    }
    spec.method = *method;
    for (const MethodOption& option : spec.options) {
        if (!takes_option(spec.method, option.key)) {
            throw spec_error(spec.text,
                             fmt::format("the {} method does not take option \"{}\" ({})",
                                         to_string(spec.method), option.key,
                                         refusal(*find_method_only_option(option.key))));
        }
    }
    return spec;
}

/// The name of a method, as a spec writes it.
std::string name(Method method) {
    return std::string(to_string(method));
}

}  // namespace

const std::vector<std::string>& refused_option_keys() {
    static const std::vector<std::string> keys = {"output", "stats",  "quiet",     "width",
                                                  "height", "filter", "reference", "threads",
                                                  "method", "seed",   "crop"};
    return keys;
}

MethodSpec parse_method_spec(const std::string& text) {
    MethodSpec spec;
    spec.text = text;
    const auto colon = text.find(':');
    const std::string method_name = text.substr(0, colon);
    if (method_name.empty()) {
        throw spec_error(text, "the method name is empty");
    }
    if (!is_name(method_name)) {
        throw spec_error(text, fmt::format("\"{}\" is not a method name", method_name));
    }
    if (colon == std::string::npos) {
        return checked_against_method(std::move(spec), method_name);
    }
    const std::string list = text.substr(colon + 1);
    if (list.empty()) {
        throw spec_error(text, "nothing follows ':'");
    }
    for (const std::string& item : split(list, ',')) {
        if (item.empty()) {
            throw spec_error(text, "an empty option between commas");
        }
        MethodOption option;
        const auto equals = item.find('=');
        option.key = item.substr(0, equals);
        if (equals != std::string::npos) {
            option.value = item.substr(equals + 1);
        }
        if (option.key.empty()) {
            throw spec_error(text, fmt::format("option \"{}\" has no key", item));
        }
        if (option.key.front() == '-') {
            throw spec_error(text, fmt::format("write option \"{}\" without dashes", option.key));
        }
        if (!is_name(option.key)) {
            throw spec_error(text, fmt::format("\"{}\" is not an option name", option.key));
        }
        if (option.value && option.value->empty()) {
            throw spec_error(text,
                             fmt::format("option \"{}\" has an empty value after '='", option.key));
        }
        const auto& refused = refused_option_keys();
        if (std::find(refused.begin(), refused.end(), option.key) != refused.end()) {
            throw spec_error(text, fmt::format("option \"{}\" is set by mrt-compare for every "
                                               "run and cannot be given in a spec",
                                               option.key));
        }
        const bool repeated =
            std::any_of(spec.options.begin(), spec.options.end(),
                        [&](const MethodOption& o) { return o.key == option.key; });
        if (repeated) {
            throw spec_error(text, fmt::format("option \"{}\" is given twice", option.key));
        }
        spec.options.push_back(std::move(option));
    }
    return checked_against_method(std::move(spec), method_name);
}

std::vector<std::string> trace_arguments(const MethodSpec& spec) {
    std::vector<std::string> args = {"--method", name(spec.method)};
    for (const MethodOption& option : spec.options) {
        args.push_back("--" + option.key);
        if (option.value) {
            args.push_back(*option.value);
        }
    }
    return args;
}

std::string spec_slug(const std::string& spec_text) {
    std::string slug = spec_text;
    for (char& c : slug) {
        const bool keep = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                          (c >= '0' && c <= '9') || c == '.' || c == '-';
        if (!keep) {
            c = '-';
        }
    }
    return slug;
}

// The runs of every method (trace/render/method.h); a tracer mrt-trace gains gets its runs here.
const std::vector<DefaultRun>& default_runs() {
    using enum Method;
    static const std::vector<DefaultRun> runs = {
        {Whitted, "", 0.0},
        {Whitted, "spp=4", 0.0},
        {Distributed, "spp-max=4", 0.0},
        {Distributed, "spp-max=16", 0.0},
        {Distributed, "spp-max=64", 0.0},
        // Time budgets of 4×, 16× and 64× what whitted took: the distributed curve from a cheap
        // anti-aliasing pass to a nearly converged image, for equal-time readings.
        {Distributed, "", 4.0},
        {Distributed, "", 16.0},
        {Distributed, "", 64.0},
        {Cone, "", 0.0},
        // Classic cone tracing can run for hours on a detailed scene: it gets 64× whitted's
        // time and stops there cleanly, saying so (its stats' "stopped").
        {ConeClassic, "", 64.0},
        // The headline ratios (headline_ratios.h), each measured in this one run: primary rays
        // alone, where classic cone tracing is compared with ours (Wand & Straßer §6 found it
        // 2.8× slower), classic given 16× our time before it stops; distributed at our time;
        // and the distributed budgets that reach our RMSE and our display-referred RMSE,
        // searched for and measured, up to 16× our time.
        {Cone, "max-depth=0", 0.0},
        {ConeClassic, "max-depth=0", 16.0, name(Cone) + ":max-depth=0"},
        {Distributed, "", 1.0, name(Cone)},
        {.method = Distributed,
         .options = "",
         .budget_factor = 16.0,
         .budget_of = name(Cone),
         .to_equal_error = true,
         .measure = ErrorMeasure::Rmse},
        {.method = Distributed,
         .options = "",
         .budget_factor = 16.0,
         .budget_of = name(Cone),
         .to_equal_error = true,
         .measure = ErrorMeasure::DisplayRmse},
    };
    return runs;
}

const std::string& DefaultRun::budget_base() const {
    return budget_of.empty() ? baseline_spec() : budget_of;
}

const std::string& baseline_spec() {
    static const std::string spec = name(Method::Whitted);
    return spec;
}

std::string default_run_spec(const DefaultRun& run) {
    return run.options.empty() ? name(run.method) : name(run.method) + ":" + run.options;
}

std::string format_budget_seconds(double seconds) {
    constexpr double kMinimum = kMinimumBudgetSeconds;
    if (!(seconds > kMinimum)) {
        return "0.05";
    }
    // Three significant digits: round at 10^(magnitude − 2), which is a power of ten above 1
    // for budgets of 1000 s and more (1234.5 → 1230).
    const int magnitude = static_cast<int>(std::floor(std::log10(seconds)));
    const double scale = std::pow(10.0, 2 - magnitude);
    const double rounded = std::max(kMinimum, std::round(seconds * scale) / scale);
    // Trailing zeros are dropped below, so a carry into a new digit (9.996 → "10") is harmless.
    const int decimals = std::max(0, 2 - magnitude);
    std::string s = fmt::format("{:.{}f}", rounded, decimals);
    if (s.find('.') != std::string::npos) {
        s.erase(s.find_last_not_of('0') + 1);
        if (s.back() == '.') {
            s.pop_back();
        }
    }
    return s;
}

std::string budget_run_spec(const DefaultRun& run, double baseline_seconds) {
    // The baseline is floored so that the budgets keep their ratios above the 0.05 s minimum:
    // on a tiny image whitted takes a millisecond and 4×, 16× and 64× of it would all become
    // the same 0.05 s run.
    const double base = std::isfinite(baseline_seconds)
                            ? std::max(baseline_seconds, kMinimumBudgetBaseSeconds)
                            : kMinimumBudgetBaseSeconds;
    return spec_with_budget(run, run.budget_factor * base);
}

std::string spec_with_budget(const DefaultRun& run, double seconds) {
    const std::string budget = "time-budget=" + format_budget_seconds(seconds);
    return name(run.method) + ":" + (run.options.empty() ? budget : run.options + "," + budget);
}

std::optional<double> time_budget_of(const std::string& spec_text, const DefaultRun& run) {
    const std::string prefix =
        name(run.method) + ":" + (run.options.empty() ? "" : run.options + ",") + "time-budget=";
    if (spec_text.rfind(prefix, 0) != 0) {
        return std::nullopt;
    }
    const char* first = spec_text.data() + prefix.size();
    const char* last = spec_text.data() + spec_text.size();
    double seconds = 0.0;
    const auto [end, error] = std::from_chars(first, last, seconds);
    if (error != std::errc() || end != last || first == last) {
        return std::nullopt;
    }
    return seconds;
}

std::ostream& operator<<(std::ostream& os, const MethodOption& o) {
    os << "MethodOption{" << o.key;
    if (o.value) {
        os << "=" << *o.value;
    }
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const MethodSpec& s) {
    os << "MethodSpec{\"" << s.text << "\", method " << s.method;
    for (const MethodOption& o : s.options) {
        os << ", " << o;
    }
    return os << "}";
}

}  // namespace mrt
