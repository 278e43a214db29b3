#pragma once
// What the mesh loader's four format scans share, for mrt_mesh's own files only (load_mesh in
// mesh_io.h is the interface). A scan reads a file's raw bytes before OpenMesh does and refuses,
// with a line or element number, what OpenMesh's readers would silently get wrong; each format's
// file (obj_scan.cpp, ply_scan.cpp, off_scan.cpp, stl_scan.cpp) says what that is for its format.
// Here: the format an extension names, the text and byte reading every scan needs, and what each
// scan reports.

#include "common/math/math.h"
#include "common/mesh/mesh_io.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mrt::mesh_io {

enum class Format { obj, ply, off, stl };

inline constexpr std::string_view kSupportedExtensions = ".obj, .ply, .off, .stl";

/// The whole file as bytes; throws mrt::Error naming it when it cannot be opened or read.
std::string read_whole_file(const std::filesystem::path& file);

/// The format a file's extension names (case-insensitive), or none.
std::optional<Format> format_from_extension(const std::filesystem::path& file);

/// "OBJ", "PLY", "OFF" or "STL", for messages.
std::string_view format_name(Format format);

/// "No texture coordinates" and "no normal" (NaN, so that no file value compares equal).
inline const Vec2f kNoUv = Vec2f::Constant(std::numeric_limits<float>::quiet_NaN());
inline const Vec3f kNoNormal = Vec3f::Constant(std::numeric_limits<float>::quiet_NaN());

// ------------------------------------------------------------------------------------------
// Text scanning helpers.

inline bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

std::string_view trim(std::string_view s);

void split_tokens(std::string_view line, std::vector<std::string_view>& tokens);

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
std::optional<double> parse_real(std::string_view token);

std::optional<long long> parse_integer(std::string_view token);

/// True when the value survives conversion to float as a finite number (the readers parse
/// floats, so 1e39 is as unusable as inf).
inline bool finite_as_float(double v) {
    return std::isfinite(v) &&
           std::abs(v) <= static_cast<double>(std::numeric_limits<float>::max());
}

std::string format_number(double v);

inline std::uint32_t load_little_endian_u32(const char* p) {
    unsigned char b[4];
    std::memcpy(b, p, 4);
    return static_cast<std::uint32_t>(b[0]) | static_cast<std::uint32_t>(b[1]) << 8 |
           static_cast<std::uint32_t>(b[2]) << 16 | static_cast<std::uint32_t>(b[3]) << 24;
}

// ------------------------------------------------------------------------------------------
// The scans. Each throws mrt::Error naming the file and the place for what it refuses.

/// OBJ (obj_scan.cpp): the face structure and the vt/vn tables, which OpenMesh gets wrong.
struct ObjCorner {
    std::uint32_t vertex = 0;
    std::optional<std::uint32_t> texcoord;
    std::optional<std::uint32_t> normal;
};

struct ObjScan {
    std::size_t vertex_count = 0;
    std::vector<MeshFileName> libraries;      ///< `mtllib` files in order, as written.
    std::vector<MeshFileName> material_uses;  ///< Distinct `usemtl` names, in order of first use.
    /// Per face (empty when the file has no `usemtl`): index into material_uses or kNoMaterialUse.
    std::vector<std::uint32_t> face_materials;
    std::vector<Vec2f> texcoords;
    std::vector<Vec3f> normals;  ///< Non-finite entries stay non-finite and are recomputed.
    std::vector<ObjCorner> corners;
    std::vector<std::size_t> face_starts{0};  ///< Face f owns corners [starts[f], starts[f+1]).
    std::size_t fan_triangles = 0;            ///< Triangles the faces describe, repeats and all.
};

ObjScan scan_obj(const std::filesystem::path& file, std::string_view text);

/// PLY (ply_scan.cpp): header and whole body checked; counts as declared.
struct PlyScan {
    std::size_t vertex_count = 0;
    std::size_t face_count = 0;
};

PlyScan scan_ply(const std::filesystem::path& file, std::string_view text);

/// OFF, ASCII or binary (off_scan.cpp): counts as declared.
struct OffScan {
    std::size_t vertex_count = 0;
    std::size_t face_count = 0;
};

OffScan scan_off(const std::filesystem::path& file, std::string_view text);

/// STL, ASCII or binary (stl_scan.cpp).
struct StlScan {
    std::size_t facet_count = 0;
};

StlScan scan_stl(const std::filesystem::path& file, std::string_view text);

/// What the format scan learned before OpenMesh runs.
struct ScanResult {
    std::optional<ObjScan> obj;
    std::optional<std::size_t> triangles;  ///< Fan triangles described, degenerate ones included.
    std::optional<std::size_t> vertices;   ///< Vertices declared or listed.
    std::optional<std::size_t> faces;      ///< Faces declared.
};

/// Runs the scan of `format` on the file's bytes.
ScanResult scan_file(const std::filesystem::path& file, Format format, std::string_view bytes);

}  // namespace mrt::mesh_io
