#include "trace/render/method.h"

#include "common/system/error.h"

#include <algorithm>
#include <ostream>

namespace mrt {

namespace {

using enum Method;

/// What each method reads beyond the options all of them do. The order is the order mrt-trace
/// checks them in, so that of several wrong options the same one is named first.
constexpr std::array kMethodOnlyOptions = {
    MethodOnlyOption{"max-anisotropy", {Cone, ConeClassic}},
    MethodOnlyOption{"no-level-blend", {Cone, ConeClassic}},
    MethodOnlyOption{"node-frames", {Cone, ConeClassic}},
    MethodOnlyOption{"keep-back-faces", {Cone, ConeClassic}},
    MethodOnlyOption{"triangle-weight", {Cone, ConeClassic}},
    MethodOnlyOption{"abuffer", {Cone, ConeClassic}},
    MethodOnlyOption{"mask-every-cone", {Cone, ConeClassic}},
    MethodOnlyOption{"refine", {Cone, ConeClassic}},
    MethodOnlyOption{"refine-levels", {Cone, ConeClassic}},
    MethodOnlyOption{"highlight-detail", {Cone}},
    MethodOnlyOption{"mean-highlights", {Cone, ConeClassic}},
    MethodOnlyOption{"spp",
                     {Whitted, Distributed},
                     "the cone methods trace one cone per pixel (more where --refine asks)"},
    MethodOnlyOption{"spp-initial", {Distributed}},
    MethodOnlyOption{"spp-max", {Distributed}},
    MethodOnlyOption{"target-error", {Distributed}},
    MethodOnlyOption{"reference", {Distributed}},
    MethodOnlyOption{"time-budget", {Distributed, Cone, ConeClassic}},
};

}  // namespace

std::ostream& operator<<(std::ostream& os, Method method) {
    return os << to_string(method);
}

std::optional<Method> find_method(std::string_view name) {
    return kMethodNames.find(name);
}

std::vector<std::string> method_names() {
    return kMethodNames.names();
}

std::string method_choices() {
    return kMethodNames.choices();
}

Method parse_method(std::string_view name) {
    if (const std::optional<Method> method = find_method(name)) {
        return *method;
    }
    throw Error("method \"" + std::string(name) + "\": no such method (expected " +
                method_choices() + ")");
}

std::span<const MethodOnlyOption> method_only_options() {
    return kMethodOnlyOptions;
}

const MethodOnlyOption* find_method_only_option(std::string_view key) {
    const auto it = std::find_if(kMethodOnlyOptions.begin(), kMethodOnlyOptions.end(),
                                 [&](const MethodOnlyOption& o) { return o.key == key; });
    return it == kMethodOnlyOptions.end() ? nullptr : &*it;
}

bool takes_option(Method method, std::string_view key) {
    const MethodOnlyOption* option = find_method_only_option(key);
    return option == nullptr || option->methods.contains(method);
}

std::string refusal(const MethodOnlyOption& option) {
    if (!option.reason.empty()) {
        return std::string(option.reason);
    }
    // The two cone methods read the same options, so they are named together ("the cone
    // methods").
    const bool both_cones = option.methods.contains(Cone) && option.methods.contains(ConeClassic);
    std::vector<std::string> names;
    int count = 0;
    for (const Method m : kMethods) {
        if (option.methods.contains(m)) {
            ++count;
            if (!(both_cones && m == ConeClassic)) {
                names.push_back("the " + std::string(to_string(m)));
            }
        }
    }
    std::string text = "only ";
    for (std::size_t i = 0; i < names.size(); ++i) {
        text += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + names[i];
    }
    return text + (count == 1 ? " method takes it" : " methods take it");
}

}  // namespace mrt
