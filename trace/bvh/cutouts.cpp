#include "trace/bvh/cutouts.h"

#include "common/texture/texture.h"

#include <algorithm>

namespace mrt {

bool MeshCutout::stands(std::uint32_t triangle, float b1, float b2) const {
    const Material& material = (*m_materials)[m_mesh->materials[triangle]];
    if (!material.cut_out()) {
        return true;
    }
    const auto& tri = m_mesh->triangles[triangle];
    const Vec2f uv = (1.0f - b1 - b2) * m_mesh->uvs[tri[0]] + b1 * m_mesh->uvs[tri[1]] +
                     b2 * m_mesh->uvs[tri[2]];
    return m_textures->opacity(material, uv) >= kCutoutThreshold;
}

SceneCutouts::SceneCutouts(const Scene& scene, const TextureSampler& textures)
    : m_index(scene.meshes.size(), -1) {
    for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
        const Mesh& mesh = scene.meshes[i];
        const bool cut = mesh.has_uvs() &&
                         std::any_of(mesh.materials.begin(), mesh.materials.end(),
                                     [&](std::uint32_t m) { return scene.materials[m].cut_out(); });
        if (cut) {
            m_index[i] = static_cast<int>(m_cutouts.size());
            m_cutouts.emplace_back(mesh, scene.materials, textures);
        }
    }
}

}  // namespace mrt
