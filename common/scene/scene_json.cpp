#include "common/scene/scene_json.h"

#include "common/system/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

namespace mrt {

namespace {

constexpr std::size_t kMaxDescriptionLength = 80;
constexpr int kMaxDescriptionDepth = 3;
constexpr std::size_t kMaxListedNames = 20;
// Scene values are single precision: larger magnitudes would silently become infinite.
constexpr std::string_view kFiniteNumber = "a finite number of magnitude <= 3.4e38";

/// Builds the document from SAX events (nlohmann's own DOM builder keeps the last of duplicate
/// keys silently and reports overflowing numbers without saying which value they were).
class DomBuilder {
  public:
    DomBuilder(Json& root, const std::string& text, const std::filesystem::path& file)
        : m_root(root), m_text(text), m_file(file) {}

    bool null() { return add(Json(nullptr)); }
    bool boolean(bool value) { return add(Json(value)); }
    bool number_integer(Json::number_integer_t value) { return add(Json(value)); }
    bool number_unsigned(Json::number_unsigned_t value) { return add(Json(value)); }
    bool number_float(Json::number_float_t value, const Json::string_t& /*text*/) {
        return add(Json(value));
    }
    bool string(Json::string_t& value) { return add(Json(std::move(value))); }
    bool binary(Json::binary_t& value) { return add(Json(std::move(value))); }

    bool start_object(std::size_t /*elements*/) { return open(Json::object()); }
    bool end_object() { return close(); }
    bool start_array(std::size_t /*elements*/) { return open(Json::array()); }
    bool end_array() { return close(); }

    bool key(Json::string_t& key) {
        Frame& frame = m_stack.back();
        if (!frame.keys.insert(key).second) {
            throw Error(m_file, pointer_of_open_frames() + "/" + pointer_token(key),
                        "duplicate key (each key may appear once per object)");
        }
        frame.key = std::move(key);
        return true;
    }

    bool parse_error(std::size_t position, const std::string& last_token,
                     const Json::exception& error) {
        if (error.id == 406) {
            throw Error(m_file, pointer_of_next_value(),
                        fmt::format("found {}, expected {}", last_token, kFiniteNumber));
        }
        // nlohmann counts characters read including the offending one.
        const std::size_t offset = position > 0 ? position - 1 : 0;
        const auto [line, column] = line_and_column(m_text, offset);
        throw Error(m_file, fmt::format("line {}, column {}", line, column),
                    "JSON syntax error: " + strip_nlohmann_prefix(error.what()));
    }

  private:
    struct Frame {
        Json* container = nullptr;
        std::string key;
        std::unordered_set<std::string> keys;
    };

    Json* add(Json&& value) {
        if (m_stack.empty()) {
            m_root = std::move(value);
            return &m_root;
        }
        Frame& frame = m_stack.back();
        if (frame.container->is_array()) {
            frame.container->push_back(std::move(value));
            return &frame.container->back();
        }
        // Appending directly skips ordered_map's linear key search; keys were checked unique.
        auto& object = frame.container->get_ref<Json::object_t&>();
        object.Container::emplace_back(frame.key, std::move(value));
        return &object.Container::back().second;
    }

    bool open(Json&& container) {
        // A container stays last in its parent until closed, so these pointers stay valid.
        m_stack.push_back(Frame{add(std::move(container)), {}, {}});
        return true;
    }

    bool close() {
        m_stack.pop_back();
        return true;
    }

    std::string pointer_of_open_frames() const {
        std::string pointer;
        for (std::size_t i = 0; i + 1 < m_stack.size(); ++i) {
            pointer += "/" + token_of_child(m_stack[i], false);
        }
        return pointer;
    }

    std::string pointer_of_next_value() const {
        std::string pointer;
        for (std::size_t i = 0; i < m_stack.size(); ++i) {
            pointer += "/" + token_of_child(m_stack[i], i + 1 == m_stack.size());
        }
        return pointer;
    }

