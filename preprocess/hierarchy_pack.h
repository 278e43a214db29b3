#pragma once
// From the in-memory hierarchy to the records of the hierarchy file: quantizes every point and
// vertex (common/quantization.h), lays the objects' trees one after another with their
// triangles, vertices and instances, and leaves out the channels the scene's materials do not
// need.

#include "common/hierarchy_file.h"
#include "common/mesh.h"
#include "common/scene.h"
#include "preprocess/point_octree.h"
#include "preprocess/scene_hierarchy.h"

#include <span>
#include <string>
#include <vector>

namespace mrt {

/// Which optional point channels the materials used by `meshes` need.
struct HierarchyChannels {
    bool specular = false;    ///< Some used material has a specular colour.
    bool mirror = false;      ///< Some used material reflects or refracts: normal gradients.
    bool refraction = false;  ///< Some used material is transparent.
    bool uvs = false;         ///< Some used material is textured and its mesh has uvs.
};
HierarchyChannels needed_channels(std::span<const Mesh* const> meshes,
                                  const std::vector<Material>& materials);

/// The file's records for a scene's hierarchy; `scene_json` and `build_json` are stored as the
/// file's scene and build records.
HierarchyData pack_hierarchy(const SceneHierarchy& hierarchy,
                             const std::vector<Material>& materials, std::string scene_json,
                             std::string build_json);

/// The file of one octree over `mesh` as its only object, the world.
HierarchyData pack_hierarchy(const PointOctree& octree, const Mesh& mesh,
                             const std::vector<Material>& materials, std::string build_json);

}  // namespace mrt
