#pragma once
// Records that list their fields once. A stats record declares
//
//     static constexpr auto fields = std::tuple{Field{"rays", &Stats::rays}, ...};
//
// and that one list drives adding two records up (add_fields), printing one (print_fields) and
// writing it out (for_each_field, which a JSON writer walks), so a new counter is one line and
// no output can forget it.
//
// A field is a data member, or a const member function for a value derived from the others
// (a mean, a total): derived values are printed and written but not added up. Embedded{&T::m}
// makes m's own fields count as the record's (printed and written inline, added with m's +=).

#include <functional>
#include <optional>
#include <ostream>
#include <string_view>
#include <tuple>
#include <type_traits>

namespace mrt {

/// One field of record T: its name where it is printed and written, and the member.
template <class T, class M>
struct Field {
    const char* name;
    M T::*member;
};

/// A record inside record T whose fields are T's own.
template <class T, class M>
struct Embedded {
    M T::*member;
};

/// A record that lists its fields.
template <class T>
concept HasFields = requires {
    std::tuple_size<decltype(T::fields)>::value;
};

namespace fields_detail {

template <class D>
inline constexpr bool is_embedded = false;
template <class T, class M>
inline constexpr bool is_embedded<Embedded<T, M>> = true;

template <class V>
inline constexpr bool is_optional = false;
template <class V>
inline constexpr bool is_optional<std::optional<V>> = true;

/// Calls f(descriptor) for each entry of T::fields.
template <class T, class F>
constexpr void for_each_descriptor(F&& f) {
    std::apply([&](const auto&... descriptor) { (f(descriptor), ...); }, T::fields);
}

template <class V>
void print_value(std::ostream& os, const V& value) {
    if constexpr (std::is_same_v<V, bool>) {
        os << (value ? "true" : "false");
    } else if constexpr (is_optional<V>) {
        if (value) {
            print_value(os, *value);
        } else {
            os << "none";
        }
    } else {
        os << value;
    }
}

}  // namespace fields_detail

/// Calls f(name, value) for every field of `record`, embedded records' fields in their place.
template <HasFields T, class F>
void for_each_field(const T& record, F&& f) {
    fields_detail::for_each_descriptor<T>([&](const auto& d) {
        if constexpr (fields_detail::is_embedded<std::decay_t<decltype(d)>>) {
            for_each_field(record.*d.member, f);
        } else {
            f(std::string_view(d.name), std::invoke(d.member, record));
        }
    });
}

/// a += b field by field: counters and sums add, flags or (a stop anywhere stops the whole),
/// embedded and nested records add with their own +=, derived values are left alone.
template <HasFields T>
T& add_fields(T& a, const T& b) {
    fields_detail::for_each_descriptor<T>([&](const auto& d) {
        if constexpr (std::is_member_object_pointer_v<decltype(d.member)>) {
            auto& mine = a.*d.member;
            if constexpr (std::is_same_v<std::decay_t<decltype(mine)>, bool>) {
                mine = mine || b.*d.member;
            } else {
                mine += b.*d.member;
            }
        }
    });
    return a;
}

/// "Name{field value, field value, ...}" with every field; flags as true/false, absent optional
/// values as "none", nested records with their own <<.
template <HasFields T>
std::ostream& print_fields(std::ostream& os, std::string_view type_name, const T& record) {
    os << type_name << '{';
    const char* separator = "";
    for_each_field(record, [&](std::string_view name, const auto& value) {
        os << separator << name << ' ';
        fields_detail::print_value(os, value);
        separator = ", ";
    });
    return os << '}';
}

}  // namespace mrt
