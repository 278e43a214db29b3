#include "trace/cone/meshes_below.h"

#include "common/system/check.h"

#include <algorithm>
#include <iterator>

namespace mrt {

MeshesBelow::MeshesBelow(const HierarchyView& view) : m_meshes(view.objects.size()) {
    // An instance's object is listed before the group that holds it: one pass in order.
    for (std::size_t o = 0; o < view.objects.size(); ++o) {
        const HierarchyObject& object = view.objects[o];
        std::vector<std::uint32_t>& meshes = m_meshes[o];
        if (object.kind == HierarchyObjectKind::Mesh) {
            meshes.push_back(static_cast<std::uint32_t>(o));
            continue;
        }
        for (std::uint32_t n = object.first_node; n < object.first_node + object.node_count; ++n) {
            const HierarchyNode& node = view.nodes[n];
            for (std::uint32_t i = node.first_instance;
                 i < node.first_instance + node.instance_count; ++i) {
                const std::uint32_t held = view.instances[i].object;
                MRT_CHECK(held < o);
                meshes.insert(meshes.end(), m_meshes[held].begin(), m_meshes[held].end());
            }
        }
        std::sort(meshes.begin(), meshes.end());
        meshes.erase(std::unique(meshes.begin(), meshes.end()), meshes.end());
    }
}

bool MeshesBelow::holds(std::uint32_t object, std::uint32_t mesh) const {
    const std::vector<std::uint32_t>& meshes = m_meshes[object];
    return std::binary_search(meshes.begin(), meshes.end(), mesh);
}

}  // namespace mrt
