#include "preprocess/octree_layout.h"

#include <algorithm>
#include <deque>

namespace mrt {

std::pair<Vec3f, float> bounding_cube(const Eigen::AlignedBox3f& box) {
    const float side = std::max(box.sizes().maxCoeff(), 1e-30f) * (1.0f + 1e-4f) +
                       1e-6f * box.max().cwiseAbs().maxCoeff();
    return {box.center() - Vec3f::Constant(0.5f * side), side};
}

std::vector<OctreeNode> breadth_first(std::unique_ptr<OctreeBuildNode> root) {
    std::vector<OctreeNode> nodes;
    std::deque<std::pair<OctreeBuildNode*, std::int32_t>> queue;  // node, parent slot to patch
    queue.emplace_back(root.get(), -1);
    while (!queue.empty()) {
        auto [build_node, parent_and_slot] = queue.front();
        queue.pop_front();
        const auto index = static_cast<std::int32_t>(nodes.size());
        if (parent_and_slot >= 0) {
            nodes[static_cast<std::size_t>(parent_and_slot / 8)]
                .children[static_cast<std::size_t>(parent_and_slot % 8)] = index;
        }
        nodes.push_back(std::move(build_node->node));
        nodes.back().children.fill(-1);
        for (int c = 0; c < 8; ++c) {
            if (build_node->children[static_cast<std::size_t>(c)]) {
                queue.emplace_back(build_node->children[static_cast<std::size_t>(c)].get(),
                                   index * 8 + c);
            }
        }
    }
    return nodes;
}

}  // namespace mrt
