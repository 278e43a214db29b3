#pragma once
// The bounding spheres of one cluster's members (a node's kept triangles, kConeClusterSize at
// most) in structure-of-arrays form, tested against a cone all at once: a fixed trip count over
// flat arrays and no branches, which the compiler turns into SIMD (four or eight spheres per
// instruction), where one sphere at a time cost a projection and three branches each.

#include "trace/cone/cone_ray.h"

#include <algorithm>
#include <array>
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

/// Bit k (k < count, the block's spheres in use) set when sphere k of `block` may hold something
/// within `reach` of `ray`'s axis between t_min and t_max: its depths overlap them and its centre
/// lies within reach + radius of the axis. Conservative for non-finite input (a NaN never clears
/// a bit of a sphere in use), as one sphere's test is.
inline std::uint32_t spheres_near_axis(const ConeBoundBlock& block, std::uint32_t count,
                                       const ConeRay& ray, float reach, float t_min, float t_max) {
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
        inside[k] = (before | after | beside) ? 0u : 1u;
    }
    std::uint32_t mask = 0;
    for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
        mask |= inside[k] << k;
    }
    static_assert(kConeClusterSize < 32);
    return mask & ((1u << std::min(count, kConeClusterSize)) - 1u);
}

}  // namespace mrt
