#pragma once
// Binned SAH construction of a binary BVH over axis-aligned boxes, shared by the per-mesh
// triangle BVHs and the per-group instance BVHs. Binning after Wald 2007, "On fast Construction
// of SAH-based Bounding Volume Hierarchies" (IEEE/EG Symposium on Interactive Ray Tracing):
// primitives are sorted into equal-width bins over their centroid bounds and only the bin
// boundaries are evaluated as split candidates, which makes each level O(n).

#include <Eigen/Geometry>

#include <cstdint>
#include <span>
#include <vector>

namespace mrt {

/// Deepest path (root = depth 0) the builder produces, so traversal stacks of this many entries
/// never overflow: below kBvhSahDepth the builder stops evaluating SAH and splits at the object
/// median, which halves the primitive count per level (2^32 primitives fit).
inline constexpr int kBvhMaxDepth = 64;
inline constexpr int kBvhSahDepth = kBvhMaxDepth - 33;

/// 32-byte binary node: bounds, and either the index of the second child (the first child
/// follows the node) for an inner node, or the first primitive of a leaf.
struct alignas(32) BinaryBvhNode {
    float lower[3];
    std::uint32_t
        offset;  ///< Inner: index of the second child; leaf: first primitive (leaf order).
    float upper[3];
    std::uint16_t count;  ///< Primitives in the leaf; 0 for an inner node.
    std::uint16_t axis;   ///< Split axis of an inner node (for front-to-back traversal).
};
static_assert(sizeof(BinaryBvhNode) == 32);

struct BvhBuildOptions {
    /// Leaves hold at most this many primitives (≤ 65535, the node's count field).
    std::uint32_t max_leaf_size = 8;
    /// Leaf cost is charged per block of this many primitives (the SIMD width of the leaf
    /// kernel: a leaf of 5 triangles costs as much as one of 8).
    std::uint32_t leaf_block = 1;
    /// SAH cost of visiting an inner node, relative to intersecting one block.
    float traversal_cost = 1.0f;
    float intersection_cost = 1.0f;
};

struct BvhBuildResult {
    /// Depth-first: the first child directly follows its parent, `offset` of an inner node is
    /// the second child; a leaf's `offset` indexes primitive_order.
    std::vector<BinaryBvhNode> nodes;
    /// Input indices in leaf order.
    std::vector<std::uint32_t> primitive_order;
};

/// Builds the BVH of `boxes` (all non-empty and finite). Parallel over subtrees with oneTBB;
/// the tree depends only on the input, never on the thread count or schedule.
BvhBuildResult build_bvh(std::span<const Eigen::AlignedBox3f> boxes,
                         const BvhBuildOptions& options);

}  // namespace mrt
