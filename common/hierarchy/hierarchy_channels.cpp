#include "common/hierarchy/hierarchy_channels.h"

namespace mrt {

HierarchyChannels needed_channels(std::span<const Mesh* const> meshes,
                                  const std::vector<Material>& materials) {
    std::vector<char> used(materials.size(), 0);
    std::vector<char> textured_with_uvs(materials.size(), 0);
    for (const Mesh* mesh : meshes) {
        for (const std::uint32_t m : mesh->materials) {
            if (m < used.size()) {
                used[m] = 1;
                textured_with_uvs[m] = textured_with_uvs[m] || mesh->has_uvs();
            }
        }
    }
    HierarchyChannels channels;
    for (std::size_t m = 0; m < materials.size(); ++m) {
        if (!used[m]) {
            continue;
        }
        const Material& material = materials[m];
        channels.specular = channels.specular || (material.specular > 0.0f).any();
        channels.mirror = channels.mirror || material.reflects() || material.refracts();
        channels.refraction = channels.refraction || material.refracts();
        channels.emission = channels.emission || material.emits();
        channels.opacity = channels.opacity || (material.cut_out() && textured_with_uvs[m]);
        channels.uvs =
            channels.uvs || ((material.texture >= 0 || material.cut_out()) && textured_with_uvs[m]);
    }
    return channels;
}

}  // namespace mrt
