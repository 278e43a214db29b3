#pragma once
// Which optional point channels of a hierarchy file (common/hierarchy/hierarchy_file.h) a scene
// needs: the one rule by which the writer leaves channels out and the reader refuses a file that
// lacks one its scene record's materials need (a mirror drawn without its reflectivity, say).

#include "common/mesh/mesh.h"
#include "common/scene/scene.h"

#include <span>
#include <vector>

namespace mrt {

/// Which optional point channels the materials used by `meshes` need.
struct HierarchyChannels {
    bool specular = false;    ///< Some used material has a specular colour.
    bool mirror = false;      ///< Some used material reflects or refracts: normal gradients.
    bool refraction = false;  ///< Some used material is transparent.
    bool emission = false;    ///< Some used material emits.
    bool opacity = false;     ///< Some used material is cut out and its mesh has uvs.
    bool uvs = false;         ///< Some used material is textured or cut out and its mesh has uvs.
};

/// The channels the materials of `materials` used by some triangle of `meshes` need.
HierarchyChannels needed_channels(std::span<const Mesh* const> meshes,
                                  const std::vector<Material>& materials);

}  // namespace mrt
