#include "common/mesh/mesh_io.h"

#include "common/system/error.h"
#include "common/math/position_weld.h"

#include <fmt/format.h>
#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

// How a file travels: the extension picks a format; a format-specific scan of the raw bytes
// checks what OpenMesh's readers would silently get wrong (non-numbers, out-of-range indices,
// truncation) and reports it with a line or element number; OpenMesh then parses the file into
// a plain polygon soup through our own importer (not a TriMesh, see SoupImporter); finally the
// soup becomes an indexed mrt::Mesh with one vertex per distinct (position, uv, normal) corner.

namespace mrt {

namespace {

namespace fs = std::filesystem;
namespace om = OpenMesh;

enum class Format { obj, ply, off, stl };

constexpr std::string_view kSupportedExtensions = ".obj, .ply, .off, .stl";

std::optional<Format> format_from_extension(const fs::path& file) {
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".obj") {
        return Format::obj;
    }
    if (ext == ".ply") {
        return Format::ply;
    }
    if (ext == ".off") {
        return Format::off;
    }
    if (ext == ".stl") {
        return Format::stl;
    }
    return std::nullopt;
}

std::string_view format_name(Format format) {
    switch (format) {
        case Format::obj:
            return "OBJ";
        case Format::ply:
            return "PLY";
        case Format::off:
            return "OFF";
        case Format::stl:
            return "STL";
    }
    return "mesh";
}

const Vec2f kNoUv = Vec2f::Constant(std::numeric_limits<float>::quiet_NaN());
const Vec3f kNoNormal = Vec3f::Constant(std::numeric_limits<float>::quiet_NaN());

// ------------------------------------------------------------------------------------------
// Text scanning helpers.

bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

std::string_view trim(std::string_view s) {
    while (!s.empty() && is_space(s.front())) {
        s.remove_prefix(1);
    }
    while (!s.empty() && is_space(s.back())) {
        s.remove_suffix(1);
    }
    return s;
}

void split_tokens(std::string_view line, std::vector<std::string_view>& tokens) {
    tokens.clear();
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && is_space(line[i])) {
            ++i;
        }
        const std::size_t start = i;
        while (i < line.size() && !is_space(line[i])) {
            ++i;
        }
        if (i > start) {
            tokens.push_back(line.substr(start, i - start));
        }
    }
}

/// Lines without their terminators, numbered from 1.
class LineCursor {
  public:
    explicit LineCursor(std::string_view text) : text_(text) {}

    bool next(std::string_view& line) {
        if (position_ >= text_.size()) {
            return false;
        }
        std::size_t end = text_.find('\n', position_);
        if (end == std::string_view::npos) {
            end = text_.size();
        }
        line = text_.substr(position_, end - position_);
        position_ = end == text_.size() ? end : end + 1;
        ++number_;
        return true;
    }
    std::size_t number() const { return number_; }
    std::size_t position() const { return position_; }

  private:
    std::string_view text_;
    std::size_t position_ = 0;
    std::size_t number_ = 0;
};

/// Whitespace-separated tokens across lines, remembering each token's line.
class TokenCursor {
  public:
    TokenCursor(std::string_view text, std::size_t first_line) : text_(text), line_(first_line) {}

    std::optional<std::string_view> next() {
        while (position_ < text_.size() && is_space(text_[position_])) {
            if (text_[position_] == '\n') {
                ++line_;
            }
            ++position_;
        }
        if (position_ >= text_.size()) {
            return std::nullopt;
        }
        const std::size_t start = position_;
        while (position_ < text_.size() && !is_space(text_[position_])) {
            ++position_;
        }
        return text_.substr(start, position_ - start);
    }
    /// Drops the rest of the current line (OpenMesh's readers ignore trailing extras).
    void skip_line() {
        while (position_ < text_.size() && text_[position_] != '\n') {
            ++position_;
        }
    }
    std::size_t line() const { return line_; }

  private:
    std::string_view text_;
    std::size_t position_ = 0;
    std::size_t line_;
};

/// A real number as text: the whole token must be a number ("nan" and "inf" included, so that
/// they can be reported rather than misread). Magnitudes beyond double range come back as ±inf.
std::optional<double> parse_real(std::string_view token) {
    if (!token.empty() && token.front() == '+') {
        token.remove_prefix(1);
    }
    if (token.empty()) {
        return std::nullopt;
    }
    double value = 0.0;
    const char* const end = token.data() + token.size();
    const auto [ptr, ec] = std::from_chars(token.data(), end, value);
    if (ptr != end) {
        return std::nullopt;
    }
    if (ec == std::errc::result_out_of_range) {
        // from_chars leaves the value alone on overflow and underflow alike; the exponent's sign
        // tells them apart.
        const std::size_t e = token.find_first_of("eE");
        const bool underflow =
            e != std::string_view::npos && e + 1 < token.size() && token[e + 1] == '-';
        const bool negative = token.front() == '-';
        if (underflow) {
            return negative ? -0.0 : 0.0;
        }
        return negative ? -std::numeric_limits<double>::infinity()
                        : std::numeric_limits<double>::infinity();
    }
    if (ec != std::errc()) {
        return std::nullopt;
    }
    return value;
}

std::optional<long long> parse_integer(std::string_view token) {
    if (!token.empty() && token.front() == '+') {
        token.remove_prefix(1);
    }
    long long value = 0;
    const char* const end = token.data() + token.size();
    const auto [ptr, ec] = std::from_chars(token.data(), end, value);
    if (token.empty() || ptr != end || ec != std::errc()) {
        return std::nullopt;
    }
    return value;
}

/// True when the value survives conversion to float as a finite number (the readers parse
/// floats, so 1e39 is as unusable as inf).
bool finite_as_float(double v) {
    return std::isfinite(v) &&
           std::abs(v) <= static_cast<double>(std::numeric_limits<float>::max());
}

std::string format_number(double v) {
    return fmt::format("{}", v);
}

std::uint32_t load_little_endian_u32(const char* p) {
    unsigned char b[4];
    std::memcpy(b, p, 4);
    return static_cast<std::uint32_t>(b[0]) | static_cast<std::uint32_t>(b[1]) << 8 |
           static_cast<std::uint32_t>(b[2]) << 16 | static_cast<std::uint32_t>(b[3]) << 24;
}

// ------------------------------------------------------------------------------------------
// OBJ. OpenMesh's OBJ reader silently drops "v" lines it cannot parse (which shifts every later
// index), drops faces with fewer than three distinct vertices, and hands out per-corner texture
// coordinates only in a way that breaks for polygons. So the scan reads the face structure and
// the vt/vn tables itself; OpenMesh's vertices and faces are checked against it.

struct ObjCorner {
    std::uint32_t vertex = 0;
    std::optional<std::uint32_t> texcoord;
    std::optional<std::uint32_t> normal;
};

struct ObjScan {
    std::size_t vertex_count = 0;
    std::vector<Vec2f> texcoords;
    std::vector<Vec3f> normals;  ///< Non-finite entries stay non-finite and are recomputed.
    std::vector<ObjCorner> corners;
    std::vector<std::size_t> face_starts{0};  ///< Face f owns corners [starts[f], starts[f+1]).
    std::size_t fan_triangles = 0;            ///< Triangles the faces describe, repeats and all.
};

