#pragma once
// Triangle meshes: indexed vertices with per-vertex normals and optional texture coordinates,
// and a material per triangle (so a checkerboard made of geometry is one mesh).

#include "common/math/math.h"

#include <array>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace mrt {

struct Mesh {
    std::string name;              ///< Where it came from (file name or procedural recipe).
    std::vector<Vec3f> positions;  ///< Object-space vertex positions.
    std::vector<Vec3f> normals;    ///< Unit vertex normals; same size as positions.
    std::vector<Vec2f> uvs;        ///< Texture coordinates per vertex, or empty.
    std::vector<std::array<std::uint32_t, 3>> triangles;  ///< Counter-clockwise vertex indices.
    std::vector<std::uint32_t> materials;  ///< Index into Scene::materials, one per triangle.

    bool has_uvs() const { return !uvs.empty(); }
    std::size_t triangle_count() const { return triangles.size(); }
    /// Axis-aligned bounds of the positions (min, max); empty mesh gives (+inf, −inf).
    Eigen::AlignedBox3f bounds() const;
};

/// Replaces the normals by angle-weighted averages of the incident face normals
/// (vertices of no non-degenerate face get (0, 0, 1)).
void compute_vertex_normals(Mesh& mesh);

/// Replaces the normals by angle-weighted averages of the normals of the faces around each
/// position (vertices at bitwise equal positions count as one: files split vertices at texture
/// seams and between patches, STL shares none, yet the surface is smooth there), leaving out
/// faces that meet a corner's own face at more than `crease_angle` (radians): a box keeps flat
/// walls. A vertex whose corners get different normals is split (position and uv copied).
/// Vertices v with given[v] keep their normal and are not split.
void compute_creased_normals(Mesh& mesh, double crease_angle, const std::vector<bool>& given = {});

/// Removes zero-area triangles (and those with repeated or non-finite vertices); returns how
/// many were removed.
std::size_t remove_degenerate_triangles(Mesh& mesh);

std::ostream& operator<<(std::ostream& os, const Mesh& m);

}  // namespace mrt
