#pragma once
// The bounding spheres of one cluster's members (a node's kept triangles, kConeClusterSize at
// most), the voxels of its points, and a node's children's bounding spheres, in
// structure-of-arrays form, tested against a cone all at once: a fixed trip count over flat arrays
// and no branches, where one sphere at a time cost a projection and three branches each.
//
// Each test has two forms. The unsuffixed one, which the traversal calls, runs the Highway
// kernels of trace/cone/cone_block_simd.cpp, compiled for AVX-512, AVX2, SSE4 (and a one-lane
// fallback) and dispatched at run time to the best the CPU has: sixteen spheres in one or two
// instructions per step, where the compiler's vectorisation of a loop is held to the SSE2 of a
// portable x86-64 build. The `_scalar` one, one member at a time, is the reference the tests
// compare them with. Both evaluate the same expressions in the same order without fused
// multiply-adds, so they agree bit for bit (unless MRT_NATIVE lets the compiler fuse the
// reference's).

#include "trace/cone/cone_bounds.h"
#include "trace/cone/cone_ray.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

namespace mrt {

/// Members per cluster: a node keeps hundreds of points and up to hundreds of triangles, cut into
/// runs this long that a cone skips together.
inline constexpr std::uint32_t kConeClusterSize = 16;

struct alignas(64) ConeBoundBlock {
    std::array<float, kConeClusterSize> x{};
    std::array<float, kConeClusterSize> y{};
    std::array<float, kConeClusterSize> z{};
    /// Unused slots have radius −∞: no depth range holds them (and their bits are cleared).
    std::array<float, kConeClusterSize> radius;

    ConeBoundBlock() { radius.fill(-std::numeric_limits<float>::infinity()); }
};
static_assert(sizeof(ConeBoundBlock) == 4 * 4 * kConeClusterSize);

/// The square a triangle's cull keeps in a Gaussian frame's units (the traversal's per-vertex
/// cull: |y_x|, |y_y| ≤ reach for the vertices y mapped by GaussianFrame::map), as a test of
/// the triangles' bounding spheres. `m` is the frame's map, the symmetric U·Λ^(−1/2)·Uᵀ from the
/// ray's u/v offsets, and `stretch` at least its norm ‖m‖₂: a sphere of radius r around c maps
/// within stretch·r of m·c along either axis, so where m·c lies farther than reach + stretch·r
/// beyond the square on one side, so do the triangle's vertices, and the cull would reject it.
/// The default keeps everything.
struct GaussianSquare {
    float m00 = 0.0f;
    float m01 = 0.0f;
    float m11 = 0.0f;
    float reach = std::numeric_limits<float>::infinity();
    float stretch = 0.0f;
};

/// Relative rounding allowed for, times the stretched size of a sphere's place in the ray's frame
/// (|t| + |a| + |b| + r): the block maps a sphere's centre with the entries of m, the cull maps
/// the vertices axis by axis (GaussianFrame::map), and their rounding differs by a few ulps of
/// the coordinates they map, so a sphere is rejected only where it lies that much beyond.
inline constexpr float kGaussianSquareRounding = 1.0f / 16384.0f;

/// Bit k (k < count, the block's spheres in use) set when sphere k of `block` may hold something
/// within `reach` of `ray`'s axis between t_min and t_max: its depths overlap them, its centre
/// lies within reach + radius of the axis, and it reaches into `square` (GaussianSquare).
/// Conservative for non-finite input (a NaN never clears a bit of a sphere in use), as one
/// sphere's test is. The SIMD kernel, dispatched at run time.
std::uint32_t spheres_near_axis(const ConeBoundBlock& block, std::uint32_t count,
                                const ConeRay& ray, float reach, float t_min, float t_max,
                                const GaussianSquare& square = {});

/// spheres_near_axis one sphere at a time: the reference.
inline std::uint32_t spheres_near_axis_scalar(const ConeBoundBlock& block, std::uint32_t count,
                                              const ConeRay& ray, float reach, float t_min,
                                              float t_max, const GaussianSquare& square = {}) {
    const Vec3f& o = ray.origin;
    const Vec3f& d = ray.direction;
    const Vec3f& u = ray.cone.u;
    const Vec3f& v = ray.cone.v;
    std::array<std::uint32_t, kConeClusterSize> inside;
    for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
        const float px = block.x[k] - o.x();
        const float py = block.y[k] - o.y();
        const float pz = block.z[k] - o.z();
        const float t = px * d.x() + py * d.y() + pz * d.z();
        const float a = px * u.x() + py * u.y() + pz * u.z();
        const float b = px * v.x() + py * v.y() + pz * v.z();
        const float r = block.radius[k];
        const float within = reach + r;
        const bool before = t + r < t_min;
        const bool after = t - r > t_max;
        const bool beside = a * a + b * b > within * within;
        const float gx = square.m00 * a + square.m01 * b;
        const float gy = square.m01 * a + square.m11 * b;
        const float size = std::abs(t) + std::abs(a) + std::abs(b) + r;
        const float slack =
            square.reach + square.stretch * r + kGaussianSquareRounding * square.stretch * size;
        const bool outside_square = std::abs(gx) > slack || std::abs(gy) > slack;
        inside[k] = (before | after | beside | outside_square) ? 0u : 1u;
    }
    std::uint32_t mask = 0;
    for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
        mask |= inside[k] << k;
    }
    static_assert(kConeClusterSize < 32);
    return mask & ((1u << std::min(count, kConeClusterSize)) - 1u);
}

