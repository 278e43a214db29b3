#pragma once
// From the in-memory octree to the records of the hierarchy file: quantizes every point and
// vertex (common/quantization.h) and leaves out the channels the scene's materials do not need.

#include "common/hierarchy_file.h"
#include "common/mesh.h"
#include "common/scene.h"
#include "preprocess/point_octree.h"

#include <string>
#include <vector>

namespace mrt {

/// Which optional point channels the materials used by `mesh` need.
struct HierarchyChannels {
    bool specular = false;    ///< Some used material has a specular colour.
    bool mirror = false;      ///< Some used material reflects or refracts: normal gradients.
    bool refraction = false;  ///< Some used material is transparent.
    bool uvs = false;         ///< Some used material is textured and the mesh has uvs.
};
HierarchyChannels needed_channels(const Mesh& mesh, const std::vector<Material>& materials);

/// The file's records for `octree` built over `mesh`; `build_json` is stored as the file's
/// build record.
HierarchyData pack_hierarchy(const PointOctree& octree, const Mesh& mesh,
                             const std::vector<Material>& materials, std::string build_json);

}  // namespace mrt
