#pragma once
// Strict, location-aware reading of the scene file's JSON (internal to the scene loader). Every
// value carries its JSON pointer, so any rejection can say "FILE: POINTER: found X, expected Y".

#include "common/math/math.h"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace mrt {

/// Keys keep their document order, so materials and groups are indexed in the order written.
using Json = nlohmann::ordered_json;

/// Deepest nesting of arrays and objects parse_json_text accepts (the top-level value is level
/// 1). A scene needs about 10 (a rotation's axis inside a transform step inside an object of a
/// group); the limit keeps every walk over the document, recursive or not, far from the stack's
/// end whatever the file holds.
inline constexpr std::size_t kMaxJsonNesting = 64;

/// Parses JSON text. Syntax errors become Error(file, "line L, column C", "JSON syntax error: …");
/// nesting deeper than kMaxJsonNesting is refused at the opening bracket ("line L, column C (byte
/// B)") before anything is built; duplicate keys and numbers that overflow to infinity are
/// rejected at their JSON pointer.
Json parse_json_text(const std::string& text, const std::filesystem::path& file);

/// 1-based line and column of the byte at `offset` (0-based) of `text`.
std::pair<std::size_t, std::size_t> line_and_column(const std::string& text, std::size_t offset);

/// A key escaped as one JSON pointer reference token (RFC 6901: "~" → "~0", "/" → "~1").
std::string pointer_token(std::string_view key);

/// Compact JSON text of a value for messages, cut short (with "...") when long or deep.
std::string describe_json(const Json& value);

/// Names sorted and joined with ", ", cut short after a readable number of them.
std::string join_names(std::vector<std::string> names);

/// Bounds of an accepted number; the description reads "a number in (0, 180)", "a number >= 0"…
struct NumberRange {
    double low = -kInfinity;
    double high = kInfinity;
    bool low_open = false;
    bool high_open = false;

    static NumberRange any() { return {}; }
    static NumberRange at_least(double low) { return {low, kInfinity, false, false}; }
    static NumberRange above(double low) { return {low, kInfinity, true, false}; }
    static NumberRange closed(double low, double high) { return {low, high, false, false}; }
    static NumberRange open(double low, double high) { return {low, high, true, true}; }

    bool contains(double x) const;
    std::string describe() const;
};

/// One JSON value and where it is. Refers to the parsed document and the file path, which must
/// outlive it.
class JsonValue {
  public:
    JsonValue(const std::filesystem::path& file, const Json& value, std::string pointer)
        : m_file(&file), m_value(&value), m_pointer(std::move(pointer)) {}

    const Json& json() const { return *m_value; }
    const std::string& pointer() const { return m_pointer; }

    /// Throws Error(file, pointer, message).
    [[noreturn]] void fail(const std::string& message) const;
    /// Throws "found <this value>, expected <expected>".
    [[noreturn]] void fail_expected(std::string_view expected) const;

    float number(const NumberRange& range = NumberRange::any()) const;
    /// As number(), without the rounding to single precision: for values that are converted
    /// (degrees to radians) before they are stored, so that they are rounded once.
    double double_number(const NumberRange& range = NumberRange::any()) const;
    float nonzero_number() const;
    int integer(int low, int high) const;
    bool boolean() const;
    std::string string() const;
    /// A string equal to one of `choices`.
    std::string choice(const std::vector<std::string>& choices) const;

    Vec2f vec2(const NumberRange& range = NumberRange::any()) const;
    Vec3f vec3(const NumberRange& range = NumberRange::any()) const;
    /// An array of 3 numbers, not all zero.
    Vec3f nonzero_vec3() const;
    /// An array of 2 numbers or one number (used for both components).
    Vec2f vec2_or_number(const NumberRange& range = NumberRange::any()) const;
    /// Linear RGB: an array of 3 numbers or one number (grey); components ≥ 0.
    Rgb colour() const;
    /// An array of `count` numbers (row-major for matrices).
    std::vector<float> numbers(std::size_t count, std::string_view expected) const;

    /// The elements of an array (fails unless it is one).
    std::vector<JsonValue> elements(std::string_view expected = "an array") const;
    /// The members of an object in document order (fails unless it is one).
    std::vector<std::pair<std::string, JsonValue>> members(
        std::string_view expected = "an object") const;
    /// A member of an object without key checks (fails unless this is an object).
    std::optional<JsonValue> find(std::string_view key) const;

  private:
    JsonValue child(const Json& value, std::string_view token) const;
    float number_element(const Json& element, std::size_t index, const NumberRange& range) const;

    const std::filesystem::path* m_file;
    const Json* m_value;
    std::string m_pointer;
};

/// An object whose keys must all come from a fixed set (strict, as Mitsuba is): constructing it
/// rejects a non-object and the first unknown key.
class JsonObject {
  public:
    JsonObject(const JsonValue& value, std::vector<std::string> allowed_keys);

    const JsonValue& value() const { return m_value; }
    std::optional<JsonValue> optional(std::string_view key) const;
    /// Fails at the object's pointer with `missing required key "KEY"` when absent.
    JsonValue required(std::string_view key) const;

  private:
    JsonValue m_value;
};

}  // namespace mrt
