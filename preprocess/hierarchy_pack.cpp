#include "preprocess/hierarchy_pack.h"

#include "common/error.h"

#include <algorithm>
#include <limits>

namespace mrt {

HierarchyChannels needed_channels(const Mesh& mesh, const std::vector<Material>& materials) {
    std::vector<char> used(materials.size(), 0);
    for (const std::uint32_t m : mesh.materials) {
        if (m < used.size()) {
            used[m] = 1;
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
        channels.uvs = channels.uvs || (material.texture >= 0 && mesh.has_uvs());
    }
    return channels;
}

HierarchyData pack_hierarchy(const PointOctree& octree, const Mesh& mesh,
                             const std::vector<Material>& materials, std::string build_json) {
    const HierarchyChannels channels = needed_channels(mesh, materials);
    HierarchyData data;
    data.grid = octree.options.grid;
    data.build_json = std::move(build_json);
    constexpr std::uint32_t kNoParent = std::numeric_limits<std::uint32_t>::max();

    std::vector<std::uint32_t> parent(octree.nodes.size(), kNoParent);
    for (std::size_t n = 0; n < octree.nodes.size(); ++n) {
        for (const std::int32_t c : octree.nodes[n].children) {
            if (c >= 0) {
                parent[static_cast<std::size_t>(c)] = static_cast<std::uint32_t>(n);
            }
        }
    }
    for (std::size_t n = 0; n < octree.nodes.size(); ++n) {
        const OctreeNode& node = octree.nodes[n];
        HierarchyNode packed{};
        packed.origin = {node.origin.x(), node.origin.y(), node.origin.z()};
        packed.side = node.side;
        packed.sphere_centre = {node.sphere_centre.x(), node.sphere_centre.y(),
                                node.sphere_centre.z()};
        packed.sphere_radius = node.sphere_radius;
        packed.first_point = static_cast<std::uint32_t>(data.core.size());
        packed.point_count = static_cast<std::uint32_t>(node.points.size());
        packed.first_triangle = static_cast<std::uint32_t>(data.node_triangles.size());
        packed.triangle_count = static_cast<std::uint32_t>(node.triangles.size());
        packed.parent = parent[n];
        packed.level = static_cast<std::uint8_t>(std::min(node.level, 255));
        // Breadth-first order puts a node's children next to each other, in octant order.
        std::uint32_t first_child = kNoParent;
        for (int c = 0; c < 8; ++c) {
            const std::int32_t child = node.children[static_cast<std::size_t>(c)];
            if (child >= 0) {
                packed.child_mask = static_cast<std::uint8_t>(packed.child_mask | (1u << c));
                first_child = std::min(first_child, static_cast<std::uint32_t>(child));
            }
        }
        packed.first_child = packed.child_mask != 0 ? first_child : 0;
        std::uint32_t expected = first_child;
        for (const std::int32_t child : node.children) {
            if (child >= 0 && static_cast<std::uint32_t>(child) != expected++) {
                throw Error("hierarchy: the octree's children are not consecutive");
            }
        }
        data.nodes.push_back(packed);
        data.node_triangles.insert(data.node_triangles.end(), node.triangles.begin(),
                                   node.triangles.end());
        for (const OctreePoint& p : node.points) {
            // Coverage is stored up to 2 (a surface folded into the Gaussian counts twice).
            data.core.push_back({p.voxel, encode_unit8(std::min(1.0f, 0.5f * p.coverage)),
                                 encode_normal(p.normal)});
            data.diffuse.push_back({encode_rgb8(p.diffuse), 0});
            if (channels.specular) {
                data.specular.push_back({encode_rgb8(p.specular), encode_phong8(p.phong_exponent)});
            }
            if (channels.mirror) {
                data.mirror.push_back({encode_unit8(p.reflectivity), encode_unit8(p.roughness),
                                       encode_tangent_angle(canonical_tangent(p.normal), p.normal),
                                       encode_gradient(p.gradient)});
            }
            if (channels.refraction) {
                data.refraction.push_back({encode_unit8(p.transparency), encode_ior8(p.ior)});
            }
        }
    }
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        const Vec3f& p = mesh.positions[v];
        data.vertex_positions.push_back({p.x(), p.y(), p.z()});
        data.vertex_normals.push_back(encode_normal(mesh.normals[v]));
        if (channels.uvs) {
            data.vertex_uvs.push_back({mesh.uvs[v].x(), mesh.uvs[v].y()});
        }
    }
    data.triangles = mesh.triangles;
    data.triangle_materials = mesh.materials;
    return data;
}

}  // namespace mrt
