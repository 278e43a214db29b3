#include "common/scene/emissive_lights.h"

#include "common/math/position_weld.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>

namespace mrt {

namespace {

/// Planes agree when their unit normals' angle is below about 0.03° and each triangle's
/// vertices lie within this fraction of the region's size of the other's plane.
constexpr float kCoplanarCosine = 0.9999999f;
constexpr float kCoplanarDistance = 1e-5f;

/// Emissive triangles of one mesh that form one light, in the mesh's space.
struct Region {
    std::vector<std::uint32_t> triangles;
    std::uint32_t material = 0;
};

/// Union-find over triangles.
class Components {
  public:
    explicit Components(std::size_t n) : m_parent(n) {
        std::iota(m_parent.begin(), m_parent.end(), std::size_t{0});
    }
    std::size_t find(std::size_t i) {
        while (m_parent[i] != i) {
            m_parent[i] = m_parent[m_parent[i]];
            i = m_parent[i];
        }
        return i;
    }
    void join(std::size_t a, std::size_t b) { m_parent[find(a)] = find(b); }

  private:
    std::vector<std::size_t> m_parent;
};

Vec3f face_normal(const Mesh& mesh, std::uint32_t t) {
    const auto& tri = mesh.triangles[t];
    return (mesh.positions[tri[1]] - mesh.positions[tri[0]])
        .cross(mesh.positions[tri[2]] - mesh.positions[tri[0]]);
}

bool coplanar(const Mesh& mesh, std::uint32_t a, std::uint32_t b) {
    const Vec3f na = face_normal(mesh, a).normalized();
    const Vec3f nb = face_normal(mesh, b).normalized();
    if (na.dot(nb) < kCoplanarCosine) {
        return false;
    }
    const Vec3f origin = mesh.positions[mesh.triangles[a][0]];
    float size = 0.0f;
    float distance = 0.0f;
    for (const std::uint32_t v : mesh.triangles[b]) {
        const Vec3f d = mesh.positions[v] - origin;
        size = std::max(size, d.norm());
        distance = std::max(distance, std::abs(na.dot(d)));
    }
    return distance <= kCoplanarDistance * size;
}

/// The regions of `mesh` whose material emits.
std::vector<Region> emissive_regions(const Scene& scene, const Mesh& mesh) {
    std::vector<std::uint32_t> emitting;
    for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t) {
        const std::uint32_t material = t < mesh.materials.size() ? mesh.materials[t] : 0u;
        if (material < scene.materials.size() && scene.materials[material].emits() &&
            face_normal(mesh, t).squaredNorm() > 0.0f) {
            emitting.push_back(t);
        }
    }
    if (emitting.empty()) {
        return {};
    }
    std::vector<std::uint32_t> representative;
    const std::vector<std::uint32_t> welded = weld_positions(
        mesh.positions.size(), [&](std::size_t v) { return mesh.positions[v]; }, representative);
    // Edges by their welded end points; the first triangle seen on an edge meets the later ones.
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::size_t>> edges;
    for (std::size_t i = 0; i < emitting.size(); ++i) {
        const auto& tri = mesh.triangles[emitting[i]];
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = welded[tri[static_cast<std::size_t>(k)]];
            const std::uint32_t b = welded[tri[static_cast<std::size_t>((k + 1) % 3)]];
            edges[std::minmax(a, b)].push_back(i);
        }
    }
    Components components(emitting.size());
    for (const auto& [edge, sharing] : edges) {
        for (std::size_t j = 1; j < sharing.size(); ++j) {
            const std::uint32_t a = emitting[sharing[0]];
            const std::uint32_t b = emitting[sharing[j]];
            if (mesh.materials[a] == mesh.materials[b] && coplanar(mesh, a, b)) {
                components.join(sharing[0], sharing[j]);
            }
        }
    }
    std::map<std::size_t, std::size_t> region_of_root;
    std::vector<Region> regions;
    for (std::size_t i = 0; i < emitting.size(); ++i) {
        const auto [it, added] = region_of_root.try_emplace(components.find(i), regions.size());
        if (added) {
            regions.push_back({{}, mesh.materials[emitting[i]]});
        }
        regions[it->second].triangles.push_back(emitting[i]);
    }
    return regions;
}

}  // namespace

std::vector<MeshAreaLight> emissive_lights(const Scene& scene) {
    if (std::none_of(scene.materials.begin(), scene.materials.end(),
                     [](const Material& m) { return m.emits(); }) ||
        scene.root >= scene.groups.size()) {
        return {};
    }
    std::vector<std::vector<Region>> regions(scene.meshes.size());
    for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
        regions[m] = emissive_regions(scene, scene.meshes[m]);
    }
    std::vector<MeshAreaLight> lights;
    for_each_mesh_instance(scene, scene.root, [&](std::uint32_t m, const Affine3f& to_world) {
        const Mesh& mesh = scene.meshes[m];
        const bool mirrored = to_world.linear().cast<double>().determinant() < 0.0;
        for (const Region& region : regions[m]) {
            std::vector<MeshAreaLight::Triangle> triangles;
            triangles.reserve(region.triangles.size());
            Vec3f normal = Vec3f::Zero();
            for (const std::uint32_t t : region.triangles) {
                const auto& tri = mesh.triangles[t];
                MeshAreaLight::Triangle world{to_world * mesh.positions[tri[0]],
                                              to_world * mesh.positions[tri[1]],
                                              to_world * mesh.positions[tri[2]]};
                if (mirrored) {
                    std::swap(world[1], world[2]);
                }
                // Area-weighted: the sum of the cross products.
                normal += (world[1] - world[0]).cross(world[2] - world[0]);
                triangles.push_back(world);
            }
            if (!(normal.squaredNorm() > 0.0f) || !all_finite(normal)) {
                continue;  // collapsed by its placement
            }
            lights.emplace_back(std::move(triangles), normal.normalized(),
                                scene.materials[region.material].emission);
        }
    });
    return lights;
}

}  // namespace mrt
