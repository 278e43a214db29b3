#include "common/mesh/mesh_io.h"

#include "common/mesh/format_scan.h"
#include "common/mesh/openmesh_import.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

// How a file travels: the extension picks a format; a format-specific scan of the raw bytes
// checks what OpenMesh's readers would silently get wrong (non-numbers, out-of-range indices,
// truncation) and reports it with a line or element number; OpenMesh then parses the file into
// a plain polygon soup through our own importer (not a TriMesh, see SoupImporter); finally the
// soup becomes an indexed mrt::Mesh with one vertex per distinct (position, uv, normal) corner.
// The scans are obj_scan.cpp, ply_scan.cpp, off_scan.cpp and stl_scan.cpp; OpenMesh and the
// importer are in openmesh_import.cpp; here the file is read, the pieces run and the soup
// assembled.

namespace mrt {

namespace {

namespace fs = std::filesystem;

using mesh_io::Corner;
using mesh_io::Format;
using mesh_io::kNoNormal;
using mesh_io::kNoUv;
using mesh_io::ObjCorner;
using mesh_io::ObjScan;
using mesh_io::PolygonSoup;
using mesh_io::read_whole_file;
using mesh_io::ScanResult;

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
/// `face_tags` (one per soup face, or empty) become the triangles' materials, `material` otherwise.
std::size_t assemble(const PolygonSoup& soup, const std::vector<Corner>& corners, bool has_uvs,
                     std::uint32_t material, const std::vector<std::uint32_t>& face_tags,
                     Mesh& mesh, std::vector<Vec3f>& file_normals) {
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
            mesh.materials.push_back(face_tags.empty() ? material : face_tags[f]);
        }
    }
    if (has_uvs) {
        mesh.uvs.resize(uvs.size());
        for (std::size_t v = 0; v < uvs.size(); ++v) {
            // A corner without texture coordinates in a file that has them gets the origin.
            mesh.uvs[v] = all_finite(uvs[v]) ? uvs[v] : Vec2f::Zero();
        }
    }
    return mesh.triangles.size();
}

/// Gives OpenMesh's OBJ faces their corners' texture coordinates and normals from the scan.
/// OpenMesh's faces are the scan's faces with at least three distinct vertices, each with its
/// repeats removed; anything else means the two disagree about the file.
/// Returns, per soup face, the scan face it is.
std::vector<std::size_t> apply_obj_corners(const fs::path& file, const ObjScan& obj,
                                           const PolygonSoup& soup, std::vector<Corner>& corners) {
    std::vector<std::size_t> scan_faces_of_soup;
    scan_faces_of_soup.reserve(soup.face_total());
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
        scan_faces_of_soup.push_back(scan_face);
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
    return scan_faces_of_soup;
}

}  // namespace

MeshLoadResult load_mesh(const fs::path& file, std::uint32_t material, double crease_angle) {
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
    const std::optional<Format> format = mesh_io::format_from_extension(file);
    if (!format) {
        throw Error(file, "",
                    fmt::format("unknown mesh format '{}' (supported: {})",
                                file.extension().string(), mesh_io::kSupportedExtensions));
    }
    const std::string bytes = read_whole_file(file);
    if (mesh_io::trim(bytes).empty()) {
        throw Error(file, "", "file is empty");
    }

    const ScanResult scan = mesh_io::scan_file(file, *format, bytes);
    const PolygonSoup soup = mesh_io::read_with_openmesh(file, *format, scan, bytes.size());

    std::vector<Corner> corners = soup.corners;
    bool has_uvs = soup.has_uvs;
    bool has_normals = soup.has_normals;
    std::vector<std::uint32_t> face_tags;
    if (scan.obj) {
        const std::vector<std::size_t> scan_faces =
            apply_obj_corners(file, *scan.obj, soup, corners);
        if (!scan.obj->face_materials.empty()) {
            face_tags.reserve(scan_faces.size());
            for (const std::size_t f : scan_faces) {
                face_tags.push_back(scan.obj->face_materials[f]);
            }
        }
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
    const std::size_t produced =
        assemble(soup, corners, has_uvs, material, face_tags, mesh, file_normals);
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

    if (scan.obj) {
        result.material_libraries = scan.obj->libraries;
        result.material_uses = scan.obj->material_uses;
        if (!face_tags.empty()) {
            // The triangles carried their faces' material uses through the degenerate removal.
            result.triangle_material_uses = mesh.materials;
            mesh.materials.assign(mesh.triangles.size(), material);
        }
    }

    // The file's normals where it gives them; elsewhere smooth, except across creases.
    std::vector<bool> given(mesh.positions.size(), false);
    if (has_normals) {
        for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
            given[v] = usable_normal(file_normals[v]);
        }
    }
    compute_creased_normals(mesh, crease_angle, given);
    for (std::size_t v = 0; v < given.size(); ++v) {
        if (given[v]) {
            mesh.normals[v] = file_normals[v].normalized();
            result.normals_from_file = true;
        }
    }
    return result;
}

bool is_mesh_file(const std::filesystem::path& file) {
    return mesh_io::format_from_extension(file).has_value();
}

}  // namespace mrt
