#pragma once
// The multi-resolution point hierarchy of Wand & Straßer §3, in memory and unquantized: an
// octree built top-down over a triangle mesh. Each node lays a k³ grid over its cube and draws
// area-uniform samples on the triangles it received; a triangle whose samples fall into more
// than `max_representatives` voxels is large at this resolution and stays in the node as a
// triangle; the others are represented by one point at the centre of every voxel their samples
// reach, and go on down to the children. So a node's points stand for exactly the triangles
// below it (no surface counted twice) and the leaves end with the original triangles.
//
// Point attributes are prefiltered: `oversampling` samples per voxel face of area are averaged
// with a Gaussian of one voxel side (σ, cut at 2.5σ) around each point —
// materials, textures (the texture at each sample's uv, so a point's colour is the texture
// averaged over its Gaussian), normals, and the normal gradient fitted to the samples' normals
// (preprocess/octree/normal_gradient.h).

#include "common/math/math.h"
#include "common/mesh/mesh.h"
#include "common/scene/scene.h"
#include "common/system/budgets.h"
#include "preprocess/octree/triangle_sampling.h"

#include <array>
#include <cstdint>
#include <vector>

namespace mrt {

class BuildBudget;
class Progress;
class TextureSampler;

struct PointOctreeOptions {
    int grid = 16;                ///< k: voxels per cube side at every node.
    int max_representatives = 3;  ///< A triangle with more stays in the node as a triangle.
    /// Prefiltering samples per voxel face of surface area (the paper's c over a minimum
    /// density of one per voxel face; representatives are chosen from 4 per voxel face).
    int oversampling = 100;
    /// How the prefiltering samples are placed. The representatives are always chosen from the
    /// low-discrepancy points, and so far the instance trees' points (scene_hierarchy.cpp) are
    /// prefiltered from them too.
    TriangleSampling sampling = TriangleSampling::LowDiscrepancy;
    std::uint64_t seed = 0;  ///< Seed of the sample sequences.
    int max_depth = 40;      ///< Below this every remaining triangle is kept.
    /// Limits on the build: Budgets::octree_depth (levels below any tree's root) and
    /// Budgets::points (over all of a scene's trees); a build that would pass one is refused.
    Budgets budgets;
};

/// A representative point with its prefiltered attributes (before quantization).
struct OctreePoint {
    std::array<std::uint8_t, 3> voxel{};  ///< Voxel index in the node's grid; position = centre.
    /// Gaussian-weighted average normal (unit), as the hierarchy file will store it.
    Vec3f normal = Vec3f::UnitZ();
    /// Normal gradient (§3.2) in the canonical tangent frame of `normal` (canonical_tangent):
    /// columns ∂n/∂u, ∂n/∂v of the normal's deviation on the plane at distance one.
    Mat2f gradient = Mat2f::Zero();
    bool gradient_fitted = false;  ///< False: the samples did not determine it (it is zero).
    Rgb diffuse = Rgb::Zero();     ///< Average diffuse albedo times texture.
    Rgb specular = Rgb::Zero();
    float phong_exponent = 0.0f;
    float reflectivity = 0.0f;
    float transparency = 0.0f;
    float roughness = 0.0f;
    float ior = 1.0f;
    Rgb emission = Rgb::Zero();  ///< Radiance emitted from the front (Material::emission).
    /// The share of the area it stands for that a cut-out leaves standing (1 for a solid
    /// surface); its colour and emission are averaged over what stands.
    float opacity = 1.0f;
    /// Where the surface lies from the voxel centre along `normal`, in voxel sides: the
    /// prefilter-weighted mean of the samples' (position − centre)·normal. A tracer places the
    /// point at centre + offset·side/k·normal, on the surface instead of up to √3/2 voxels off
    /// it (a surface crossing from one voxel layer to the next would otherwise jump by a voxel).
    float offset = 0.0f;
    /// The surface area the point stands for, relative to a voxel face (side²): its share of
    /// the samples' area, each sample's split among the node's points by their Gaussian
    /// weights, so a node's coverages add up to the area of the triangles its points represent.
    /// 1 for a flat surface along the grid; less on slanted ones, which occupy more voxels.
    float coverage = 0.0f;
    /// Length of the weighted average of the unit normals the point stands for (the samples',
    /// each weighed like every other attribute): 1 where they agree, less where they spread
    /// (bumps, creases, curvature across its Gaussian). The tracer widens its highlight by it
    /// (Toksvig), the spread of normals within a point being the paper's "normal
    /// distributions" left for future work (§7).
    float normal_length = 1.0f;
};

struct OctreeNode {
    Vec3f origin = Vec3f::Zero();  ///< Minimum corner of the node's cube.
    float side = 0.0f;             ///< Edge length of the cube; voxel side = side / k.
    int level = 0;
    std::vector<OctreePoint> points;
    std::vector<std::uint32_t> triangles;  ///< Mesh triangles kept here, ascending.
    /// Instance trees (preprocess/scene_hierarchy.h): the instances held here, ascending.
    std::vector<std::uint32_t> instances;
    std::array<std::int32_t, 8> children{-1, -1, -1, -1, -1, -1, -1, -1};  ///< −1: none.
    Vec3f sphere_centre = Vec3f::Zero();  ///< Bounding sphere of everything in the subtree.
    float sphere_radius = 0.0f;
    Eigen::AlignedBox3f bounds;  ///< Bounding box of everything in the subtree.

    Vec3f voxel_centre(const std::array<std::uint8_t, 3>& v, int grid) const {
        const float step = side / static_cast<float>(grid);
        return origin + step * (Vec3f(v[0], v[1], v[2]) + Vec3f::Constant(0.5f));
    }
};

struct PointOctree {
    PointOctreeOptions options;
    std::vector<OctreeNode> nodes;  ///< nodes[0] is the root; children follow their parents.
};

/// Builds the hierarchy over `mesh` (world space; its per-triangle materials index
/// `materials`). `textures` may be null when no material has a texture. Deterministic for the
/// options' seed whatever the number of threads. `progress`, if given, advances by one per
/// triangle as it comes to rest in a node (its total should be the triangle count).
/// Refusals (geometry beyond single-precision cubes, options.budgets) name the mesh.
PointOctree build_point_octree(const Mesh& mesh, const std::vector<Material>& materials,
                               const TextureSampler* textures, const PointOctreeOptions& options,
                               Progress* progress = nullptr);

/// As above, as one of a scene's trees: its points count against `budget`'s total, and
/// refusals name `budget`'s scene file and the mesh.
PointOctree build_point_octree(const Mesh& mesh, const std::vector<Material>& materials,
                               const TextureSampler* textures, const PointOctreeOptions& options,
                               BuildBudget& budget, Progress* progress = nullptr);

}  // namespace mrt
