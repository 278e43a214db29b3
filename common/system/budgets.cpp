#include "common/system/budgets.h"

#include "common/system/error.h"

#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <ostream>

namespace mrt {
namespace {

/// The field of each name of kBudgetNames, in the same order.
constexpr std::array<std::uint64_t Budgets::*, std::size(kBudgetNames)> kBudgetFields{
    &Budgets::instanced_triangles,
    &Budgets::instances,
    &Budgets::procedural_triangles,
    &Budgets::group_nesting,
    &Budgets::octree_depth,
    &Budgets::points,
    &Budgets::pixels};

std::uint64_t Budgets::*budget_field(std::string_view name) {
    for (std::size_t i = 0; i < kBudgetFields.size(); ++i) {
        if (kBudgetNames[i] == name) {
            return kBudgetFields[i];
        }
    }
    std::string names;
    for (const std::string_view n : kBudgetNames) {
        if (!names.empty()) {
            names += ", ";
        }
        names.append(n);
    }
    throw Error("unknown budget '" + std::string(name) + "' (expected one of " + names + ")");
}

/// A count as people read it: exact below a million, else three significant digits.
std::string readable_count(std::uint64_t n) {
    if (n == std::numeric_limits<std::uint64_t>::max()) {
        return "more than 1.8e19";
    }
    if (n < 1'000'000) {
        return std::to_string(n);
    }
    char text[32];
    std::snprintf(text, sizeof text, "%.3g", static_cast<double>(n));
    return text;
}

}  // namespace

std::uint64_t& budget(Budgets& budgets, std::string_view name) {
    return budgets.*budget_field(name);
}

std::uint64_t budget(const Budgets& budgets, std::string_view name) {
    return budgets.*budget_field(name);
}

void set_budget(Budgets& budgets, std::string_view assignment) {
    const std::size_t eq = assignment.find('=');
    if (eq == std::string_view::npos) {
        throw Error("--budget " + std::string(assignment) + ": expected NAME=VALUE");
    }
    std::uint64_t& limit = budget(budgets, assignment.substr(0, eq));
    const std::string value(assignment.substr(eq + 1));
    const auto invalid = [&] {
        return Error("--budget " + std::string(assignment) +
                     ": expected a whole number from 1 to 1.8e19 after '='");
    };
    std::uint64_t parsed = 0;
    const char* const end = value.data() + value.size();
    const auto [ptr, ec] = std::from_chars(value.data(), end, parsed);
    if (ec == std::errc() && ptr == end && parsed > 0) {
        limit = parsed;
        return;
    }
    // Numbers such as 2e9: accepted when they are whole and in range.
    double real = 0.0;
    const auto [rptr, rec] = std::from_chars(value.data(), end, real);
    if (rec != std::errc() || rptr != end || !(real >= 1.0) || real != std::floor(real) ||
        real >= 18446744073709551616.0) {
        throw invalid();
    }
    limit = static_cast<std::uint64_t>(real);
}

void check_budget(const Budgets& budgets, std::string_view name, std::uint64_t asked,
                  std::string_view what, const std::filesystem::path& file,
                  const std::string& location) {
    const std::uint64_t limit = budget(budgets, name);
    if (asked <= limit) {
        return;
    }
    throw Error(file, location,
                "the scene asks for " + readable_count(asked) + " " + std::string(what) +
                    ", over the limit of " + readable_count(limit) + " (raise it with --budget " +
                    std::string(name) + "=N)");
}

std::string budget_help() {
    const Budgets defaults;
    std::string text = "Raise a limit on the work a scene may ask for, NAME=VALUE (repeatable):";
    for (const std::string_view name : kBudgetNames) {
        text += ' ';
        text.append(name);
        text += " (" + readable_count(budget(defaults, name)) + ')';
    }
    return text;
}

std::ostream& operator<<(std::ostream& os, const Budgets& b) {
    os << "Budgets{";
    bool first = true;
    for (const std::string_view name : kBudgetNames) {
        os << (first ? "" : ", ") << name << '=' << budget(b, name);
        first = false;
    }
    return os << '}';
}

}  // namespace mrt
