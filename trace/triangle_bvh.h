#pragma once
// Binned-SAH BVH over the triangles of one mesh, in the mesh's object space. Flat arrays of
// compact nodes; leaves reference a contiguous run of triangles stored in leaf order with their
// vertices inline (no indirection in the hot loop).

#include "common/mesh.h"
#include "common/ray.h"

#include <cstdint>
#include <vector>

namespace mrt {

/// 32-byte node: bounds, and either the index of the second child (the first child follows the
/// node) for an inner node, or the first triangle of a leaf.
struct alignas(32) BvhNode {
    float lower[3];
    std::uint32_t offset;  ///< Inner: index of the second child; leaf: first triangle (leaf order).
    float upper[3];
    std::uint16_t count;   ///< Triangles in the leaf; 0 for an inner node.
    std::uint16_t axis;    ///< Split axis of an inner node (for front-to-back traversal).
};
static_assert(sizeof(BvhNode) == 32);

/// Nearest triangle hit in object space.
struct TriangleHit {
    float t = kInfinity;
    std::uint32_t triangle = 0;  ///< Index into the mesh's triangle list.
    float b1 = 0.0f, b2 = 0.0f;
};

class TriangleBvh {
public:
    TriangleBvh() = default;
    explicit TriangleBvh(const Mesh& mesh);

    /// Updates `hit` if a triangle is hit with t in (0, min(ray.t_max, hit.t)).
    bool intersect(const Ray& ray, TriangleHit& hit) const;
    /// Any hit with t in (0, ray.t_max).
    bool occluded(const Ray& ray) const;

    Eigen::AlignedBox3f bounds() const;
    const std::vector<BvhNode>& nodes() const { return m_nodes; }
    std::size_t bytes() const;

private:
    struct LeafTriangle {
        Vec3f v0, v1, v2;
        std::uint32_t index;
    };
    std::vector<BvhNode> m_nodes;
    std::vector<LeafTriangle> m_triangles;
};

}  // namespace mrt
