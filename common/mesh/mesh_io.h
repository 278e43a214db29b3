#pragma once
// Loading mesh files through OpenMesh (OBJ, PLY, OFF, STL). OpenMesh is included only in
// openmesh_import.cpp.

#include "common/mesh/mesh.h"

#include <filesystem>

namespace mrt {

struct MeshLoadResult {
    Mesh mesh;
    std::size_t degenerate_triangles_removed = 0;  ///< Zero-area triangles dropped.
    bool normals_from_file = false;                ///< Vertex normals came from the file.
};

/// Loads a mesh file; every triangle gets material `material`. Polygons are triangulated.
/// Vertex normals are used when the file has them, computed otherwise; UVs kept when present
/// (vertices are split where a vertex has different UVs in different faces).
/// Throws mrt::Error naming the file for: missing/unreadable file, unknown extension, no
/// triangles, NaN/Inf coordinates, out-of-range indices.
MeshLoadResult load_mesh(const std::filesystem::path& file, std::uint32_t material);

/// Whether load_mesh reads `file`, by its extension (.obj, .ply, .off, .stl, any case).
bool is_mesh_file(const std::filesystem::path& file);

}  // namespace mrt