ObjScan scan_obj(const fs::path& file, std::string_view text) {
    ObjScan scan;
    std::vector<std::string_view> tokens;
    std::string_view raw;

    // Pass 1: the vertex tables, because faces may refer forwards.
    LineCursor lines(text);
    while (lines.next(raw)) {
        split_tokens(trim(raw), tokens);
        if (tokens.empty() || tokens[0].front() == '#') {
            continue;
        }
        const auto location = [&lines] { return fmt::format("line {}", lines.number()); };
        const auto numbers = [&](std::size_t count) {
            std::vector<double> values;
            for (std::size_t i = 1; i <= count && i < tokens.size(); ++i) {
                const std::optional<double> v = parse_real(tokens[i]);
                if (!v) {
                    break;
                }
                values.push_back(*v);
            }
            return values;
        };
        if (tokens[0] == "v") {
            ++scan.vertex_count;
            const std::vector<double> p = numbers(3);
            if (p.size() < 3) {
                throw Error(file, location(),
                            fmt::format("vertex {} does not have three numeric coordinates",
                                        scan.vertex_count));
            }
            if (!finite_as_float(p[0]) || !finite_as_float(p[1]) || !finite_as_float(p[2])) {
                throw Error(file, location(),
                            fmt::format("vertex {} has a non-finite coordinate ({} {} {})",
                                        scan.vertex_count, format_number(p[0]), format_number(p[1]),
                                        format_number(p[2])));
            }
        } else if (tokens[0] == "vt") {
            const std::vector<double> t = numbers(2);
            if (t.size() < 2 || !finite_as_float(t[0]) || !finite_as_float(t[1])) {
                throw Error(file, location(),
                            fmt::format("texture coordinate {} is not a pair of finite numbers",
                                        scan.texcoords.size() + 1));
            }
            scan.texcoords.emplace_back(static_cast<float>(t[0]), static_cast<float>(t[1]));
        } else if (tokens[0] == "vn") {
            const std::vector<double> n = numbers(3);
            if (n.size() < 3) {
                throw Error(file, location(),
                            fmt::format("normal {} does not have three numeric components",
                                        scan.normals.size() + 1));
            }
            const bool finite =
                finite_as_float(n[0]) && finite_as_float(n[1]) && finite_as_float(n[2]);
            scan.normals.push_back(finite
                                       ? Vec3f(static_cast<float>(n[0]), static_cast<float>(n[1]),
                                               static_cast<float>(n[2]))
                                       : kNoNormal);
        }
    }

    // Pass 2: faces. Negative indices count back from the entries read so far.
    LineCursor face_lines(text);
    std::size_t seen_vertices = 0;
    std::size_t seen_texcoords = 0;
    std::size_t seen_normals = 0;
    while (face_lines.next(raw)) {
        split_tokens(trim(raw), tokens);
        if (tokens.empty()) {
            continue;
        }
        if (tokens[0] == "v") {
            ++seen_vertices;
        } else if (tokens[0] == "vt") {
            ++seen_texcoords;
        } else if (tokens[0] == "vn") {
            ++seen_normals;
        }
        if (tokens[0] != "f") {
            continue;
        }
        const auto location = [&face_lines] { return fmt::format("line {}", face_lines.number()); };
        const auto resolve = [&](std::string_view part, std::size_t seen, std::size_t total,
                                 const char* what, const char* plural) -> std::uint32_t {
            const std::optional<long long> index = parse_integer(part);
            if (!index || *index == 0) {
                throw Error(file, location(),
                            fmt::format("malformed {} index '{}' in a face", what, part));
            }
            const long long resolved =
                *index > 0 ? *index : static_cast<long long>(seen) + *index + 1;
            if (resolved < 1 || resolved > static_cast<long long>(total)) {
                throw Error(file, location(),
                            fmt::format("face refers to {} {} but the file has {} {}", what, *index,
                                        total, total == 1 ? what : plural));
            }
            return static_cast<std::uint32_t>(resolved - 1);
        };
        std::size_t corner_count = 0;
        for (std::size_t i = 1; i < tokens.size(); ++i) {
            if (tokens[i].front() == '#') {
                break;
            }
            std::string_view parts[3];
            std::size_t part_count = 0;
            std::string_view rest = tokens[i];
            while (true) {
                const std::size_t slash = rest.find('/');
                if (part_count == 3) {
                    throw Error(file, location(),
                                fmt::format("malformed face corner '{}'", tokens[i]));
                }
                parts[part_count++] = rest.substr(0, slash);
                if (slash == std::string_view::npos) {
                    break;
                }
                rest.remove_prefix(slash + 1);
            }
            ObjCorner corner;
            corner.vertex =
                resolve(parts[0], seen_vertices, scan.vertex_count, "vertex", "vertices");
            if (part_count > 1 && !parts[1].empty()) {
                corner.texcoord = resolve(parts[1], seen_texcoords, scan.texcoords.size(),
                                          "texture coordinate", "texture coordinates");
            }
            if (part_count > 2 && !parts[2].empty()) {
                corner.normal =
                    resolve(parts[2], seen_normals, scan.normals.size(), "normal", "normals");
            }
            scan.corners.push_back(corner);
            ++corner_count;
        }
        // Refused like any other malformed line: a face line of one or two corners is a
        // mistake (OBJ's lines are 'l'), and OpenMesh would drop it without a word.
        if (corner_count < 3) {
            throw Error(file, location(),
                        fmt::format("face has {} corner{}, expected at least three", corner_count,
                                    corner_count == 1 ? "" : "s"));
        }
        scan.face_starts.push_back(scan.corners.size());
        scan.fan_triangles += corner_count - 2;
    }
    return scan;
}

// ------------------------------------------------------------------------------------------
// PLY. OpenMesh's ASCII reader parses with iostreams, which fail on "nan" and then misread
// everything after it; its binary reader happily reads past the end of a truncated file. The
// scan walks the whole body once.

enum class PlyEncoding { ascii, binary_little_endian, binary_big_endian };

struct PlyProperty {
    std::string name;
    std::string type;        ///< Value type.
    std::string count_type;  ///< Non-empty for list properties.
};

struct PlyElement {
    std::string name;
    std::size_t count = 0;
    std::vector<PlyProperty> properties;
};

struct PlyHeader {
    PlyEncoding encoding = PlyEncoding::ascii;
    std::vector<PlyElement> elements;
    std::size_t body_offset = 0;
    std::size_t body_first_line = 0;
};

/// Bytes of a PLY scalar type, or 0 for an unknown type name.
std::size_t ply_type_size(std::string_view type) {
    if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") {
        return 1;
    }
    if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") {
        return 2;
    }
    if (type == "int" || type == "uint" || type == "int32" || type == "uint32" || type == "float" ||
        type == "float32") {
        return 4;
    }
    if (type == "double" || type == "float64") {
        return 8;
    }
    return 0;
}

bool ply_type_is_real(std::string_view type) {
    return type == "float" || type == "float32" || type == "double" || type == "float64";
}

