#pragma once
// The prefilter of Wand & Straßer §3.2, shared by the mesh octrees and the instance trees: dense
// samples of a surface, each carrying the material it stands for, averaged with a Gaussian of
// one voxel side (σ, cut at 2.5σ) around the centre of every chosen voxel of a node's k³ grid.
// The normal gradient is fitted to the samples' normals (preprocess/octree/normal_gradient.h).

#include "common/math/math.h"
#include "preprocess/octree/point_octree.h"
#include "preprocess/octree/triangle_sampling.h"

#include <cstdint>
#include <span>
#include <vector>

namespace mrt {

class TextureSampler;

/// One dense sample of a surface with the attributes the points average (node space).
struct SurfaceSample {
    Vec3f position = Vec3f::Zero();
    Vec3f normal = Vec3f::UnitZ();  ///< Unit shading normal.
    /// The length of the average of the unit normals the sample stands for: 1 for a sample of a
    /// triangle, a point's OctreePoint::normal_length for a sample taken from a point.
    float normal_length = 1.0f;
    Rgb diffuse = Rgb::Zero();  ///< Albedo times texture at the sample.
    Rgb specular = Rgb::Zero();
    /// log of the Phong exponent: exponents are averaged geometrically, since highlights of
    /// exponent 10 and 1000 blend to something like 100, not 505.
    double log_phong = 0.0;
    float reflectivity = 0.0f;
    float transparency = 0.0f;
    float roughness = 0.0f;
    float ior = 1.0f;
    Rgb emission = Rgb::Zero();
    /// A cut-out's opacity at the sample (1 for a solid surface): the area stands whole, and
    /// the points average colours over what stands (OctreePoint::opacity).
    float opacity = 1.0f;
    /// Surface area the sample stands for, in voxel faces ((side/k)²) of the node gathering it:
    /// dimensionless, so that neither a node of side 1e30 nor one of 1e-30 over- or underflows.
    float area = 0.0f;
    std::uint32_t voxel = 0;  ///< Linear voxel index (x fastest) in the node's grid.
};

/// Linear index (x fastest) of the voxel of `node`'s grid that holds p (clamped to the grid).
std::uint32_t voxel_index(const OctreeNode& node, int grid, const Vec3f& p);

/// Fills `out` with the first out.size() samples of the sequence `key` of `scheme` on triangle t
/// of `mesh`, each standing for an equal share of its area in units of `voxel_face` (node
/// space), placed by `to_node` (object → node space; null is the identity). `textures` may be
/// null when no material is textured. Voxels are left for the caller.
void triangle_samples(const Mesh& mesh, const std::vector<Material>& materials,
                      const TextureSampler* textures, std::uint32_t t, std::uint64_t key,
                      const Affine3f* to_node, double voxel_face, std::span<SurfaceSample> out,
                      TriangleSampling scheme);

/// The area of the triangle (a, b, c), in double: its edges' cross product overflows single
/// precision from coordinates of about 1e19 on.
double triangle_area(const Vec3f& a, const Vec3f& b, const Vec3f& c);

/// The longest edge of the triangle (a, b, c), in double.
double longest_edge(const Vec3f& a, const Vec3f& b, const Vec3f& c);

/// The node's points: one at the centre of every voxel in `chosen` (linear indices, repeats
/// allowed), its attributes the Gaussian-weighted averages of `samples` (whose `voxel` fields
/// must be set) and its coverage the gathered area relative to a plane through the centre.
/// Distances are measured in voxel sides, so any finite node side works.
std::vector<OctreePoint> prefilter_points(const OctreeNode& node, int grid,
                                          const std::vector<SurfaceSample>& samples,
                                          std::vector<std::uint32_t> chosen);

}  // namespace mrt
