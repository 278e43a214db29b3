// OBJ. OpenMesh's OBJ reader silently drops "v" lines it cannot parse (which shifts every later
// index), drops faces with fewer than three distinct vertices, and hands out per-corner texture
// coordinates only in a way that breaks for polygons. So the scan reads the face structure and
// the vt/vn tables itself; OpenMesh's vertices and faces are checked against it.

#include "common/mesh/format_scan.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <algorithm>

namespace mrt::mesh_io {

namespace fs = std::filesystem;

namespace {

/// `mtllib file...` adds libraries; `usemtl name` makes `material_use` the following faces'.
void read_material_statement(const fs::path& file, std::size_t line,
                             const std::vector<std::string_view>& tokens, ObjScan& scan,
                             std::uint32_t& material_use) {
    if (tokens.size() < 2 || tokens[1].front() == '#') {
        throw Error(file, fmt::format("line {}", line),
                    fmt::format("'{}' without a {}", tokens[0],
                                tokens[0] == "usemtl" ? "material name" : "library file"));
    }
    if (tokens[0] == "mtllib") {
        for (std::size_t i = 1; i < tokens.size() && tokens[i].front() != '#'; ++i) {
            scan.libraries.push_back({std::string(tokens[i]), line});
        }
        return;
    }
    const std::string name(tokens[1]);
    const auto it = std::find_if(scan.material_uses.begin(), scan.material_uses.end(),
                                 [&](const MeshFileName& use) { return use.name == name; });
    material_use = static_cast<std::uint32_t>(it - scan.material_uses.begin());
    if (it == scan.material_uses.end()) {
        scan.material_uses.push_back({name, line});
    }
}

}  // namespace

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
    std::uint32_t material_use = kNoMaterialUse;
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
        } else if (tokens[0] == "usemtl" || tokens[0] == "mtllib") {
            read_material_statement(file, face_lines.number(), tokens, scan, material_use);
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
        if (material_use != kNoMaterialUse || !scan.face_materials.empty()) {
            // The faces before the first usemtl had none.
            scan.face_materials.resize(scan.face_starts.size() - 2, kNoMaterialUse);
            scan.face_materials.push_back(material_use);
        }
        scan.fan_triangles += corner_count - 2;
    }
    return scan;
}

}  // namespace mrt::mesh_io