    // An open child is the last element of its array; the next value goes after it. In an object
    // either is the member of the last key read.
    static std::string token_of_child(const Frame& frame, bool next_value) {
        if (frame.container->is_array()) {
            const std::size_t size = frame.container->size();
            return std::to_string(next_value || size == 0 ? size : size - 1);
        }
        return pointer_token(frame.key);
    }

    static std::string strip_nlohmann_prefix(std::string message) {
        // "[json.exception.parse_error.101] parse error at line 1, column 2: syntax error ..."
        if (const auto bracket = message.find("] "); bracket != std::string::npos) {
            message.erase(0, bracket + 2);
        }
        if (message.starts_with("parse error")) {
            if (const auto colon = message.find(": "); colon != std::string::npos) {
                message.erase(0, colon + 2);
            }
        }
        // Our prefix already says "JSON syntax error: ".
        constexpr std::string_view kRedundant = "syntax error ";
        if (message.starts_with(kRedundant)) {
            message.erase(0, kRedundant.size());
        }
        return message;
    }

    Json& m_root;
    const std::string& m_text;
    const std::filesystem::path& m_file;
    std::vector<Frame> m_stack;
};

void describe_into(const Json& value, std::string& out, int depth) {
    if (out.size() > kMaxDescriptionLength) {
        return;
    }
    if (value.is_object() || value.is_array()) {
        const bool object = value.is_object();
        const char* brackets = object ? "{}" : "[]";
        if (value.empty()) {
            out += brackets;
            return;
        }
        out += brackets[0];
        if (depth >= kMaxDescriptionDepth) {
            out += "...";
        } else {
            bool first = true;
            for (auto it = value.begin(); it != value.end(); ++it) {
                if (!first) {
                    out += ',';
                }
                first = false;
                if (out.size() > kMaxDescriptionLength) {
                    out += "...";
                    break;
                }
                if (object) {
                    out += Json(it.key()).dump() + ":";
                }
                describe_into(*it, out, depth + 1);
            }
        }
        out += brackets[1];
        return;
    }
    out += value.dump(-1, ' ', false, Json::error_handler_t::replace);
}

/// Refuses the first '[' or '{' that opens level kMaxJsonNesting + 1, counting brackets outside
/// strings. It runs before the parser, so nothing is built from such a document; brackets that do
/// not match are left to the parser to report.
void check_nesting(const std::string& text, const std::filesystem::path& file) {
    std::size_t depth = 0;
    bool in_string = false;
    bool escaped = false;
    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (in_string) {
            if (escaped) {
                escaped = false;
            } else if (c == '\\') {
                escaped = true;
            } else if (c == '"') {
                in_string = false;
            }
            continue;
        }
        if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxJsonNesting) {
                const auto [line, column] = line_and_column(text, i);
                throw Error(file, fmt::format("line {}, column {} (byte {})", line, column, i),
                            fmt::format("arrays and objects nest deeper than {} levels (a scene "
                                        "needs about 10)",
                                        kMaxJsonNesting));
            }
        } else if ((c == ']' || c == '}') && depth > 0) {
            --depth;
        }
    }
}

}  // namespace

Json parse_json_text(const std::string& text, const std::filesystem::path& file) {
    check_nesting(text, file);
    Json root;
    DomBuilder builder(root, text, file);
    Json::sax_parse(text, &builder);
    return root;
}

std::pair<std::size_t, std::size_t> line_and_column(const std::string& text, std::size_t offset) {
    offset = std::min(offset, text.size());
    std::size_t line = 1;
    std::size_t line_start = 0;
    for (std::size_t i = 0; i < offset; ++i) {
        if (text[i] == '\n') {
            ++line;
            line_start = i + 1;
        }
    }
    return {line, offset - line_start + 1};
}

std::string pointer_token(std::string_view key) {
    std::string token;
    token.reserve(key.size());
    for (const char c : key) {
        if (c == '~') {
            token += "~0";
        } else if (c == '/') {
            token += "~1";
        } else {
            token += c;
        }
    }
    return token;
}

