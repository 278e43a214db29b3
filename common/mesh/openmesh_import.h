#pragma once
// OpenMesh's readers behind a plain interface: the one file that includes OpenMesh
// (openmesh_import.cpp) turns a mesh file into a polygon soup, every face as written.

#include "common/math/math.h"
#include "common/mesh/format_scan.h"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace mrt::mesh_io {

/// A polygon corner as the importer saw it; NaN attributes mean "none".
struct Corner {
    std::uint32_t vertex = 0;
    Vec2f uv = kNoUv;
    Vec3f normal = kNoNormal;
};

/// A file's polygons as OpenMesh's reader delivered them: vertices in file order, faces as
/// written (not triangulated, indices checked).
struct PolygonSoup {
    std::vector<Vec3f> positions;
    std::vector<Vec3f> vertex_normals;  ///< kNoNormal where the file gives none.
    std::vector<Vec2f> vertex_uvs;      ///< kNoUv where the file gives none.
    std::vector<Corner> corners;
    std::vector<std::size_t> face_starts{0};  ///< Face f owns corners [starts[f], starts[f+1]).
    bool has_normals = false;  ///< The reader delivered vertex normals and reports reading them.
    bool has_uvs = false;      ///< The same for texture coordinates.

    std::size_t face_total() const { return face_starts.size() - 1; }
};

/// Runs OpenMesh's reader of `format` on `file`, whose scan found `scan`; `file_size` (bytes)
/// bounds how many vertices and corners it may deliver. Throws mrt::Error naming the file when
/// the reader fails, disagrees with the scan's counts or delivers a non-finite position.
PolygonSoup read_with_openmesh(const std::filesystem::path& file, Format format,
                               const ScanResult& scan, std::size_t file_size);

}  // namespace mrt::mesh_io