bool is_ply_list_of_vertex_indices(const PlyElement& element, const PlyProperty& property) {
    return element.name == "face" &&
           (property.name == "vertex_indices" || property.name == "vertex_index");
}

/// Refuses headers OpenMesh's PLY reader would misread: it skips any list other than a face's
/// vertex indices as if it were a single value, converts coordinates only from floating-point
/// types and indices only from integer types, and needs x, y and z.
void check_ply_header_for_openmesh(const fs::path& file, const PlyHeader& header) {
    static constexpr std::string_view kRealVertexProperties[] = {"x",  "y", "z", "nx", "ny",
                                                                 "nz", "u", "v", "s",  "t"};
    bool has_coordinate[3] = {false, false, false};
    for (const PlyElement& element : header.elements) {
        for (const PlyProperty& property : element.properties) {
            const std::string where =
                fmt::format("property '{}' of element '{}'", property.name, element.name);
            if (!property.count_type.empty()) {
                if (!is_ply_list_of_vertex_indices(element, property)) {
                    throw Error(file, "",
                                fmt::format("{} is a list, which OpenMesh cannot read (only a "
                                            "face's vertex_indices may be a list)",
                                            where));
                }
                if (ply_type_is_real(property.type)) {
                    throw Error(file, "", fmt::format("{} must have an integer type", where));
                }
                continue;
            }
            if (element.name != "vertex") {
                continue;
            }
            const auto* const real = std::find(std::begin(kRealVertexProperties),
                                               std::end(kRealVertexProperties), property.name);
            if (real != std::end(kRealVertexProperties) && !ply_type_is_real(property.type)) {
                throw Error(file, "", fmt::format("{} must be float or double", where));
            }
            for (int axis = 0; axis < 3; ++axis) {
                has_coordinate[axis] |= property.name == kRealVertexProperties[axis];
            }
        }
    }
    if (!(has_coordinate[0] && has_coordinate[1] && has_coordinate[2])) {
        throw Error(file, "", "the PLY header declares no vertex x, y and z properties");
    }
}

PlyHeader parse_ply_header(const fs::path& file, std::string_view text) {
    PlyHeader header;
    LineCursor lines(text);
    std::string_view raw;
    std::vector<std::string_view> tokens;
    if (!lines.next(raw) || (trim(raw) != "ply" && trim(raw) != "PLY")) {
        throw Error(file, "", "not a PLY file (it does not start with 'ply')");
    }
    // OpenMesh reads the header as a stream of words. It loops forever once a word fails to
    // parse (a version or a count that is not a number, a missing end_header), so those are
    // refused here; and it finds the binary body by counting 12 bytes from the end of the last
    // word it read before "end_header", which must therefore be where the body really starts.
    std::size_t openmesh_word_end = lines.position();
    bool have_format = false;
    while (true) {
        const std::size_t line_start = lines.position();
        if (!lines.next(raw)) {
            throw Error(file, "", "PLY header has no 'end_header' line");
        }
        const auto location = [&lines] { return fmt::format("line {}", lines.number()); };
        split_tokens(trim(raw), tokens);
        if (tokens.empty()) {
            continue;
        }
        const std::string_view keyword = tokens[0];
        if (lines.number() == 2 && keyword != "format") {
            // OpenMesh takes the second word of the header as the format, whatever it says.
            throw Error(file, location(), "the PLY header's second line must be its 'format' line");
        }
        if (keyword == "end_header") {
            break;
        }
        const std::size_t content_end = line_start + raw.find_last_not_of(" \t\r\n\v\f") + 1;
        openmesh_word_end = keyword == "comment" ? lines.position() : content_end;
        if (keyword == "comment" || keyword == "obj_info") {
            continue;
        }
        if (keyword == "format") {
            if (tokens.size() != 3 || !parse_real(tokens[2]) ||
                !finite_as_float(*parse_real(tokens[2]))) {
                throw Error(file, location(),
                            "expected 'format <ascii|binary_little_endian|binary_big_endian> "
                            "<version>'");
            }
            if (tokens[1] == "ascii") {
                header.encoding = PlyEncoding::ascii;
            } else if (tokens[1] == "binary_little_endian") {
                header.encoding = PlyEncoding::binary_little_endian;
            } else if (tokens[1] == "binary_big_endian") {
                header.encoding = PlyEncoding::binary_big_endian;
            } else {
                throw Error(file, location(), fmt::format("unknown PLY format '{}'", tokens[1]));
            }
            have_format = true;
        } else if (keyword == "element" && tokens.size() == 3) {
            const std::optional<long long> count = parse_integer(tokens[2]);
            if (!count || *count < 0 || *count > std::numeric_limits<std::uint32_t>::max()) {
                throw Error(file, location(),
                            fmt::format("bad element count '{}' in PLY header", tokens[2]));
            }
            header.elements.push_back(
                {std::string(tokens[1]), static_cast<std::size_t>(*count), {}});
        } else if (keyword == "property" && !header.elements.empty() &&
                   ((tokens.size() == 3 && ply_type_size(tokens[1]) != 0) ||
                    (tokens.size() == 5 && tokens[1] == "list" && ply_type_size(tokens[2]) != 0 &&
                     ply_type_size(tokens[3]) != 0))) {
            PlyProperty property;
            if (tokens.size() == 3) {
                property = {std::string(tokens[2]), std::string(tokens[1]), ""};
            } else {
                property = {std::string(tokens[4]), std::string(tokens[3]), std::string(tokens[2])};
            }
            header.elements.back().properties.push_back(std::move(property));
        } else {
            throw Error(file, location(),
                        fmt::format("unsupported PLY header line '{}'", trim(raw)));
        }
    }
    if (!have_format) {
        throw Error(file, "", "PLY header has no 'format' line");
    }
    header.body_offset = lines.position();
    header.body_first_line = lines.number() + 1;
    const bool crlf = text.substr(openmesh_word_end, 2) == "\r\n";
    if (header.encoding != PlyEncoding::ascii &&
        openmesh_word_end + (crlf ? 14 : 12) != header.body_offset) {
        throw Error(file, fmt::format("line {}", lines.number()),
                    "OpenMesh can only find the binary data when 'end_header' directly follows "
                    "a non-comment header line (no blank line, trailing spaces or comment before "
                    "it)");
    }
    check_ply_header_for_openmesh(file, header);
    return header;
}

/// Reads the values of a PLY body in order, whichever encoding.
class PlyValues {
  public:
    PlyValues(const fs::path& file, std::string_view body, const PlyHeader& header)
        : file_(file),
          body_(body),
          encoding_(header.encoding),
          tokens_(body, header.body_first_line) {}

