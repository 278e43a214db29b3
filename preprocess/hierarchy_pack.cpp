#include "preprocess/hierarchy_pack.h"

#include "common/system/error.h"

#include <algorithm>
#include <limits>

namespace mrt {

namespace {

constexpr std::uint32_t kNoParent = std::numeric_limits<std::uint32_t>::max();

/// One object to lay out: its tree and, for a mesh, its geometry (null for a group).
struct ObjectSource {
    const PointOctree* tree;
    const Mesh* mesh;
};

std::uint32_t count32(std::size_t n, const char* what) {
    if (n > std::numeric_limits<std::uint32_t>::max()) {
        throw Error(std::string("hierarchy: more ") + what + " than 32-bit indices address");
    }
    return static_cast<std::uint32_t>(n);
}

void pack_points(const OctreeNode& node, const HierarchyChannels& channels, HierarchyData& data) {
    for (const OctreePoint& p : node.points) {
        data.core.push_back({p.voxel, encode_coverage8(p.coverage), encode_normal(p.normal)});
        data.offset.push_back({encode_offset8(p.offset)});
        data.diffuse.push_back({encode_rgb8(p.diffuse), encode_normal_length8(p.normal_length)});
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
        if (channels.emission) {
            data.emission.push_back({{encode_half(p.emission[0]), encode_half(p.emission[1]),
                                      encode_half(p.emission[2])}});
        }
        if (channels.opacity) {
            data.opacity.push_back({encode_unit8(p.opacity)});
        }
    }
}

/// Appends one object's nodes (and a mesh's triangles and vertices) to `data`.
void pack_object(const ObjectSource& source, const HierarchyChannels& channels,
                 HierarchyData& data) {
    const std::vector<OctreeNode>& nodes = source.tree->nodes;
    if (nodes.empty()) {
        throw Error("hierarchy: an object without nodes");
    }
    HierarchyObject object{};
    object.first_node = count32(data.nodes.size(), "nodes");
    object.node_count = count32(nodes.size(), "nodes");
    object.kind = source.mesh != nullptr ? HierarchyObjectKind::Mesh : HierarchyObjectKind::Group;
    if (source.mesh != nullptr) {
        object.first_triangle = count32(data.triangles.size(), "triangles");
        object.triangle_count = count32(source.mesh->triangles.size(), "triangles");
        object.first_vertex = count32(data.vertex_positions.size(), "vertices");
        object.vertex_count = count32(source.mesh->positions.size(), "vertices");
    }
    std::vector<std::uint32_t> parent(nodes.size(), kNoParent);
    for (std::size_t n = 0; n < nodes.size(); ++n) {
        for (const std::int32_t c : nodes[n].children) {
            if (c >= 0) {
                parent[static_cast<std::size_t>(c)] =
                    object.first_node + static_cast<std::uint32_t>(n);
            }
        }
    }
    for (std::size_t n = 0; n < nodes.size(); ++n) {
        const OctreeNode& node = nodes[n];
        HierarchyNode packed{};
        packed.origin = {node.origin.x(), node.origin.y(), node.origin.z()};
        packed.side = node.side;
        packed.sphere_centre = {node.sphere_centre.x(), node.sphere_centre.y(),
                                node.sphere_centre.z()};
        packed.sphere_radius = node.sphere_radius;
        packed.first_point = count32(data.core.size(), "points");
        packed.point_count = count32(node.points.size(), "points");
        packed.first_triangle = count32(data.node_triangles.size(), "kept triangles");
        packed.triangle_count = count32(node.triangles.size(), "kept triangles");
        if (node.instances.size() > std::numeric_limits<std::uint16_t>::max()) {
            throw Error("hierarchy: more instances in one node than 16 bits count");
        }
        packed.instance_count = static_cast<std::uint16_t>(node.instances.size());
        packed.first_instance = node.instances.empty() ? 0 : node.instances.front();
        for (std::size_t i = 0; i < node.instances.size(); ++i) {
            if (node.instances[i] != packed.first_instance + i) {
                throw Error("hierarchy: a node's instances are not consecutive");
            }
        }
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
        std::uint32_t expected = first_child;
        for (const std::int32_t child : node.children) {
            if (child >= 0 && static_cast<std::uint32_t>(child) != expected++) {
                throw Error("hierarchy: the octree's children are not consecutive");
            }
        }
        packed.first_child = packed.child_mask != 0 ? object.first_node + first_child : 0;
        data.nodes.push_back(packed);
        for (const std::uint32_t t : node.triangles) {
            data.node_triangles.push_back(object.first_triangle + t);
        }
        pack_points(node, channels, data);
    }
    if (source.mesh != nullptr) {
        const Mesh& mesh = *source.mesh;
        for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
            const Vec3f& p = mesh.positions[v];
            data.vertex_positions.push_back({p.x(), p.y(), p.z()});
            data.vertex_normals.push_back(encode_normal(mesh.normals[v]));
            if (channels.uvs) {
                data.vertex_uvs.push_back(mesh.has_uvs()
                                              ? std::array{mesh.uvs[v].x(), mesh.uvs[v].y()}
                                              : std::array{0.0f, 0.0f});
            }
        }
        for (const auto& tri : mesh.triangles) {
            data.triangles.push_back({object.first_vertex + tri[0], object.first_vertex + tri[1],
                                      object.first_vertex + tri[2]});
        }
        data.triangle_materials.insert(data.triangle_materials.end(), mesh.materials.begin(),
                                       mesh.materials.end());
    }
    data.objects.push_back(object);
}

HierarchyData pack_objects(std::span<const ObjectSource> objects,
                           std::span<const SceneInstance> instances, std::uint32_t world, int grid,
                           const std::vector<Material>& materials, std::string scene_json,
                           std::string build_json) {
    std::vector<const Mesh*> meshes;
    for (const ObjectSource& o : objects) {
        if (o.mesh != nullptr) {
            meshes.push_back(o.mesh);
        }
    }
    const HierarchyChannels channels = needed_channels(meshes, materials);
    HierarchyData data;
    data.grid = grid;
    data.world_object = world;
    data.scene_json = std::move(scene_json);
    data.build_json = std::move(build_json);
    for (const ObjectSource& o : objects) {
        pack_object(o, channels, data);
    }
    for (const SceneInstance& instance : instances) {
        data.instances.push_back(
            {HierarchyInstance::pack(instance.transform), instance.object, {}});
    }
    return data;
}

}  // namespace

HierarchyData pack_hierarchy(const SceneHierarchy& hierarchy,
                             const std::vector<Material>& materials, std::string scene_json,
                             std::string build_json) {
    std::vector<ObjectSource> objects;
    for (const SceneObject& o : hierarchy.objects) {
        objects.push_back({&o.tree, o.kind == SceneObject::Kind::Mesh ? o.mesh : nullptr});
    }
    return pack_objects(objects, hierarchy.instances, hierarchy.world, hierarchy.options.grid,
                        materials, std::move(scene_json), std::move(build_json));
}

HierarchyData pack_hierarchy(const PointOctree& octree, const Mesh& mesh,
                             const std::vector<Material>& materials, std::string build_json) {
    const ObjectSource object{&octree, &mesh};
    return pack_objects(std::span(&object, 1), {}, 0, octree.options.grid, materials, "{}",
                        std::move(build_json));
}

}  // namespace mrt
