#pragma once
// The scene a hierarchy file stands for: its scene record (camera, lights, materials, textures)
// with the file's own geometry — each mesh object's triangles and vertices (normals decoded from
// their quantized form) as a mesh, each group object's instances as a group, the world object
// as the root — so that every tracer can render a .mrh file without the scene it was built
// from. load_scene (common/scene_io/scene_loader.h) calls it for files that begin with the .mrh
// magic.

#include "common/hierarchy/hierarchy_file.h"
#include "common/scene/scene.h"
#include "common/system/budgets.h"

#include <filesystem>

namespace mrt {

/// The Scene of `file` (opened from `path`, which errors name). Throws mrt::Error when the
/// record is not a valid scene record or a triangle refers to a material it does not have, or
/// when the record's camera is over the `pixels` budget (load_scene checks the geometry's).
Scene scene_from_hierarchy(const HierarchyFile& file, const std::filesystem::path& path,
                           const Budgets& budgets = {});

}  // namespace mrt
