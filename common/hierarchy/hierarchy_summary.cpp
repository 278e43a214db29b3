#include "common/hierarchy/hierarchy_summary.h"

#include <fmt/format.h>

#include <array>
#include <cstdint>
#include <map>
#include <utility>

namespace mrt {

std::string hierarchy_summary(const HierarchyFile& file, const std::string& indent) {
    std::string out;
    std::size_t mesh_objects = 0;
    for (const HierarchyObject& o : file.objects()) {
        mesh_objects += o.kind == HierarchyObjectKind::Mesh ? 1 : 0;
    }
    out += fmt::format(
        "{}grid {}³, {} mesh and {} group objects (world: object {}), {} "
        "instances, {} nodes, {} points, {} triangles, {} vertices\n",
        indent, file.grid(), mesh_objects, file.objects().size() - mesh_objects,
        file.world_object(), file.instances().size(), file.nodes().size(), file.core().size(),
        file.triangles().size(), file.vertex_positions().size());
    out += fmt::format("{}channels: position offset normal coverage diffuse", indent);
    if (!file.specular().empty()) {
        out += " specular";
    }
    if (!file.mirror().empty()) {
        out += " reflectivity roughness normal-gradient";
    }
    if (!file.refraction().empty()) {
        out += " transparency ior";
    }
    if (!file.emission().empty()) {
        out += " emission";
    }
    if (!file.opacity().empty()) {
        out += " opacity";
    }
    if (!file.vertex_uvs().empty()) {
        out += " uv";
    }
    out += '\n';
    // (group?, level) → nodes, points, triangles or instances
    std::map<std::pair<bool, int>, std::array<std::uint64_t, 3>> levels;
    for (const HierarchyObject& o : file.objects()) {
        const bool group = o.kind == HierarchyObjectKind::Group;
        for (std::uint32_t n = o.first_node; n < o.first_node + o.node_count; ++n) {
            const HierarchyNode& node = file.nodes()[n];
            auto& level = levels[{group, node.level}];
            level[0] += 1;
            level[1] += node.point_count;
            level[2] += group ? node.instance_count : node.triangle_count;
        }
    }
    out += fmt::format("{}objects level     nodes     points  triangles/instances\n", indent);
    for (const auto& [key, counts] : levels) {
        out +=
            fmt::format("{}{:7} {:5} {:9} {:10} {:10}\n", indent, key.first ? "groups" : "meshes",
                        key.second, counts[0], counts[1], counts[2]);
    }
    out += fmt::format("{}section      bytes\n", indent);
    for (const SectionInfo& section : file.sections().sections()) {
        out += fmt::format("{}{:7} {:10}\n", indent, fmt::format("'{}'", tag_name(section.tag)),
                           section.size);
    }
    return out;
}

}  // namespace mrt