/// The voxel codes, surface offsets and normal codes (PointCore::voxel, PointOffset::along_normal,
/// PointCore::normal) of one point cluster's points, in structure-of-arrays form: what a cone needs
/// to reject most of them, and to place and weigh the rest (cone_point_lanes.h), before it reads
/// their records.
struct alignas(64) ConeVoxelBlock {
    std::array<std::uint8_t, kConeClusterSize> x{};
    std::array<std::uint8_t, kConeClusterSize> y{};
    std::array<std::uint8_t, kConeClusterSize> z{};
    std::array<std::int8_t, kConeClusterSize> offset{};
    std::array<std::uint16_t, kConeClusterSize> normal_u{};
    std::array<std::uint16_t, kConeClusterSize> normal_v{};
};
static_assert(sizeof(ConeVoxelBlock) == 8 * kConeClusterSize);

/// Where a node's voxel centres lie in the point weight's Gaussian coordinates (G⁻¹ times the
/// offset from the cone's axis), affine in the voxel's indices.
struct VoxelGaussian {
    Vec2f first = Vec2f::Zero();  ///< The centre of voxel (0, 0, 0).
    std::array<Vec2f, 3> step{};  ///< One voxel along x, y, z.
    float clip = 0.0f;            ///< The radius a point's weight is cut at.
    float offset_stretch = 0.0f;  ///< Per step of an offset's code: its reach.
};

/// Bit k (k < count) set when point k of `block` may lie within the clip: its voxel centre lies
/// within `clip` plus how far its offset along the normal can move it (`offset_stretch` per step
/// of its code). A NaN centre clears its bit, as the point's own weight would be 0. The SIMD
/// kernel, dispatched at run time.
std::uint32_t voxels_within_clip(const ConeVoxelBlock& block, std::uint32_t count,
                                 const VoxelGaussian& voxels);

/// voxels_within_clip one point at a time: the reference.
inline std::uint32_t voxels_within_clip_scalar(const ConeVoxelBlock& block, std::uint32_t count,
                                               const VoxelGaussian& voxels) {
    std::array<std::uint32_t, kConeClusterSize> inside;
    for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
        const float i = static_cast<float>(block.x[k]);
        const float j = static_cast<float>(block.y[k]);
        const float l = static_cast<float>(block.z[k]);
        const float gx = voxels.first.x() + i * voxels.step[0].x() + j * voxels.step[1].x() +
                         l * voxels.step[2].x();
        const float gy = voxels.first.y() + i * voxels.step[0].y() + j * voxels.step[1].y() +
                         l * voxels.step[2].y();
        const float reach =
            voxels.clip + voxels.offset_stretch * std::abs(static_cast<float>(block.offset[k]));
        inside[k] = gx * gx + gy * gy <= reach * reach ? 1u : 0u;
    }
    std::uint32_t mask = 0;
    for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
        mask |= inside[k] << k;
    }
    return mask & ((1u << std::min(count, kConeClusterSize)) - 1u);
}

/// Children per octree node.
inline constexpr std::uint32_t kConeChildCount = 8;

/// The bounding spheres of one node's children (HierarchyNode::sphere_centre, sphere_radius, in
/// the node's object space) and the radius of each child's points' kernel, in
/// structure-of-arrays form: the traversal's first test of each child (ConeSphereTest::
/// circle_may_touch) eight at a time, with the depths that order them front to back.
struct alignas(32) ConeChildBlock {
    std::array<float, kConeChildCount> x{};
    std::array<float, kConeChildCount> y{};
    std::array<float, kConeChildCount> z{};
    /// Unused slots have radius −∞ (their bits are cleared all the same).
    std::array<float, kConeChildCount> radius;
    /// The child's footprint widening: kPointKernelRadius times its point spacing
    /// (common/footprint/point_weight.h), in object-space units.
    std::array<float, kConeChildCount> widening{};

    ConeChildBlock() { radius.fill(-std::numeric_limits<float>::infinity()); }
};
static_assert(sizeof(ConeChildBlock) == 5 * 4 * kConeChildCount);

/// Bit k (k < count, the children in use) set when child k's sphere, in `ray`'s frame as
/// ConeRay::sphere_of puts it, may touch the cone between t_min and t_max:
/// test.circle_may_touch(sphere, widening[k], t_min, t_max), so non-finite input sets the bit
/// and a sphere wholly before t_min or after t_max clears it. `nearest[k]` receives the sphere's
/// nearest depth, t − radius (for every k < kConeChildCount; unused slots get +∞), by which the
/// traversal visits the children front to back. The SIMD kernel, dispatched at run time.
std::uint32_t children_near_cone(const ConeChildBlock& block, std::uint32_t count,
                                 const ConeRay& ray, const ConeSphereTest& test, float t_min,
                                 float t_max, std::array<float, kConeChildCount>& nearest);

/// children_near_cone one child at a time, through circle_may_touch itself: the reference.
inline std::uint32_t children_near_cone_scalar(const ConeChildBlock& block, std::uint32_t count,
                                               const ConeRay& ray, const ConeSphereTest& test,
                                               float t_min, float t_max,
                                               std::array<float, kConeChildCount>& nearest) {
    std::uint32_t mask = 0;
    for (std::uint32_t k = 0; k < kConeChildCount; ++k) {
        const SphereInRayFrame sphere =
            ray.sphere_of(Vec3f(block.x[k], block.y[k], block.z[k]), block.radius[k]);
        nearest[k] = sphere.t - sphere.radius;
        if (k < count && test.circle_may_touch(sphere, block.widening[k], t_min, t_max)) {
            mask |= 1u << k;
        }
    }
    return mask;
}

}  // namespace mrt
