// PLY. OpenMesh's ASCII reader parses with iostreams, which fail on "nan" and then misread
// everything after it; its binary reader happily reads past the end of a truncated file. The
// scan walks the whole body once.

#include "common/mesh/format_scan.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <iterator>

namespace mrt::mesh_io {

namespace fs = std::filesystem;

namespace {

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

}  // namespace

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

}  // namespace mrt::mesh_io
