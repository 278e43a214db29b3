#pragma once
// Cut-outs for the ray tracers: a triangle hit counts only where its material's opacity
// (Material::opacity_texture, point-sampled at the hit's texture coordinates) is at least ½, the
// alpha test of conventional renderers. Leaves, fences and hair cards are textured quads with
// holes; whitted's rays pass through the holes, distributed's samples average the holes over a
// pixel, and both see a binary mask's edge where the bilinear opacity crosses ½. (The cone
// tracer and the points weigh the surface by the opacity filtered over their footprints
// instead: trace/cone/cone_traversal.cpp and preprocess/octree/surface_prefilter.cpp.)

#include "common/mesh/mesh.h"
#include "common/scene/scene.h"

#include <cstdint>
#include <vector>

namespace mrt {

class TextureSampler;

/// The alpha test's threshold.
inline constexpr float kCutoutThreshold = 0.5f;

/// The cut-out of one mesh: which of its triangles' hits stand.
class MeshCutout {
  public:
    MeshCutout(const Mesh& mesh, const std::vector<Material>& materials,
               const TextureSampler& textures)
        : m_mesh(&mesh), m_materials(&materials), m_textures(&textures) {}

    /// Whether the hit at barycentrics (b1, b2) of `triangle` lies on the surface rather than in
    /// a hole.
    bool stands(std::uint32_t triangle, float b1, float b2) const;

  private:
    const Mesh* m_mesh;
    const std::vector<Material>* m_materials;
    const TextureSampler* m_textures;
};

/// The cut-outs of a scene's meshes: only meshes with texture coordinates and a material with an
/// opacity texture have one (a mesh without texture coordinates has no textures, so no holes).
class SceneCutouts {
  public:
    /// The scene and the sampler must outlive this.
    SceneCutouts(const Scene& scene, const TextureSampler& textures);

    /// Mesh `mesh`'s cut-out, or null where it has none (every hit stands).
    const MeshCutout* of_mesh(std::uint32_t mesh) const {
        return m_index[mesh] < 0 ? nullptr : &m_cutouts[static_cast<std::size_t>(m_index[mesh])];
    }
    bool empty() const { return m_cutouts.empty(); }

  private:
    std::vector<MeshCutout> m_cutouts;
    std::vector<int> m_index;  ///< Per mesh: into m_cutouts, or −1.
};

}  // namespace mrt
