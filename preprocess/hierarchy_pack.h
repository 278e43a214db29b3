#pragma once
// From the in-memory hierarchy to the records of the hierarchy file: quantizes every point and
// vertex (common/math/quantization.h), lays the objects' trees one after another with their
// triangles, vertices and instances, and leaves out the channels the scene's materials do not
// need.

#include "common/hierarchy/hierarchy_channels.h"
#include "common/hierarchy/hierarchy_file.h"
#include "common/mesh/mesh.h"
#include "common/scene/scene.h"
#include "preprocess/octree/point_octree.h"
#include "preprocess/scene_hierarchy.h"

#include <span>
#include <string>
#include <vector>

namespace mrt {

/// The file's records for a scene's hierarchy; `scene_json` and `build_json` are stored as the
/// file's scene and build records.
HierarchyData pack_hierarchy(const SceneHierarchy& hierarchy,
                             const std::vector<Material>& materials, std::string scene_json,
                             std::string build_json);

/// The file of one octree over `mesh` as its only object, the world.
HierarchyData pack_hierarchy(const PointOctree& octree, const Mesh& mesh,
                             const std::vector<Material>& materials, std::string build_json);

}  // namespace mrt
