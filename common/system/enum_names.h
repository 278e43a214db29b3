#pragma once
// The names of an enum's values in one table, which printing, parsing and the list of choices
// in a message all read, so a new value is one row and no printer or parser can miss it:
//
//     inline constexpr EnumNames<Differentials, 2> kDifferentialsNames{{{
//         {Differentials::WhenRead, "when-read"},
//         {Differentials::Always, "always"},
//     }}};
//     kDifferentialsNames.name(Differentials::Always)  → "always"
//     kDifferentialsNames.find("when-read")            → Differentials::WhenRead
//     kDifferentialsNames.choices()                    → "when-read or always"
//     kDifferentialsNames.names()                      → {"when-read", "always"}

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace mrt {

template <typename E, std::size_t N>
class EnumNames {
  public:
    using Entry = std::pair<E, std::string_view>;

    constexpr explicit EnumNames(const std::array<Entry, N>& entries) : m_entries(entries) {}

    /// The name of `value`; `fallback` for a value the table does not list (a corrupt enum).
    constexpr std::string_view name(E value, std::string_view fallback = "unknown") const {
        for (const Entry& entry : m_entries) {
            if (entry.first == value) {
                return entry.second;
            }
        }
        return fallback;
    }

    /// The value named `text`, or nothing when no value has that name.
    constexpr std::optional<E> find(std::string_view text) const {
        for (const Entry& entry : m_entries) {
            if (entry.second == text) {
                return entry.first;
            }
        }
        return std::nullopt;
    }

    /// The names, in the table's order (a command line's list of choices).
    std::vector<std::string> names() const {
        std::vector<std::string> all;
        for (const Entry& entry : m_entries) {
            all.emplace_back(entry.second);
        }
        return all;
    }

    /// The names for a message, in the table's order: "a, b or c".
    std::string choices(std::string_view last_separator = " or ") const {
        std::string text;
        for (std::size_t i = 0; i < N; ++i) {
            text += i == 0 ? "" : i + 1 == N ? last_separator : ", ";
            text += m_entries[i].second;
        }
        return text;
    }

    constexpr auto begin() const { return m_entries.begin(); }
    constexpr auto end() const { return m_entries.end(); }
    static constexpr std::size_t size() { return N; }

  private:
    std::array<Entry, N> m_entries;
};

}  // namespace mrt
