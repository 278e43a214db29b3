#pragma once
// What an MTL material means for rendering: the mapping of its statements onto the project's
// Material, written down in docs/scene-format.md ("Materials from the mesh file").

#include "common/mesh/mtl_library.h"
#include "common/scene/scene.h"

#include <filesystem>
#include <functional>
#include <string>

namespace mrt {

/// The index in Scene::textures of `file` read as `channel` (colour: 8-bit sRGB), added when new.
using MtlTextureIndex = std::function<int(const std::filesystem::path& file, TextureChannel)>;

/// The Material named `name` that `mtl` stands for, its textures numbered by `texture`. `warn`
/// receives what the mapping changes (a cut-out whose uv options differ from the colour's),
/// naming the library and line.
Material material_from_mtl(const MtlMaterial& mtl, const std::filesystem::path& library,
                           std::string name, const MtlTextureIndex& texture,
                           const MtlWarning& warn = {});

}  // namespace mrt
