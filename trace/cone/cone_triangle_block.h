#pragma once
// The vertices of one triangle cluster's members in structure-of-arrays form, and the triangle
// loop's cheap rejections (wholly before or after the cone's depths; wholly beyond the cull's
// square on one side) for all of them at once. Before, each triangle whose bounding sphere
// passed was rejected one at a time after its indices and vertices had been gathered from the
// file and placed in the ray's frame: most of the triangles a cone's clusters let through
// (default scene: 14 of 27 for a secondary cone; the complex scene: 51 of 85 for a primary).
//
// The kernel (trace/cone/cone_block_simd.cpp) evaluates TriangleInRayFrame's placement and map
// in their order without fused multiply-adds, and rejects a triangle only where every vertex
// compares beyond the same bound, which a NaN never does: where it rejects, triangle_culled,
// the traversal's own test of one triangle, rejects too. The traversal runs that test again on
// what the kernel keeps, so the images do not depend on the kernel.

#include "trace/cone/cone_bound_block.h"
#include "trace/cone/cone_ray.h"
#include "trace/cone/cone_triangle.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>

namespace mrt {

struct alignas(64) ConeTriangleBlock {
    /// Coordinate a (x, y, z) of vertex i of member k: position[3·i + a][k].
    std::array<std::array<float, kConeClusterSize>, 9> position{};

    std::array<Vec3f, 3> vertices(std::uint32_t k) const {
        std::array<Vec3f, 3> p;
        for (std::size_t i = 0; i < 3; ++i) {
            p[i] = Vec3f(position[3 * i][k], position[3 * i + 1][k], position[3 * i + 2][k]);
        }
        return p;
    }
    void set(std::uint32_t k, const std::array<Vec3f, 3>& p) {
        for (std::size_t i = 0; i < 3; ++i) {
            for (Eigen::Index a = 0; a < 3; ++a) {
                position[3 * i + static_cast<std::size_t>(a)][k] = p[i][a];
            }
        }
    }
};
static_assert(sizeof(ConeTriangleBlock) == 9 * 4 * kConeClusterSize);

/// What a triangle must reach to be weighed: the cone's depths, and the square |y_x|, |y_y| ≤
/// reach of `frame`'s units (the per-vertex cull; an infinite reach has no square).
struct TriangleCull {
    float t_min = 0.0f;
    float t_max = std::numeric_limits<float>::infinity();
    GaussianFrame frame;
    float reach = std::numeric_limits<float>::infinity();
};

/// Whether the triangle placed as `in_ray`, mapped as `mapped` into cull.frame, lies wholly
/// before t_min or after t_max, or wholly beyond the square on one side (misses_square): the
/// traversal's test of one triangle. A NaN vertex never makes it reject by itself (the minima and
/// maxima take std::min's and std::max's choice of operand).
inline bool triangle_culled(const TriangleInRayFrame& in_ray,
                            const TriangleInRayFrame::Mapped& mapped, const TriangleCull& cull) {
    return std::max({in_ray.t[0], in_ray.t[1], in_ray.t[2]}) < cull.t_min ||
           std::min({in_ray.t[0], in_ray.t[1], in_ray.t[2]}) > cull.t_max ||
           misses_square(mapped.points(), cull.reach);
}

/// Bit k of `candidates` kept where member k of `block` may pass triangle_culled: cleared only
/// where that test rejects it (every vertex before t_min, after t_max, or beyond one side of the
/// square). The SIMD kernel, dispatched at run time.
std::uint32_t triangles_within_cull(const ConeTriangleBlock& block, std::uint32_t candidates,
                                    const ConeRay& ray, const TriangleCull& cull);

/// triangles_within_cull one triangle at a time, through triangle_culled itself: the reference.
inline std::uint32_t triangles_within_cull_scalar(const ConeTriangleBlock& block,
                                                  std::uint32_t candidates, const ConeRay& ray,
                                                  const TriangleCull& cull) {
    std::uint32_t kept = 0;
    for (std::uint32_t bits = candidates; bits != 0; bits &= bits - 1) {
        const auto k = static_cast<std::uint32_t>(std::countr_zero(bits));
        const TriangleInRayFrame in_ray(ray, block.vertices(k));
        if (!triangle_culled(in_ray, in_ray.map(cull.frame), cull)) {
            kept |= 1u << k;
        }
    }
    return kept;
}

}  // namespace mrt
