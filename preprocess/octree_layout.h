#pragma once
// What the recursive builders of the mesh octrees and the instance trees share: the node under
// construction, the cube of a box, and the breadth-first layout the hierarchy file stores.

#include "common/math.h"
#include "preprocess/point_octree.h"

#include <array>
#include <memory>
#include <utility>
#include <vector>

namespace mrt {

/// A node while its tree is being built: the node and its (up to eight) subtrees.
struct OctreeBuildNode {
    OctreeNode node;
    std::array<std::unique_ptr<OctreeBuildNode>, 8> children;
};

/// The smallest cube, centred on `box`, that holds it with a small margin so that no sample
/// lands exactly on the far faces: (minimum corner, side).
std::pair<Vec3f, float> bounding_cube(const Eigen::AlignedBox3f& box);

/// The tree's nodes breadth-first, children in slot order: a layout fixed by the tree, not by
/// the schedule that built it. Child indices are set; the build nodes are consumed.
std::vector<OctreeNode> breadth_first(std::unique_ptr<OctreeBuildNode> root);

}  // namespace mrt
