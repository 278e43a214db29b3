#include "common/scene_io/hierarchy_scene.h"

#include "common/math/quantization.h"
#include "common/scene_io/scene_record.h"

#include <fmt/format.h>

#include <optional>

namespace mrt {

Scene scene_from_hierarchy(const HierarchyFile& file, const std::filesystem::path& path,
                           const Budgets& budgets) {
    Scene scene = load_scene_record(file.scene_json(), path, budgets);
    file.check_materials(static_cast<std::uint32_t>(scene.materials.size()));
    scene.groups.clear();
    const std::span<const HierarchyObject> objects = file.objects();
    // Each object's index among the scene's meshes or groups; the reader guarantees that an
    // instance refers to an object listed before its group, so one pass in order suffices.
    std::vector<std::uint32_t> index(objects.size(), 0);
    for (std::size_t o = 0; o < objects.size(); ++o) {
        const HierarchyObject& object = objects[o];
        if (object.kind == HierarchyObjectKind::Mesh) {
            Mesh mesh;
            mesh.name = fmt::format("{} object {}", path.filename().string(), o);
            const bool uvs = !file.vertex_uvs().empty();
            for (std::uint32_t v = object.first_vertex;
                 v < object.first_vertex + object.vertex_count; ++v) {
                const auto& p = file.vertex_positions()[v];
                mesh.positions.emplace_back(p[0], p[1], p[2]);
                mesh.normals.push_back(decode_normal(file.vertex_normals()[v]));
                if (uvs) {
                    mesh.uvs.emplace_back(file.vertex_uvs()[v][0], file.vertex_uvs()[v][1]);
                }
            }
            for (std::uint32_t t = object.first_triangle;
                 t < object.first_triangle + object.triangle_count; ++t) {
                const auto& tri = file.triangles()[t];
                mesh.triangles.push_back({tri[0] - object.first_vertex,
                                          tri[1] - object.first_vertex,
                                          tri[2] - object.first_vertex});
                mesh.materials.push_back(file.triangle_materials()[t]);
            }
            index[o] = static_cast<std::uint32_t>(scene.meshes.size());
            scene.meshes.push_back(std::move(mesh));
            continue;
        }
        Group group;
        group.name = fmt::format("object {}", o);
        for (std::uint32_t n = object.first_node; n < object.first_node + object.node_count; ++n) {
            const HierarchyNode& node = file.nodes()[n];
            for (std::uint32_t i = node.first_instance;
                 i < node.first_instance + node.instance_count; ++i) {
                const HierarchyInstance& instance = file.instances()[i];
                Instance child;
                child.kind = objects[instance.object].kind == HierarchyObjectKind::Mesh
                                 ? Instance::Kind::Mesh
                                 : Instance::Kind::Group;
                child.index = index[instance.object];
                child.transform = instance.affine();
                group.children.push_back(child);
            }
        }
        index[o] = static_cast<std::uint32_t>(scene.groups.size());
        scene.groups.push_back(std::move(group));
    }
    // The channels the writer would have written for this scene must all be there: a mirror
    // whose file lost its reflectivity would otherwise render as a matt surface.
    std::vector<const Mesh*> meshes;
    for (const Mesh& mesh : scene.meshes) {
        meshes.push_back(&mesh);
    }
    file.check_channels(needed_channels(meshes, scene.materials));
    const HierarchyObject& world = objects[file.world_object()];
    if (world.kind == HierarchyObjectKind::Group) {
        scene.root = index[file.world_object()];
    } else {
        // A flattened file: its one mesh is the world.
        Group root;
        root.name = "world";
        root.children.push_back(
            {Instance::Kind::Mesh, index[file.world_object()], Affine3f::Identity()});
        scene.root = static_cast<std::uint32_t>(scene.groups.size());
        scene.groups.push_back(std::move(root));
    }
    return scene;
}

}  // namespace mrt