    /// The next value as a double; `what` names it, for error messages only.
    template <typename Name>
    double next(std::string_view type, const Name& what) {
        if (encoding_ == PlyEncoding::ascii) {
            const std::optional<std::string_view> token = tokens_.next();
            if (!token) {
                throw Error(file_, "", fmt::format("file ends before {}", what()));
            }
            std::optional<double> value;
            if (ply_type_is_real(type)) {
                value = parse_real(*token);
            } else if (const std::optional<long long> integer = parse_integer(*token)) {
                value = static_cast<double>(*integer);
            }
            if (!value) {
                throw Error(file_, location(),
                            fmt::format("'{}' is not a valid {} for {}", *token, type, what()));
            }
            return *value;
        }
        const std::size_t size = ply_type_size(type);
        if (body_.size() - offset_ < size) {
            throw Error(file_, "", fmt::format("file is truncated: it ends before {}", what()));
        }
        unsigned char bytes[8] = {};
        std::memcpy(bytes, body_.data() + offset_, size);
        offset_ += size;
        const bool file_is_little = encoding_ == PlyEncoding::binary_little_endian;
        if (file_is_little != (std::endian::native == std::endian::little)) {
            std::reverse(bytes, bytes + size);
        }
        return decode(type, bytes);
    }

    bool is_ascii() const { return encoding_ == PlyEncoding::ascii; }
    std::string location() const {
        return is_ascii() ? fmt::format("line {}", tokens_.line()) : "";
    }

  private:
    static double decode(std::string_view type, const unsigned char* bytes) {
        const auto load = [bytes]<typename T>(T) {
            T value;
            std::memcpy(&value, bytes, sizeof(T));
            return static_cast<double>(value);
        };
        if (type == "char" || type == "int8") {
            return load(std::int8_t{});
        }
        if (type == "uchar" || type == "uint8") {
            return load(std::uint8_t{});
        }
        if (type == "short" || type == "int16") {
            return load(std::int16_t{});
        }
        if (type == "ushort" || type == "uint16") {
            return load(std::uint16_t{});
        }
        if (type == "int" || type == "int32") {
            return load(std::int32_t{});
        }
        if (type == "uint" || type == "uint32") {
            return load(std::uint32_t{});
        }
        if (type == "float" || type == "float32") {
            return load(float{});
        }
        return load(double{});
    }

    const fs::path& file_;
    std::string_view body_;
    PlyEncoding encoding_;
    TokenCursor tokens_;
    std::size_t offset_ = 0;
};

struct PlyScan {
    std::size_t vertex_count = 0;
    std::size_t face_count = 0;
};

PlyScan scan_ply(const fs::path& file, std::string_view text) {
    const PlyHeader header = parse_ply_header(file, text);
    PlyValues values(file, text.substr(header.body_offset), header);
    PlyScan scan;
    for (const PlyElement& element : header.elements) {
        if (element.name == "vertex") {
            scan.vertex_count = element.count;
        } else if (element.name == "face") {
            scan.face_count = element.count;
        }
    }
    for (const PlyElement& element : header.elements) {
        const bool is_vertex = element.name == "vertex";
        const bool is_face = element.name == "face";
        for (std::size_t item = 0; item < element.count; ++item) {
            for (const PlyProperty& property : element.properties) {
                const auto what = [&] {
                    return fmt::format("{} {}'s '{}'", element.name, item, property.name);
                };
                if (property.count_type.empty()) {
                    const double v = values.next(property.type, what);
                    const bool coordinate =
                        property.name == "x" || property.name == "y" || property.name == "z";
                    if (is_vertex && coordinate && !finite_as_float(v)) {
                        throw Error(file, values.location(),
                                    fmt::format("vertex {} has a non-finite coordinate ({} = {})",
                                                item, property.name, format_number(v)));
                    }
                    if (ply_type_is_real(property.type) && !finite_as_float(v) &&
                        values.is_ascii()) {
                        // iostreams cannot parse it, so OpenMesh would misread the rest.
                        throw Error(file, values.location(),
                                    fmt::format("{} is not a finite number", what()));
                    }
                    continue;
                }
                const double count =
                    values.next(property.count_type, [&] { return what() + " count"; });
                if (count < 0.0) {
                    throw Error(file, values.location(),
                                fmt::format("{} has a negative list length", what()));
                }
                const bool indices = is_face && (property.name == "vertex_indices" ||
                                                 property.name == "vertex_index");
                for (double i = 0.0; i < count; i += 1.0) {
                    const double v = values.next(property.type, what);
                    if (indices && (v < 0.0 || v >= static_cast<double>(scan.vertex_count))) {
                        throw Error(file, values.location(),
                                    fmt::format("face {} refers to vertex {} but the file has "
                                                "{} vertices",
                                                item, format_number(v), scan.vertex_count));
                    }
                }
            }
        }
    }
    return scan;
}

// ------------------------------------------------------------------------------------------
// OFF (ASCII). OpenMesh reads tokens with iostreams, like its PLY reader, and loops over the
// declared face count even after its stream has failed. The scan follows the same layout:
// header line, counts, one vertex per line (coordinates, then normals for NOFF, then whatever
// else the line holds), then faces as a count followed by that many indices.

struct OffScan {
    std::size_t vertex_count = 0;
    std::size_t face_count = 0;
};

/// Binary OFF as OpenMesh reads it: little-endian counts, then per vertex 3 floats, 3 more for
/// NOFF and 2 more for STOFF, then per face a count and that many indices.
OffScan scan_binary_off(const fs::path& file, std::string_view body, bool has_normals,
                        bool has_texcoords) {
    OffScan scan;
    std::size_t offset = 0;
    const auto next_u32 = [&](const auto& what) {
        if (body.size() - offset < 4) {
            throw Error(file, "", fmt::format("file is truncated: it ends before {}", what()));
        }
        const std::uint32_t value = load_little_endian_u32(body.data() + offset);
        offset += 4;
        return value;
    };
    scan.vertex_count = next_u32([] { return std::string("the vertex count"); });
    scan.face_count = next_u32([] { return std::string("the face count"); });
    next_u32([] { return std::string("the edge count"); });
    const std::size_t vertex_bytes = 12 + (has_normals ? 12 : 0) + (has_texcoords ? 8 : 0);
    for (std::size_t v = 0; v < scan.vertex_count; ++v) {
        float p[3];
        for (float& c : p) {
            c = std::bit_cast<float>(next_u32([v] { return fmt::format("vertex {}", v); }));
        }
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
            throw Error(file, "",
                        fmt::format("vertex {} has a non-finite coordinate ({} {} {})", v, p[0],
                                    p[1], p[2]));
        }
        for (std::size_t skipped = 12; skipped < vertex_bytes; skipped += 4) {
            next_u32([v] { return fmt::format("vertex {}", v); });
        }
    }
    for (std::size_t f = 0; f < scan.face_count; ++f) {
        const auto what = [f] { return fmt::format("face {}", f); };
        const std::uint32_t corners = next_u32(what);
        for (std::uint32_t c = 0; c < corners; ++c) {
            const std::uint32_t index = next_u32(what);
            if (index >= scan.vertex_count) {
                throw Error(file, "",
                            fmt::format("face {} refers to vertex {} but the file has {} vertices",
                                        f, index, scan.vertex_count));
            }
        }
    }
    return scan;
}

