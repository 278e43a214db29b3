#pragma once
// What the recursive builders of the mesh octrees and the instance trees share: the node under
// construction, the cube of a box, and the breadth-first layout the hierarchy file stores.

#include "common/math/math.h"
#include "preprocess/octree/point_octree.h"

#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace mrt {

/// A node while its tree is being built: the node and its (up to eight) subtrees.
struct OctreeBuildNode {
    OctreeNode node;
    std::array<std::unique_ptr<OctreeBuildNode>, 8> children;
};

/// The largest magnitude of a node cube's coordinates. The hierarchy stores cubes, bounding
/// spheres and vertices in single precision (up to 3.4e38), and a bounding sphere reaches √3/2
/// of a side beyond its centre: with corners within ±1e38 every such sum stays finite.
inline constexpr double kMaxCubeCoordinate = 1e38;

/// The smallest cube, centred on `box`, that holds it with a small margin so that no sample
/// lands exactly on the far faces: (minimum corner, side). Computed in double: the box's
/// extent may be beyond single precision even when its corners are not; check cube_fits first.
std::pair<Vec3f, float> bounding_cube(const Eigen::AlignedBox3d& box);

/// Whether `box` is finite and its bounding cube's corners lie within ±kMaxCubeCoordinate.
bool cube_fits(const Eigen::AlignedBox3d& box);

/// Why `box` does not fit, for a refusal: "it spans [a, b] along x, …".
std::string cube_overflow(const Eigen::AlignedBox3d& box);

/// Sets node.sphere_centre and sphere_radius from node.bounds (in double: the box's diagonal
/// overflows single precision before its corners do).
void set_bounding_sphere(OctreeNode& node);

/// The tree's nodes breadth-first, children in slot order: a layout fixed by the tree, not by
/// the schedule that built it. Child indices are set; the build nodes are consumed.
std::vector<OctreeNode> breadth_first(std::unique_ptr<OctreeBuildNode> root);

}  // namespace mrt
