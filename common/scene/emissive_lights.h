#pragma once
// The lights a scene's emissive geometry makes: every placement of a mesh's faces whose material
// emits (Material::emission) becomes area lights, one per flat, edge-connected region of one
// material, so that the Cornell box's light quad is one light of two triangles, not two lights.
// Every loader calls this after building a scene (scene files and hierarchy files alike), which
// is why lights made of geometry are never written anywhere.

#include "common/scene/scene.h"

#include <vector>

namespace mrt {

/// The area lights of `scene`'s emissive faces, in world space. Regions join triangles of one
/// material that share an edge (by vertex position) and whose planes agree within rounding; a
/// placement that mirrors keeps each light's emitting side the side its faces' winding faces.
/// Triangles of zero area emit nothing and are left out.
std::vector<MeshAreaLight> emissive_lights(const Scene& scene);

}  // namespace mrt