OffScan scan_off(const fs::path& file, std::string_view text) {
    LineCursor lines(text);
    std::string_view first;
    lines.next(first);
    // OpenMesh's header: [ST][C][N]OFF at the very start of the line, optionally followed by one
    // separator and BINARY.
    std::string_view keyword = first;
    const auto take = [&keyword](std::string_view part) {
        if (keyword.substr(0, part.size()) != part) {
            return false;
        }
        keyword.remove_prefix(part.size());
        return true;
    };
    const bool has_texcoords = take("ST");
    const bool has_colors = take("C");
    const bool has_normals = take("N");
    if (keyword.substr(0, 1) == "4" || keyword.substr(0, 1) == "n") {
        throw Error(
            file, "line 1",
            fmt::format("'{}' files (other than 3D vertices) are not supported", trim(first)));
    }
    if (!take("OFF")) {
        throw Error(file, "line 1",
                    "not an OFF file (the first line does not start with [ST][C][N]OFF)");
    }
    if (keyword.size() >= 7 && is_space(keyword[0]) && keyword.substr(1, 6) == "BINARY") {
        if (has_colors) {
            throw Error(file, "line 1", "binary OFF files with colors are not supported");
        }
        return scan_binary_off(file, text.substr(lines.position()), has_normals, has_texcoords);
    }
    if (!trim(keyword).empty()) {
        throw Error(file, "line 1", fmt::format("unsupported OFF header '{}'", trim(first)));
    }
    OffScan scan;
    TokenCursor tokens(text.substr(lines.position()), 2);
    // `what` names the expected value; it is a function so that names are only formatted for
    // error messages.
    const auto next_token = [&](const auto& what) {
        const std::optional<std::string_view> token = tokens.next();
        if (!token) {
            throw Error(file, "", fmt::format("file ends before {}", what()));
        }
        return *token;
    };
    const auto next_count = [&](const auto& what) {
        const std::string_view token = next_token(what);
        const std::optional<long long> value = parse_integer(token);
        if (!value || *value < 0) {
            throw Error(file, fmt::format("line {}", tokens.line()),
                        fmt::format("expected {} but found '{}'", what(), token));
        }
        return static_cast<std::size_t>(*value);
    };
    scan.vertex_count = next_count([] { return std::string("the vertex count"); });
    scan.face_count = next_count([] { return std::string("the face count"); });
    next_count([] { return std::string("the edge count"); });

    for (std::size_t v = 0; v < scan.vertex_count; ++v) {
        double p[3];
        for (double& c : p) {
            const std::string_view token = next_token([v] { return fmt::format("vertex {}", v); });
            const std::optional<double> value = parse_real(token);
            if (!value) {
                throw Error(file, fmt::format("line {}", tokens.line()),
                            fmt::format("vertex {}: '{}' is not a number", v, token));
            }
            c = *value;
        }
        if (!finite_as_float(p[0]) || !finite_as_float(p[1]) || !finite_as_float(p[2])) {
            throw Error(file, fmt::format("line {}", tokens.line()),
                        fmt::format("vertex {} has a non-finite coordinate ({} {} {})", v,
                                    format_number(p[0]), format_number(p[1]), format_number(p[2])));
        }
        if (has_normals) {
            for (int i = 0; i < 3; ++i) {
                const std::string_view token =
                    next_token([v] { return fmt::format("vertex {}'s normal", v); });
                const std::optional<double> value = parse_real(token);
                if (!value || !finite_as_float(*value)) {
                    throw Error(
                        file, fmt::format("line {}", tokens.line()),
                        fmt::format("vertex {}'s normal: '{}' is not a finite number", v, token));
                }
            }
        }
        tokens.skip_line();
    }
    for (std::size_t f = 0; f < scan.face_count; ++f) {
        const std::size_t corners =
            next_count([f] { return fmt::format("the corner count of face {}", f); });
        for (std::size_t c = 0; c < corners; ++c) {
            const std::string_view token = next_token([f] { return fmt::format("face {}", f); });
            const std::optional<long long> index = parse_integer(token);
            if (!index || *index < 0 || *index >= static_cast<long long>(scan.vertex_count)) {
                throw Error(file, fmt::format("line {}", tokens.line()),
                            fmt::format("face {} refers to vertex '{}' but the file has {} "
                                        "vertices",
                                        f, token, scan.vertex_count));
            }
        }
        if (has_colors) {
            tokens.skip_line();
        }
    }
    return scan;
}

// ------------------------------------------------------------------------------------------
// STL. OpenMesh welds the three corners of every facet by exact position, which is what makes
// the result indexed; it treats a file as binary when its size matches the facet count in the
// header. The scan checks every corner coordinate, naming the facet.

struct StlScan {
    std::size_t facet_count = 0;
};

StlScan scan_stl(const fs::path& file, std::string_view text) {
    StlScan scan;
    if (text.size() >= 84) {
        const std::uint32_t count = load_little_endian_u32(text.data() + 80);
        if (84 + 50 * static_cast<std::uint64_t>(count) == text.size()) {
            scan.facet_count = count;
            for (std::size_t f = 0; f < count; ++f) {
                for (std::size_t c = 0; c < 9; ++c) {
                    const float v = std::bit_cast<float>(
                        load_little_endian_u32(text.data() + 84 + 50 * f + 12 + 4 * c));
                    if (!std::isfinite(v)) {
                        throw Error(file, fmt::format("facet {}", f),
                                    fmt::format("corner {} has a non-finite coordinate", c / 3));
                    }
                }
            }
            return scan;
        }
    }
    TokenCursor tokens(text, 1);
    const std::optional<std::string_view> first = tokens.next();
    if (!first || *first != "solid") {
        throw Error(file, "",
                    "not an STL file (neither a binary STL of matching size nor ASCII starting "
                    "with 'solid')");
    }
    while (const std::optional<std::string_view> token = tokens.next()) {
        if (*token == "facet") {
            ++scan.facet_count;
        } else if (*token == "vertex") {
            for (int i = 0; i < 3; ++i) {
                const std::optional<std::string_view> number = tokens.next();
                const std::optional<double> value =
                    number ? parse_real(*number) : std::optional<double>();
                if (!value || !finite_as_float(*value)) {
                    throw Error(file, fmt::format("line {}", tokens.line()),
                                fmt::format("facet {}: '{}' is not a finite coordinate",
                                            scan.facet_count == 0 ? 0 : scan.facet_count - 1,
                                            number.value_or("")));
                }
            }
        }
    }
    return scan;
}

// ------------------------------------------------------------------------------------------
// OpenMesh side.

/// A polygon corner as the importer saw it; NaN attributes mean "none".
struct Corner {
    std::uint32_t vertex = 0;
    Vec2f uv = kNoUv;
    Vec3f normal = kNoNormal;
};

/// Collects what OpenMesh's readers deliver as a plain polygon soup. A TriMesh would be the
/// obvious target, but its importer silently drops faces with invalid or repeated indices,
/// duplicates vertices around non-manifold edges (tearing smooth normals apart), and assigns
/// per-corner texture coordinates of polygons to the wrong halfedges once it has triangulated
/// them. Here every face arrives as written, and bad indices are recorded, not skipped.
class SoupImporter final : public om::IO::BaseImporter {
  public:
    /// `capacity` bounds how many vertices and corners a file of that many bytes can hold, so
    /// that a reader looping on a lying header cannot exhaust memory.
    explicit SoupImporter(std::size_t capacity) : capacity_(capacity) {}

