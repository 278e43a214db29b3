#include "preprocess/octree/octree_layout.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <deque>

namespace mrt {

namespace {

/// (minimum corner, side) of the cube of `box`, in double.
std::pair<Vec3d, double> cube_of(const Eigen::AlignedBox3d& box) {
    const double side = std::max(box.sizes().maxCoeff(), 1e-30) * (1.0 + 1e-4) +
                        1e-6 * box.max().cwiseAbs().maxCoeff();
    return {box.center() - Vec3d::Constant(0.5 * side), side};
}

}  // namespace

std::pair<Vec3f, float> bounding_cube(const Eigen::AlignedBox3d& box) {
    const auto [origin, side] = cube_of(box);
    return {origin.cast<float>(), static_cast<float>(side)};
}

bool cube_fits(const Eigen::AlignedBox3d& box) {
    if (!box.min().allFinite() || !box.max().allFinite() || box.isEmpty()) {
        return false;
    }
    const auto [origin, side] = cube_of(box);
    const double reach = std::max(origin.cwiseAbs().maxCoeff(),
                                  (origin + Vec3d::Constant(side)).cwiseAbs().maxCoeff());
    return std::isfinite(side) && reach <= kMaxCubeCoordinate;
}

std::string cube_overflow(const Eigen::AlignedBox3d& box) {
    int axis = 0;
    (box.min().cwiseAbs().cwiseMax(box.max().cwiseAbs()) + box.sizes()).maxCoeff(&axis);
    return fmt::format(
        "it spans [{:.6g}, {:.6g}] along {}, beyond what the point hierarchy's "
        "single-precision node cubes hold (coordinates within ±{:.6g})",
        box.min()[axis], box.max()[axis], "xyz"[axis], kMaxCubeCoordinate);
}

void set_bounding_sphere(OctreeNode& node) {
    const Eigen::AlignedBox3d box = node.bounds.cast<double>();
    node.sphere_centre = box.center().cast<float>();
    node.sphere_radius = static_cast<float>(0.5 * box.sizes().norm());
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
