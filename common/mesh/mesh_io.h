#pragma once
// Loading mesh files through OpenMesh (OBJ, PLY, OFF, STL). OpenMesh is included only in
// openmesh_import.cpp.

#include "common/mesh/mesh.h"

#include <filesystem>
#include <string>
#include <vector>

namespace mrt {

/// A name an OBJ file gives with its line: a material library (`mtllib`) or a material
/// (`usemtl`).
struct MeshFileName {
    std::string name;
    std::size_t line = 0;
};

/// The crease angle that smooths across every edge (a scan's ridges as much as a box's corners).
inline constexpr double kSmoothEverywhere = 3.14159265358979323846;

/// A triangle's material use when its face had no `usemtl` before it.
inline constexpr std::uint32_t kNoMaterialUse = 0xffffffffu;

struct MeshLoadResult {
    Mesh mesh;
    /// OBJ only: the `mtllib` files as written (relative to the mesh file's directory), the
    /// distinct `usemtl` names in order of first use, and per triangle the index of its face's
    /// name there or kNoMaterialUse (empty when the file has no `usemtl`). The mesh's own
    /// materials are all the `material` given to load_mesh; the scene loader replaces them.
    std::vector<MeshFileName> material_libraries;
    std::vector<MeshFileName> material_uses;
    std::vector<std::uint32_t> triangle_material_uses;
    std::size_t degenerate_triangles_removed = 0;  ///< Zero-area triangles dropped.
    bool normals_from_file = false;                ///< Vertex normals came from the file.
};

/// Loads a mesh file; every triangle gets material `material`. Polygons are triangulated.
/// Vertex normals are used when the file has them, computed otherwise; UVs kept when present
/// (vertices are split where a vertex has different UVs in different faces).
/// Throws mrt::Error naming the file for: missing/unreadable file, unknown extension, no
/// triangles, NaN/Inf coordinates, out-of-range indices.
/// Where the file gives no normals, faces meeting at more than `crease_angle` (radians) are not
/// smoothed across (compute_creased_normals); the default, π, smooths across every edge.
MeshLoadResult load_mesh(const std::filesystem::path& file, std::uint32_t material,
                         double crease_angle = kSmoothEverywhere);

/// Whether load_mesh reads `file`, by its extension (.obj, .ply, .off, .stl, any case).
bool is_mesh_file(const std::filesystem::path& file);

}  // namespace mrt