    std::vector<Vec3f> positions;
    std::vector<Vec3f> vertex_normals;
    std::vector<Vec2f> vertex_uvs;
    std::vector<Corner> corners;
    std::vector<std::size_t> face_starts{0};
    bool got_normals = false;
    bool got_uvs = false;
    std::optional<std::pair<std::string, std::string>> error;  ///< First (location, message).

    std::size_t face_total() const { return face_starts.size() - 1; }

    om::VertexHandle add_vertex(const om::Vec3f& p) override {
        return append_vertex(Vec3f(p[0], p[1], p[2]));
    }
    om::VertexHandle add_vertex(const om::Vec3d& p) override {
        const auto to_float = [](double v) {
            return finite_as_float(v) ? static_cast<float>(v)
                                      : std::numeric_limits<float>::infinity();
        };
        return append_vertex(Vec3f(to_float(p[0]), to_float(p[1]), to_float(p[2])));
    }
    om::VertexHandle add_vertex() override { return append_vertex(Vec3f::Zero()); }

    void set_point(om::VertexHandle vh, const om::Vec3f& p) override {
        if (valid(vh)) {
            positions[static_cast<std::size_t>(vh.idx())] = Vec3f(p[0], p[1], p[2]);
        }
    }

    om::FaceHandle add_face(const VHandles& indices) override {
        const om::FaceHandle refused;
        const std::size_t face = face_total();
        if (error) {
            return refused;
        }
        for (const om::VertexHandle vh : indices) {
            if (!valid(vh)) {
                record_error(fmt::format("face {}", face),
                             fmt::format("refers to vertex {} but the file has {} vertices",
                                         vh.idx(), positions.size()));
                return refused;
            }
        }
        if (face_total() >= capacity_ || corners.size() + indices.size() > capacity_) {
            record_error("", "more face corners than the file's size allows (corrupt header?)");
            return refused;
        }
        for (const om::VertexHandle vh : indices) {
            const auto v = static_cast<std::size_t>(vh.idx());
            corners.push_back({static_cast<std::uint32_t>(v), vertex_uvs[v], vertex_normals[v]});
        }
        face_starts.push_back(corners.size());
        return om::FaceHandle(static_cast<int>(face));
    }

    void set_normal(om::VertexHandle vh, const om::Vec3f& n) override {
        if (valid(vh)) {
            vertex_normals[static_cast<std::size_t>(vh.idx())] = Vec3f(n[0], n[1], n[2]);
            got_normals = true;
        }
    }
    void set_normal(om::VertexHandle vh, const om::Vec3d& n) override {
        set_normal(vh, om::Vec3f(static_cast<float>(n[0]), static_cast<float>(n[1]),
                                 static_cast<float>(n[2])));
    }
    void set_texcoord(om::VertexHandle vh, const om::Vec2f& t) override {
        if (valid(vh)) {
            vertex_uvs[static_cast<std::size_t>(vh.idx())] = Vec2f(t[0], t[1]);
            got_uvs = true;
        }
    }

    std::size_t n_vertices() const override { return positions.size(); }
    std::size_t n_faces() const override { return face_total(); }
    std::size_t n_edges() const override { return 0; }

    // Everything below carries information a triangle soup for rendering does not use (colors,
    // status flags, face normals, material names) or belongs to OpenMesh's own .om format, which
    // writes connectivity directly.
    om::HalfedgeHandle add_edge(om::VertexHandle, om::VertexHandle) override {
        return om::HalfedgeHandle();
    }
    om::FaceHandle add_face(om::HalfedgeHandle) override { return om::FaceHandle(); }
    void add_face_texcoords(om::FaceHandle, om::VertexHandle,
                            const std::vector<om::Vec2f>&) override {}
    void add_face_texcoords(om::FaceHandle, om::VertexHandle,
                            const std::vector<om::Vec3f>&) override {}
    void set_face_texindex(om::FaceHandle, int) override {}
    void set_halfedge(om::VertexHandle, om::HalfedgeHandle) override {}
    void set_color(om::VertexHandle, const om::Vec3uc&) override {}
    void set_color(om::VertexHandle, const om::Vec4uc&) override {}
    void set_color(om::VertexHandle, const om::Vec3f&) override {}
    void set_color(om::VertexHandle, const om::Vec4f&) override {}
    void set_status(om::VertexHandle, const om::Attributes::StatusInfo&) override {}
    void set_next(om::HalfedgeHandle, om::HalfedgeHandle) override {}
    void set_face(om::HalfedgeHandle, om::FaceHandle) override {}
    void request_face_texcoords2D() override {}
    void set_texcoord(om::HalfedgeHandle, const om::Vec2f&) override {}
    void set_texcoord(om::VertexHandle, const om::Vec3f&) override {}
    void set_texcoord(om::HalfedgeHandle, const om::Vec3f&) override {}
    void set_status(om::HalfedgeHandle, const om::Attributes::StatusInfo&) override {}
    void set_color(om::EdgeHandle, const om::Vec3uc&) override {}
    void set_color(om::EdgeHandle, const om::Vec4uc&) override {}
    void set_color(om::EdgeHandle, const om::Vec3f&) override {}
    void set_color(om::EdgeHandle, const om::Vec4f&) override {}
    void set_status(om::EdgeHandle, const om::Attributes::StatusInfo&) override {}
    void set_normal(om::FaceHandle, const om::Vec3f&) override {}
    void set_normal(om::FaceHandle, const om::Vec3d&) override {}
    void set_color(om::FaceHandle, const om::Vec3uc&) override {}
    void set_color(om::FaceHandle, const om::Vec4uc&) override {}
    void set_color(om::FaceHandle, const om::Vec3f&) override {}
    void set_color(om::FaceHandle, const om::Vec4f&) override {}
    void set_status(om::FaceHandle, const om::Attributes::StatusInfo&) override {}
    void add_texture_information(int, std::string) override {}

  private:
    om::VertexHandle append_vertex(const Vec3f& p) {
        if (positions.size() >= capacity_) {
            record_error("", "more vertices than the file's size allows (corrupt header?)");
            return om::VertexHandle();
        }
        positions.push_back(p);
        vertex_normals.push_back(kNoNormal);
        vertex_uvs.push_back(kNoUv);
        return om::VertexHandle(static_cast<int>(positions.size() - 1));
    }
    bool valid(om::VertexHandle vh) const {
        return vh.idx() >= 0 && static_cast<std::size_t>(vh.idx()) < positions.size();
    }
    void record_error(std::string location, std::string message) {
        if (!error) {
            error.emplace(std::move(location), std::move(message));
        }
    }

    std::size_t capacity_;
};

std::mutex& openmesh_mutex() {
    static std::mutex mutex;
    return mutex;
}

/// OpenMesh's omerr/omlog/omout default to cerr/clog/cout; their multi-line chatter must not
/// reach the user, but can explain a failure. Their stream buffer is replaced, once for the whole
/// program (OpenMesh is used nowhere else), by this one, which each read clears and inspects
/// under openmesh_mutex(). (mostream::disconnect would leak the target wrapper it allocated.)
std::stringbuf& openmesh_log() {
    // Never destroyed, so that OpenMesh's own static streams may outlive it safely.
    static std::stringbuf* const log = [] {
        auto* const buffer = new std::stringbuf;
        for (om::mostream* const stream : {&omerr(), &omlog(), &omout()}) {
            stream->flush();
            stream->rdbuf(buffer);
        }
        return buffer;
    }();
    return *log;
}

