#pragma once
// Binned-SAH BVH over the triangles of one mesh, in the mesh's object space. Flat arrays of
// compact nodes; leaves reference a contiguous run of triangles stored in leaf order with their
// vertices inline (no indirection in the hot loop). Traversal is ordered front to back by entry
// distance, with a fixed stack; triangles are tested four at a time with the watertight test of
// trace/bvh/triangle_intersect.h.

#include "common/math/ray.h"
#include "common/mesh/mesh.h"

#include <cstdint>
#include <vector>

namespace mrt {

class MeshCutout;

/// 4-wide node: the boxes of up to four children as structure of arrays, so one SSE slab test
/// checks all four (Dammertz, Hanika & Keller 2008, "Shallow Bounding Volume Hierarchies for
/// Fast SIMD Ray Tracing of Incoherent Rays"; Ernst & Greiner 2008, "Multi Bounding Volume
/// Hierarchies"). The binned-SAH binary tree (32-byte nodes, see trace/bvh/bvh_build.h) is
/// collapsed into these: half the depth, hence half the dependent node fetches and branches per
/// ray. Nodes are in depth-first order: a node's first inner child directly follows it.
struct alignas(64) BvhNode {
    /// Per child lane: lower x, upper x, lower y, upper y, lower z, upper z. Unused lanes hold an
    /// empty box (lower +inf, upper −inf) that no ray enters.
    float bounds[6][4];
    /// Inner child: index of its node; leaf child: its first triangle packet (four triangles
    /// each, leaf order).
    std::uint32_t child[4];
    std::uint16_t count[4];  ///< Triangles of a leaf child; 0 for an inner child or unused lane.
    std::uint32_t reserved[2];
};
static_assert(sizeof(BvhNode) == 128, "two cache lines");

/// Nearest triangle hit in object space. Hits at exactly equal t resolve to the lowest triangle
/// index, so the result does not depend on the tree or the traversal order.
struct TriangleHit {
    float t = kInfinity;
    std::uint32_t triangle = 0;  ///< Index into the mesh's triangle list.
    float b1 = 0.0f, b2 = 0.0f;
};

class TriangleBvh {
  public:
    TriangleBvh() = default;
    explicit TriangleBvh(const Mesh& mesh);

    /// Updates `hit` if a triangle is hit with t in (0, min(ray.t_max, hit.t)), or at exactly
    /// hit.t (< ray.t_max) by a triangle of lower index than hit.triangle. Rays with a
    /// non-finite origin or direction hit nothing.
    /// With a `cutout`, only hits it lets stand count (trace/bvh/cutouts.h).
    bool intersect(const Ray& ray, TriangleHit& hit, const MeshCutout* cutout = nullptr) const;
    /// Any hit with t in (0, ray.t_max) (that `cutout` lets stand).
    bool occluded(const Ray& ray, const MeshCutout* cutout = nullptr) const;

    Eigen::AlignedBox3f bounds() const;
    /// Empty for an empty mesh; otherwise nodes()[0] is the root.
    const std::vector<BvhNode>& nodes() const { return m_nodes; }
    std::size_t bytes() const;

  private:
    /// Four triangles of a leaf as structure of arrays, v[vertex][axis][lane], for the 4-wide
    /// leaf kernel. A leaf whose size is not a multiple of 4 is padded with copies of its last
    /// triangle: a copy hits at the same t with the same index, so it never changes a result.
    struct alignas(16) TrianglePacket {
        float v[3][3][4];
        std::uint32_t index[4];
    };
    static_assert(sizeof(TrianglePacket) == 160);

    template <bool kAnyHit, bool kCutout>
    bool traverse(const Ray& ray, TriangleHit& hit, const MeshCutout* cutout) const;

    std::vector<BvhNode> m_nodes;           ///< Depth-first; m_nodes[0] is the root.
    std::vector<TrianglePacket> m_packets;  ///< Leaf order.
    Eigen::AlignedBox3f m_bounds;           ///< Of all triangles (empty for an empty mesh).
};

}  // namespace mrt
