#pragma once
// Two-level (multi-level) bounding volume hierarchy over a Scene: a binned-SAH BVH per unique
// mesh, and one per group over its children (mesh or nested group instances, each with its
// transform). Unique geometry is stored once however often it is instanced.
// Intersection is watertight (Woop, Benthin & Wald 2013): rays aimed at shared edges and vertices
// of a closed mesh never slip through.

#include "common/math/ray.h"
#include "common/scene/scene.h"
#include "common/system/fields.h"
#include "trace/bvh/triangle_bvh.h"

#include <cstdint>
#include <iosfwd>
#include <memory>
#include <vector>

namespace mrt {

class SceneCutouts;

/// Object → world transform of a hit, compact 3×4.
using Affine3fCompact = Eigen::Transform<float, 3, Eigen::AffineCompact, Eigen::DontAlign>;

/// Nearest hit along a ray.
struct SceneHit {
    float t = kInfinity;         ///< Ray parameter (units of |ray.direction|).
    std::uint32_t mesh = 0;      ///< Index into Scene::meshes.
    std::uint32_t triangle = 0;  ///< Index into that mesh's triangles.
    float b1 = 0.0f;             ///< Barycentric weight of vertex 1.
    float b2 = 0.0f;  ///< Barycentric weight of vertex 2 (vertex 0 gets 1 − b1 − b2).
    Affine3fCompact object_to_world = Affine3fCompact::Identity();

    bool valid() const { return t < kInfinity; }
};

/// What building the BVHs made.
struct SceneBvhStats {
    std::uint64_t mesh_nodes = 0;        ///< Nodes of the meshes' BVHs.
    std::uint64_t group_nodes = 0;       ///< Nodes of the groups' BVHs over instances.
    std::uint64_t unique_triangles = 0;  ///< Triangles of the meshes, each counted once.
    std::uint64_t bytes = 0;             ///< Memory of all the BVHs.
    double build_seconds = 0.0;

    static constexpr auto fields = std::tuple{
        Field{"mesh_nodes", &SceneBvhStats::mesh_nodes},
        Field{"group_nodes", &SceneBvhStats::group_nodes},
        Field{"unique_triangles", &SceneBvhStats::unique_triangles},
        Field{"bytes", &SceneBvhStats::bytes},
        Field{"build_seconds", &SceneBvhStats::build_seconds},
    };
};

std::ostream& operator<<(std::ostream& os, const SceneBvhStats& s);

class SceneBvh {
  public:
    /// Builds BVHs for every mesh and group of the scene (in parallel over meshes). The scene must
    /// outlive the SceneBvh.
    explicit SceneBvh(const Scene& scene);
    ~SceneBvh();
    SceneBvh(SceneBvh&&) noexcept;
    SceneBvh& operator=(SceneBvh&&) noexcept;

    /// Nearest hit with t in (0, ray.t_max); returns false when there is none. With
    /// `cutouts` (built over the same scene), hits in a cut-out's holes do not count.
    bool intersect(const Ray& ray, SceneHit& hit, const SceneCutouts* cutouts = nullptr) const;
    /// Whether anything is hit with t in (0, ray.t_max) (any hit, early exit).
    bool occluded(const Ray& ray, const SceneCutouts* cutouts = nullptr) const;

    /// World-space bounds of the whole scene.
    Eigen::AlignedBox3f bounds() const;
    const SceneBvhStats& stats() const { return m_stats; }

  private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
    SceneBvhStats m_stats;
};

}  // namespace mrt