/// The first non-empty line of `log`.
std::string first_line(const std::stringbuf& log) {
    std::istringstream lines(log.str());
    std::string line;
    while (std::getline(lines, line)) {
        const std::string_view t = trim(line);
        if (!t.empty()) {
            return std::string(t);
        }
    }
    return {};
}

// ------------------------------------------------------------------------------------------
// Assembly.

bool same_bits(const Vec2f& a, const Vec2f& b) {
    return std::bit_cast<std::uint32_t>(a.x()) == std::bit_cast<std::uint32_t>(b.x()) &&
           std::bit_cast<std::uint32_t>(a.y()) == std::bit_cast<std::uint32_t>(b.y());
}

bool same_bits(const Vec3f& a, const Vec3f& b) {
    return std::bit_cast<std::uint32_t>(a.x()) == std::bit_cast<std::uint32_t>(b.x()) &&
           std::bit_cast<std::uint32_t>(a.y()) == std::bit_cast<std::uint32_t>(b.y()) &&
           std::bit_cast<std::uint32_t>(a.z()) == std::bit_cast<std::uint32_t>(b.z());
}

bool usable_normal(const Vec3f& n) {
    // Squared norms below ~1e-30 lose their direction to float rounding when normalised.
    return all_finite(n) && n.squaredNorm() > 1e-30f;
}

/// Turns the soup into an indexed mesh: the first corner to use a file vertex keeps its index,
/// corners with other (uv, normal) values get one appended vertex per distinct combination.
/// Returns the number of fan triangles produced.
std::size_t assemble(const SoupImporter& soup, const std::vector<Corner>& corners, bool has_uvs,
                     std::uint32_t material, Mesh& mesh, std::vector<Vec3f>& file_normals) {
    const std::size_t file_vertices = soup.positions.size();
    mesh.positions = soup.positions;
    file_normals = soup.vertex_normals;
    std::vector<Vec2f> uvs = soup.vertex_uvs;
    std::vector<bool> claimed(file_vertices, false);
    // Extra variants of a file vertex, searched linearly: seams give each vertex only a few.
    std::vector<std::vector<std::uint32_t>> variants(file_vertices);

    const auto output_vertex = [&](const Corner& c) -> std::uint32_t {
        if (!claimed[c.vertex]) {
            claimed[c.vertex] = true;
            uvs[c.vertex] = c.uv;
            file_normals[c.vertex] = c.normal;
            return c.vertex;
        }
        const auto matches = [&](std::uint32_t v) {
            return same_bits(uvs[v], c.uv) && same_bits(file_normals[v], c.normal);
        };
        if (matches(c.vertex)) {
            return c.vertex;
        }
        for (const std::uint32_t v : variants[c.vertex]) {
            if (matches(v)) {
                return v;
            }
        }
        const auto v = static_cast<std::uint32_t>(mesh.positions.size());
        mesh.positions.push_back(soup.positions[c.vertex]);
        uvs.push_back(c.uv);
        file_normals.push_back(c.normal);
        variants[c.vertex].push_back(v);
        return v;
    };

    std::vector<std::uint32_t> polygon;
    for (std::size_t f = 0; f + 1 < soup.face_starts.size(); ++f) {
        polygon.clear();
        for (std::size_t i = soup.face_starts[f]; i < soup.face_starts[f + 1]; ++i) {
            polygon.push_back(output_vertex(corners[i]));
        }
        for (std::size_t i = 1; i + 1 < polygon.size(); ++i) {
            mesh.triangles.push_back({polygon[0], polygon[i], polygon[i + 1]});
        }
    }
    mesh.materials.assign(mesh.triangles.size(), material);
    if (has_uvs) {
        mesh.uvs.resize(uvs.size());
        for (std::size_t v = 0; v < uvs.size(); ++v) {
            // A corner without texture coordinates in a file that has them gets the origin.
            mesh.uvs[v] = all_finite(uvs[v]) ? uvs[v] : Vec2f::Zero();
        }
    }
    return mesh.triangles.size();
}

/// Vertex normals computed as if vertices at the same position were one: files split vertices
/// for texture seams (spot.obj) or between surface patches (teapot.obj), and STL has no sharing
/// at all, yet the surface is smooth across those splits. Hard edges need normals in the file.
void compute_welded_normals(Mesh& mesh) {
    std::vector<std::uint32_t> representative;
    const std::vector<std::uint32_t> welded_index = weld_positions(
        mesh.positions.size(), [&](std::size_t v) { return mesh.positions[v]; }, representative);
    Mesh welded;
    welded.positions.reserve(representative.size());
    for (const std::uint32_t v : representative) {
        welded.positions.push_back(mesh.positions[v] + Vec3f::Zero());
    }
    welded.triangles.reserve(mesh.triangles.size());
    for (const auto& t : mesh.triangles) {
        welded.triangles.push_back({welded_index[t[0]], welded_index[t[1]], welded_index[t[2]]});
    }
    compute_vertex_normals(welded);
    mesh.normals.resize(mesh.positions.size());
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        mesh.normals[v] = welded.normals[welded_index[v]];
    }
}

std::string read_whole_file(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) {
        throw Error(file, "", fmt::format("cannot be opened: {}", std::strerror(errno)));
    }
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) {
        throw Error(file, "", fmt::format("cannot be read: {}", std::strerror(errno)));
    }
    return bytes;
}

/// What the format scan learned before OpenMesh runs.
struct ScanResult {
    std::optional<ObjScan> obj;
    std::optional<std::size_t> triangles;  ///< Fan triangles described, degenerate ones included.
    std::optional<std::size_t> vertices;   ///< Vertices declared or listed.
    std::optional<std::size_t> faces;      ///< Faces declared.
};

ScanResult scan_file(const fs::path& file, Format format, std::string_view bytes) {
    ScanResult scan;
    switch (format) {
        case Format::obj:
            scan.obj = scan_obj(file, bytes);
            scan.triangles = scan.obj->fan_triangles;
            scan.vertices = scan.obj->vertex_count;
            break;
        case Format::ply: {
            const PlyScan ply = scan_ply(file, bytes);
            scan.vertices = ply.vertex_count;
            scan.faces = ply.face_count;
            break;
        }
        case Format::off: {
            const OffScan off = scan_off(file, bytes);
            scan.vertices = off.vertex_count;
            scan.faces = off.face_count;
            break;
        }
        case Format::stl:
            scan.triangles = scan_stl(file, bytes).facet_count;
            break;
    }
    return scan;
}

