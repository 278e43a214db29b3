#pragma once
// What an MTL material means for rendering: the mapping of its statements onto the project's
// Material, written down in docs/scene-format.md ("Materials from the mesh file").

#include "common/mesh/mtl_library.h"
#include "common/scene/scene.h"

#include <filesystem>
#include <functional>
#include <string>

namespace mrt {

/// The Material named `name` that `mtl` stands for. `texture(file)` returns the index in
/// Scene::textures of an 8-bit-sRGB colour texture, adding it when new. `warn` receives what the
/// mapping cannot render (a `map_d` cut-out), naming the library and line.
Material material_from_mtl(const MtlMaterial& mtl, const std::filesystem::path& library,
                           std::string name,
                           const std::function<int(const std::filesystem::path&)>& texture,
                           const MtlWarning& warn = {});

}  // namespace mrt