std::string describe_json(const Json& value) {
    std::string out;
    describe_into(value, out, 0);
    // Containers stop listing elements near kMaxDescriptionLength; this cuts long strings.
    constexpr std::size_t kMaxLength = 2 * kMaxDescriptionLength;
    if (out.size() > kMaxLength) {
        std::size_t cut = kMaxLength - 3;
        // Never cut a UTF-8 sequence in half.
        while (cut > 0 && (static_cast<unsigned char>(out[cut]) & 0xC0u) == 0x80u) {
            --cut;
        }
        out.resize(cut);
        out += "...";
    }
    return out;
}

std::string join_names(std::vector<std::string> names) {
    std::sort(names.begin(), names.end());
    std::string out;
    for (std::size_t i = 0; i < names.size(); ++i) {
        if (i == kMaxListedNames) {
            out += fmt::format(", ... ({} more)", names.size() - i);
            break;
        }
        out += (i == 0 ? "" : ", ") + names[i];
    }
    return out;
}

bool NumberRange::contains(double x) const {
    const bool low_ok = low_open ? x > low : x >= low;
    const bool high_ok = high_open ? x < high : x <= high;
    return low_ok && high_ok;
}

std::string NumberRange::describe() const {
    const bool has_low = std::isfinite(low);
    const bool has_high = std::isfinite(high);
    if (has_low && has_high) {
        return fmt::format("a number in {}{}, {}{}", low_open ? '(' : '[', low, high,
                           high_open ? ')' : ']');
    }
    if (has_low) {
        return fmt::format("a number {} {}", low_open ? ">" : ">=", low);
    }
    if (has_high) {
        return fmt::format("a number {} {}", high_open ? "<" : "<=", high);
    }
    return "a number";
}

void JsonValue::fail(const std::string& message) const {
    throw Error(*m_file, m_pointer, message);
}

void JsonValue::fail_expected(std::string_view expected) const {
    fail(fmt::format("found {}, expected {}", describe_json(*m_value), expected));
}

JsonValue JsonValue::child(const Json& value, std::string_view token) const {
    return JsonValue(*m_file, value, m_pointer + "/" + std::string(token));
}

float JsonValue::number(const NumberRange& range) const {
    return static_cast<float>(double_number(range));
}

double JsonValue::double_number(const NumberRange& range) const {
    if (!m_value->is_number()) {
        fail_expected(range.describe());
    }
    const double x = m_value->get<double>();
    if (!std::isfinite(x) || std::abs(x) > static_cast<double>(std::numeric_limits<float>::max())) {
        fail_expected(kFiniteNumber);
    }
    if (!range.contains(x)) {
        fail_expected(range.describe());
    }
    return x;
}

float JsonValue::nonzero_number() const {
    const float x = number();
    if (x == 0.0f) {
        fail_expected("a non-zero number");
    }
    return x;
}

int JsonValue::integer(int low, int high) const {
    const std::string expected = fmt::format("an integer in [{}, {}]", low, high);
    if (!m_value->is_number_integer()) {
        fail_expected(expected);
    }
    if (m_value->is_number_unsigned()) {
        const auto x = m_value->get<Json::number_unsigned_t>();
        if (x > static_cast<Json::number_unsigned_t>(high)) {
            fail_expected(expected);
        }
    }
    const auto x = m_value->get<Json::number_integer_t>();
    if (x < low || x > high) {
        fail_expected(expected);
    }
    return static_cast<int>(x);
}

bool JsonValue::boolean() const {
    if (!m_value->is_boolean()) {
        fail_expected("true or false");
    }
    return m_value->get<bool>();
}

std::string JsonValue::string() const {
    if (!m_value->is_string()) {
        fail_expected("a string");
    }
    return m_value->get<std::string>();
}

std::string JsonValue::choice(const std::vector<std::string>& choices) const {
    const std::string expected = "one of: " + join_names(choices);
    if (!m_value->is_string()) {
        fail_expected(expected);
    }
    const auto& s = m_value->get_ref<const Json::string_t&>();
    if (std::find(choices.begin(), choices.end(), s) == choices.end()) {
        fail_expected(expected);
    }
    return s;
}

