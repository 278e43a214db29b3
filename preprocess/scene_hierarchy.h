#pragma once
// The point hierarchy of a whole scene, instanced (the paper's Figure 7 scene is 110 k unique
// triangles instanced to 8.7 M): one point octree per unique mesh in its object space
// (preprocess/octree/point_octree.h), and per group an instance tree in the group's space whose
// nodes hold the group's instances at the leaves and, wherever a node holds more than one instance
// below it, points that approximate all of them.
//
// A group node's points are prefiltered like a mesh node's (preprocess/octree/surface_prefilter.h),
// from the finer representations below it, mapped into the group's space: the points of the
// first nodes of each instance's trees whose spacing is at most half this node's (with the
// triangles kept above them, sampled at c per voxel face). With that spacing every surface
// point is within the finer voxel diagonal of a finer representative, and that one within half
// this node's diagonal of this node's: within this node's diagonal, the guarantee of the mesh
// octrees. Their attributes are already prefiltered over at most half a voxel, so the node's
// filter is √(1 + ¼) ≈ 1.12 voxels wide at most instead of one.
//
// The build's work grows linearly with the instances: only nodes well inside their nearest
// ancestor with points make points (halves of a pile of instances share its cube, and their
// points would be as coarse), and a node whose samples would be many layers of surface deep
// (piled instances) thins them to what its voxels need. HierarchyWork counts that work.

#include "common/math/math.h"
#include "common/mesh/mesh.h"
#include "common/scene/scene.h"
#include "preprocess/octree/point_octree.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace mrt {

class Progress;
class TextureSampler;

/// An object placed in a group's space.
struct SceneInstance {
    std::uint32_t object = 0;                   ///< Into SceneHierarchy::objects.
    Affine3f transform = Affine3f::Identity();  ///< Object space → group space.
};

/// A unique mesh with its point octree, or a group with its instance tree.
struct SceneObject {
    enum class Kind : std::uint8_t { Mesh, Group };
    Kind kind = Kind::Mesh;
    const Mesh* mesh = nullptr;  ///< Mesh objects: the geometry (the scene's, or the flattened).
    /// Mesh: its point octree. Group: the instance tree (nodes hold points and instances).
    PointOctree tree;
};

/// What building the instance trees' points cost, in units that do not depend on the machine
/// or the thread count: the scale of the build's work, for tests and benchmarks.
struct HierarchyWork {
    /// Samples the instance trees' nodes drew: representative-choosing positions, prefiltering
    /// samples and finer points taken as samples.
    std::uint64_t samples = 0;
    std::uint64_t visits = 0;         ///< Nodes of the trees below them walked through.
    std::uint64_t point_nodes = 0;    ///< Instance-tree nodes that made points.
    std::uint64_t thinned_nodes = 0;  ///< Of those, nodes whose samples were thinned.
};

struct SceneHierarchy {
    PointOctreeOptions options;
    std::vector<SceneObject> objects;  ///< Every object after the objects it instances.
    std::vector<SceneInstance> instances;
    std::uint32_t world = 0;                ///< The object that is the scene.
    std::unique_ptr<const Mesh> flattened;  ///< The world's one mesh in a flattened build.
    HierarchyWork work;                     ///< What the instance trees' points cost.
};

/// How a build treats the scene's instances.
enum class Instancing : std::uint8_t {
    Keep,     ///< Unique geometry once, placed by instance trees (the default).
    Flatten,  ///< Every instance expanded into one world-space mesh (mrt-preprocess --flatten).
};

/// Builds the hierarchy of `scene`'s world. Flattened, one octree over every triangle in
/// world space instead (instances expanded). `textures` may be null when nothing is textured.
/// Refuses (mrt::Error naming scene.file and the mesh or group) geometry beyond what single-
/// precision node cubes hold and builds over options.budgets (points, octree depth).
/// Deterministic for the options' seed whatever the number of threads; `progress` advances by
/// one per triangle coming to rest in a mesh octree and by a group's instances when its
/// instance tree has its points (its total: hierarchy_progress_total).
SceneHierarchy build_scene_hierarchy(const Scene& scene, const TextureSampler* textures,
                                     const PointOctreeOptions& options,
                                     Instancing instancing = Instancing::Keep,
                                     Progress* progress = nullptr);

/// The units build_scene_hierarchy advances a progress bar by when it builds every mesh and
/// group of the scene: the unique triangles and the groups' instances (flattened: every
/// instanced triangle).
std::uint64_t hierarchy_progress_total(const Scene& scene,
                                       Instancing instancing = Instancing::Keep);

/// Most instances a leaf of an instance tree holds.
inline constexpr std::size_t kInstancesPerLeaf = 4;

}  // namespace mrt
