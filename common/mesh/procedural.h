#pragma once
// Procedural geometry for scenes the project generates itself.

#include "common/mesh/mesh.h"

#include <cstdint>

namespace mrt {

/// UV sphere centred at the origin: `segments` around the equator (≥ 3) and `rings` from pole to
/// pole (≥ 2); exact unit-sphere normals scaled by nothing; UVs (longitude, latitude) in [0,1].
Mesh make_sphere(float radius, int segments, int rings, std::uint32_t material);

/// Unit-normal quad in the XZ plane centred at the origin, size_x × size_z, facing +Y, UVs [0,1]².
Mesh make_quad(float size_x, float size_z, std::uint32_t material);

/// Checkerboard made of geometry in the XZ plane centred at the origin, facing +Y:
/// tiles_x × tiles_z square-ish tiles, each two triangles, materials alternating between
/// `material_a` (tile (0,0)) and `material_b`. UVs span [0,1]² over the whole board. Shared tile
/// corners are shared vertices (watertight).
Mesh make_checkerboard(float size_x, float size_z, int tiles_x, int tiles_z,
                       std::uint32_t material_a, std::uint32_t material_b);

/// Largest `depth` make_plant accepts; each level triples the branches, (3^(depth+1) − 1)/2 in all.
constexpr int kMaxPlantDepth = 8;
/// Largest `leaves_per_branch` make_plant accepts.
constexpr int kMaxPlantLeavesPerBranch = 1000;

/// A plant: a closed, tapering stem (rings shared by its 4 segments, capped at both ends: 60
/// triangles) that branches `depth` times, with leaves (curved, normal-interpolated blades of 8
/// triangles) along every branch, all of it deterministic in `seed`. About 1 unit tall, rooted at
/// the origin, growing along +Y. Many small, thin, differently oriented triangles: the hard case
/// for point sampling. Materials: `stem` for the branches, `leaf` for the leaves; uvs along and
/// across each part. Throws Error unless depth ∈ [0, kMaxPlantDepth] and leaves_per_branch ∈ [0,
/// kMaxPlantLeavesPerBranch].
Mesh make_plant(std::uint64_t seed, int depth, int leaves_per_branch, std::uint32_t stem,
                std::uint32_t leaf);

// Triangle counts of the shapes above, from their parameters alone, so that a scene's request is
// weighed against its budget before anything is generated. Saturating: a count too large for
// 64 bits comes out as the largest uint64. Parameters below the generators' minimums count as
// them (the generators refuse those anyway).
std::uint64_t sphere_triangle_count(int segments, int rings);
std::uint64_t checkerboard_triangle_count(int tiles_x, int tiles_z);
std::uint64_t plant_triangle_count(int depth, int leaves_per_branch);

}  // namespace mrt