float JsonValue::number_element(const Json& element, std::size_t index,
                                const NumberRange& range) const {
    return child(element, std::to_string(index)).number(range);
}

std::vector<float> JsonValue::numbers(std::size_t count, std::string_view expected) const {
    if (!m_value->is_array() || m_value->size() != count) {
        fail_expected(expected);
    }
    std::vector<float> result;
    result.reserve(count);
    for (std::size_t i = 0; i < count; ++i) {
        result.push_back(number_element((*m_value)[i], i, NumberRange::any()));
    }
    return result;
}

Vec2f JsonValue::vec2(const NumberRange& range) const {
    if (!m_value->is_array() || m_value->size() != 2) {
        fail_expected("an array of 2 numbers");
    }
    return {number_element((*m_value)[0], 0, range), number_element((*m_value)[1], 1, range)};
}

Vec3f JsonValue::vec3(const NumberRange& range) const {
    if (!m_value->is_array() || m_value->size() != 3) {
        fail_expected("an array of 3 numbers");
    }
    return {number_element((*m_value)[0], 0, range), number_element((*m_value)[1], 1, range),
            number_element((*m_value)[2], 2, range)};
}

Vec3f JsonValue::nonzero_vec3() const {
    const Vec3f v = vec3();
    // The square of a tiny but non-zero vector may underflow; any non-zero component suffices.
    if (v == Vec3f::Zero()) {
        fail_expected("a non-zero vector");
    }
    return v;
}

Vec2f JsonValue::vec2_or_number(const NumberRange& range) const {
    if (m_value->is_number()) {
        const float x = number(range);
        return {x, x};
    }
    if (!m_value->is_array() || m_value->size() != 2) {
        fail_expected("an array of 2 numbers or a number");
    }
    return vec2(range);
}

Rgb JsonValue::colour() const {
    const NumberRange non_negative = NumberRange::at_least(0.0);
    if (m_value->is_number()) {
        const float x = number(non_negative);
        return {x, x, x};
    }
    if (!m_value->is_array() || m_value->size() != 3) {
        fail_expected("an array of 3 numbers or a number");
    }
    return vec3(non_negative).array();
}

std::vector<JsonValue> JsonValue::elements(std::string_view expected) const {
    if (!m_value->is_array()) {
        fail_expected(expected);
    }
    std::vector<JsonValue> result;
    result.reserve(m_value->size());
    for (std::size_t i = 0; i < m_value->size(); ++i) {
        result.push_back(child((*m_value)[i], std::to_string(i)));
    }
    return result;
}

std::vector<std::pair<std::string, JsonValue>> JsonValue::members(std::string_view expected) const {
    if (!m_value->is_object()) {
        fail_expected(expected);
    }
    std::vector<std::pair<std::string, JsonValue>> result;
    result.reserve(m_value->size());
    for (auto it = m_value->begin(); it != m_value->end(); ++it) {
        result.emplace_back(it.key(), child(it.value(), pointer_token(it.key())));
    }
    return result;
}

std::optional<JsonValue> JsonValue::find(std::string_view key) const {
    if (!m_value->is_object()) {
        fail_expected("an object");
    }
    const auto it = m_value->find(key);
    if (it == m_value->end()) {
        return std::nullopt;
    }
    return child(*it, pointer_token(key));
}

JsonObject::JsonObject(const JsonValue& value, std::vector<std::string> allowed_keys)
    : m_value(value) {
    for (const auto& [key, member] : value.members()) {
        if (std::find(allowed_keys.begin(), allowed_keys.end(), key) == allowed_keys.end()) {
            member.fail("unknown key (expected one of: " + join_names(allowed_keys) + ")");
        }
    }
}

std::optional<JsonValue> JsonObject::optional(std::string_view key) const {
    return m_value.find(key);
}

JsonValue JsonObject::required(std::string_view key) const {
    auto member = m_value.find(key);
    if (!member) {
        m_value.fail(fmt::format("missing required key \"{}\"", key));
    }
    return *member;
}

}  // namespace mrt