/// Runs OpenMesh's reader for `file` into `soup`; returns the options it reports having read.
om::IO::Options read_with_openmesh(const fs::path& file, Format format, const ScanResult& scan,
                                   SoupImporter& soup) {
    // OBJ attributes come from the scan (see ObjScan), so OpenMesh need not read them.
    om::IO::Options options;
    if (format != Format::obj) {
        options += om::IO::Options::VertexNormal;
        options += om::IO::Options::VertexTexCoord;
    }
    bool read_ok = false;
    std::string diagnostics;
    {
        // OpenMesh's readers are global singletons with per-read state, and its log streams
        // are global too.
        const std::lock_guard lock(openmesh_mutex());
        std::stringbuf& log = openmesh_log();
        log.str("");
        read_ok = om::IO::IOManager().read(file.string(), soup, options);
        diagnostics = first_line(log);
        log.str("");
    }
    const std::string explanation = diagnostics.empty() ? "" : " (OpenMesh: " + diagnostics + ")";
    if (soup.error) {
        throw Error(file, soup.error->first, soup.error->second);
    }
    if (!read_ok) {
        throw Error(file, "",
                    fmt::format("not a readable {} file{}", format_name(format), explanation));
    }
    if (scan.vertices && soup.positions.size() != *scan.vertices) {
        throw Error(file, "",
                    fmt::format("OpenMesh read {} of the {} vertices in the file{}",
                                soup.positions.size(), *scan.vertices, explanation));
    }
    if (scan.faces && soup.face_total() != *scan.faces) {
        throw Error(file, "",
                    fmt::format("OpenMesh read {} of the {} faces in the file{}", soup.face_total(),
                                *scan.faces, explanation));
    }
    for (std::size_t v = 0; v < soup.positions.size(); ++v) {
        const Vec3f& p = soup.positions[v];
        if (!all_finite(p)) {
            throw Error(file, "",
                        fmt::format("vertex {} has a non-finite coordinate ({} {} {})", v, p.x(),
                                    p.y(), p.z()));
        }
    }
    return options;
}

/// Gives OpenMesh's OBJ faces their corners' texture coordinates and normals from the scan.
/// OpenMesh's faces are the scan's faces with at least three distinct vertices, each with its
/// repeats removed; anything else means the two disagree about the file.
void apply_obj_corners(const fs::path& file, const ObjScan& obj, const SoupImporter& soup,
                       std::vector<Corner>& corners) {
    const std::size_t scan_faces = obj.face_starts.size() - 1;
    const auto distinct = [&obj](std::size_t f) {
        std::vector<std::uint32_t> vertices;
        for (std::size_t i = obj.face_starts[f]; i < obj.face_starts[f + 1]; ++i) {
            if (std::find(vertices.begin(), vertices.end(), obj.corners[i].vertex) ==
                vertices.end()) {
                vertices.push_back(obj.corners[i].vertex);
            }
        }
        return vertices;
    };
    std::size_t scan_face = 0;
    for (std::size_t f = 0; f < soup.face_total(); ++f) {
        std::vector<std::uint32_t> expected;
        while (scan_face < scan_faces && (expected = distinct(scan_face)).size() < 3) {
            ++scan_face;
        }
        const std::size_t first = soup.face_starts[f];
        const std::size_t count = soup.face_starts[f + 1] - first;
        if (scan_face == scan_faces || expected.size() != count ||
            !std::equal(expected.begin(), expected.end(), soup.corners.begin() + first,
                        [](std::uint32_t v, const Corner& c) { return v == c.vertex; })) {
            throw Error(
                file, "",
                fmt::format("OpenMesh's reading of face {} disagrees with the file", f + 1));
        }
        for (std::size_t i = 0; i < count; ++i) {
            Corner& corner = corners[first + i];
            // The first corner naming this vertex decides its attributes.
            for (std::size_t j = obj.face_starts[scan_face]; j < obj.face_starts[scan_face + 1];
                 ++j) {
                const ObjCorner& source = obj.corners[j];
                if (source.vertex != corner.vertex) {
                    continue;
                }
                if (source.texcoord) {
                    corner.uv = obj.texcoords[*source.texcoord];
                }
                if (source.normal) {
                    corner.normal = obj.normals[*source.normal];
                }
                break;
            }
        }
        ++scan_face;
    }
}

}  // namespace

MeshLoadResult load_mesh(const fs::path& file, std::uint32_t material) {
    std::error_code ec;
    const fs::file_status status = fs::status(file, ec);
    if (!fs::exists(status)) {
        if (ec && ec != std::errc::no_such_file_or_directory) {
            throw Error(file, "", fmt::format("cannot be accessed: {}", ec.message()));
        }
        throw Error(file, "", "file not found");
    }
    if (fs::is_directory(status)) {
        throw Error(file, "", "is a directory, not a mesh file");
    }
    const std::optional<Format> format = format_from_extension(file);
    if (!format) {
        throw Error(file, "",
                    fmt::format("unknown mesh format '{}' (supported: {})",
                                file.extension().string(), kSupportedExtensions));
    }
    const std::string bytes = read_whole_file(file);
    if (trim(bytes).empty()) {
        throw Error(file, "", "file is empty");
    }

    const ScanResult scan = scan_file(file, *format, bytes);
    SoupImporter soup(bytes.size());
    const om::IO::Options options = read_with_openmesh(file, *format, scan, soup);

    std::vector<Corner> corners = soup.corners;
    bool has_uvs = soup.got_uvs && options.vertex_has_texcoord();
    bool has_normals = soup.got_normals && options.vertex_has_normal();
    if (scan.obj) {
        apply_obj_corners(file, *scan.obj, soup, corners);
        const auto& obj_corners = scan.obj->corners;
        has_uvs = std::any_of(obj_corners.begin(), obj_corners.end(),
                              [](const ObjCorner& c) { return c.texcoord.has_value(); });
        has_normals = std::any_of(obj_corners.begin(), obj_corners.end(),
                                  [](const ObjCorner& c) { return c.normal.has_value(); });
    }
    for (Corner& c : corners) {
        // Unusable normals all become the same "none", so they do not split vertices.
        if (!has_normals || !usable_normal(c.normal)) {
            c.normal = kNoNormal;
        }
        if (!has_uvs) {
            c.uv = kNoUv;
        }
    }

    MeshLoadResult result;
    Mesh& mesh = result.mesh;
    mesh.name = file.filename().string();
    std::vector<Vec3f> file_normals;
    const std::size_t produced = assemble(soup, corners, has_uvs, material, mesh, file_normals);
    if (produced == 0 && scan.triangles.value_or(0) == 0) {
        throw Error(file, "",
                    mesh.positions.empty()
                        ? std::string("contains no triangles (no vertices or faces found)")
                        : fmt::format("contains no triangles ({} vertices, no faces)",
                                      mesh.positions.size()));
    }
    // OpenMesh's OBJ and STL readers drop faces with repeated vertices before we see them.
    const std::size_t dropped_by_reader =
        scan.triangles && *scan.triangles > produced ? *scan.triangles - produced : 0;
    result.degenerate_triangles_removed = dropped_by_reader + remove_degenerate_triangles(mesh);
    if (mesh.triangles.empty()) {
        throw Error(file, "",
                    fmt::format("contains no triangles with non-zero area (all {} are degenerate)",
                                result.degenerate_triangles_removed));
    }

    compute_welded_normals(mesh);
    if (has_normals) {
        for (std::size_t v = 0; v < mesh.normals.size(); ++v) {
            if (usable_normal(file_normals[v])) {
                mesh.normals[v] = file_normals[v].normalized();
                result.normals_from_file = true;
            }
        }
    }
    return result;
}

}  // namespace mrt
