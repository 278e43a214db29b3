#pragma once
// The tracers mrt-trace offers and which of its options each one reads: the one table mrt-trace
// checks its command line against and mrt-compare checks its method specs against, so neither
// learns the methods from the other's text. A new tracer is a new Method, its name in to_string,
// and its row in the options it reads (method.cpp).

#include "common/system/enum_names.h"

#include <array>
#include <cstdint>
#include <initializer_list>
#include <iosfwd>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace mrt {

/// A tracer, as mrt-trace's --method names it.
enum class Method : std::uint8_t {
    Whitted,      ///< "whitted": the conventional ray tracer (trace/raytrace/whitted.h).
    Distributed,  ///< "distributed": the adaptive stochastic tracer (trace/raytrace/distributed.h).
    Cone,         ///< "cone": multi-resolution cone tracing (trace/cone/cone_tracer.h).
    ConeClassic,  ///< "cone-classic": the same against every triangle, no points (§6).
};

/// Every method and its name on the command line and in --stats, in the order mrt-trace's
/// --help lists them.
inline constexpr EnumNames<Method, 4> kMethodNames{{{
    {Method::Whitted, "whitted"},
    {Method::Distributed, "distributed"},
    {Method::Cone, "cone"},
    {Method::ConeClassic, "cone-classic"},
}}};

/// Every method, in kMethodNames' order.
inline constexpr std::array kMethods = {Method::Whitted, Method::Distributed, Method::Cone,
                                        Method::ConeClassic};
static_assert(kMethods.size() == kMethodNames.size());

/// The method's name ("cone-classic").
constexpr std::string_view to_string(Method method) {
    return kMethodNames.name(method);
}
std::ostream& operator<<(std::ostream& os, Method method);

/// The method named `name`, or nothing when no method has that name.
std::optional<Method> find_method(std::string_view name);

/// The method named `name`; throws mrt::Error listing the names otherwise.
Method parse_method(std::string_view name);

/// Every method's name, in kMethods' order (for a command line's list of choices).
std::vector<std::string> method_names();

/// The names for a message: "whitted, distributed, cone or cone-classic".
std::string method_choices();

/// The methods that trace cones through the hierarchy (`cone`, `cone-classic`).
constexpr bool is_cone(Method method) {
    return method == Method::Cone || method == Method::ConeClassic;
}

/// A set of methods.
class MethodSet {
  public:
    constexpr MethodSet(std::initializer_list<Method> methods) {
        for (const Method m : methods) {
            m_bits |= bit(m);
        }
    }
    constexpr bool contains(Method method) const { return (m_bits & bit(method)) != 0; }

  private:
    static constexpr unsigned bit(Method m) { return 1u << static_cast<unsigned>(m); }
    unsigned m_bits = 0;
};

/// An option of mrt-trace that only some methods read; every other option, every method reads.
struct MethodOnlyOption {
    std::string_view key;  ///< Long option name, without the dashes ("spp-max").
    MethodSet methods;     ///< The methods that read it; the others refuse it.
    /// Why the others refuse it, when there is more to say than which methods take it.
    std::string_view reason{};
};

/// Every option that only some methods read, in the order mrt-trace checks them.
std::span<const MethodOnlyOption> method_only_options();

/// The row of `key` in method_only_options(), or null for an option every method reads (or
/// none does).
const MethodOnlyOption* find_method_only_option(std::string_view key);

/// Whether `method` reads option `key`: false only for a method-only option of other methods.
bool takes_option(Method method, std::string_view key);

/// Why a method the option is not for refuses it: its reason, or which methods take it ("only
/// the distributed and the cone methods take it").
std::string refusal(const MethodOnlyOption& option);

}  // namespace mrt
