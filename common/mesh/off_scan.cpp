// OFF (ASCII). OpenMesh reads tokens with iostreams, like its PLY reader, and loops over the
// declared face count even after its stream has failed. The scan follows the same layout:
// header line, counts, one vertex per line (coordinates, then normals for NOFF, then whatever
// else the line holds), then faces as a count followed by that many indices.

#include "common/mesh/format_scan.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <bit>

namespace mrt::mesh_io {

namespace fs = std::filesystem;

namespace {

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

}  // namespace

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

}  // namespace mrt::mesh_io
