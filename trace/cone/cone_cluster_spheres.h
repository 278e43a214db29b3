#pragma once
// The bounding spheres of all point or all triangle clusters (ConeCluster), in
// structure-of-arrays form. A node's clusters are consecutive, so a cone tests up to
// kConeClusterSize of them with one SIMD kernel (trace/cone/cone_block_simd.cpp) before it
// reads any cluster's record. One at a time, placing each centre in the ray's frame and testing
// it was the largest single item of the complex scene's instruction profile (a node visited
// holds a few clusters; two thirds of them lie beside the cone).
//
// Like the other block tests (cone_bound_block.h) the test has two forms: the unsuffixed kernel,
// dispatched at run time, and the `_scalar` reference, one sphere at a time through
// sphere_may_hold, which is the traversal's own test of a single cluster. Both evaluate the same
// expressions in the same order without fused multiply-adds, so they agree bit for bit and the
// traversal keeps the clusters it kept when it tested them one by one.

#include "trace/cone/cone_bound_block.h"
#include "trace/cone/cone_ray.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

namespace mrt {

/// Whether a bounding sphere (centre, radius) may hold something within `reach` of `ray`'s axis
/// between t_min and t_max: its depths overlap them and its centre lies within reach + radius of
/// the axis. `centre_in_ray` receives the centre in the ray's frame. A NaN passes.
inline bool sphere_may_hold(const ConeRay& ray, const Vec3f& centre, float radius, float reach,
                            float t_min, float t_max, VertexInRayFrame& centre_in_ray) {
    centre_in_ray = ray.frame_of(centre);
    if (centre_in_ray.t + radius < t_min || centre_in_ray.t - radius > t_max) {
        return false;
    }
    const float within = reach + radius;
    return !(centre_in_ray.offset.squaredNorm() > within * within);
}

struct ConeClusterSpheres {
    std::vector<float> x;
    std::vector<float> y;
    std::vector<float> z;
    /// Followed by kConeClusterSize unused entries of radius −∞ (no depth range holds them), so
    /// that a block read from a node's last clusters stays within the arrays.
    std::vector<float> radius;

    ConeClusterSpheres() : ConeClusterSpheres(std::vector<Sphere>{}) {}

    /// From anything with `centre` (three floats) and `radius` members, in order.
    template <class Clusters>
    explicit ConeClusterSpheres(const Clusters& clusters) {
        const std::size_t size = clusters.size() + kConeClusterSize;
        x.reserve(size);
        y.reserve(size);
        z.reserve(size);
        radius.reserve(size);
        for (const auto& c : clusters) {
            x.push_back(c.centre[0]);
            y.push_back(c.centre[1]);
            z.push_back(c.centre[2]);
            radius.push_back(c.radius);
        }
        x.resize(size, 0.0f);
        y.resize(size, 0.0f);
        z.resize(size, 0.0f);
        radius.resize(size, -std::numeric_limits<float>::infinity());
    }

    /// Spheres in use (without the padding).
    std::size_t size() const { return radius.size() - kConeClusterSize; }

  private:
    struct Sphere {
        std::array<float, 3> centre;
        float radius;
    };
};

/// Bit k (k < count ≤ kConeClusterSize) set when sphere `first + k` may hold something within
/// `reach` of `ray`'s axis between t_min and t_max, as sphere_may_hold answers. The SIMD kernel,
/// dispatched at run time.
std::uint32_t clusters_near_axis(const ConeClusterSpheres& spheres, std::uint32_t first,
                                 std::uint32_t count, const ConeRay& ray, float reach, float t_min,
                                 float t_max);

/// clusters_near_axis one sphere at a time: the reference.
inline std::uint32_t clusters_near_axis_scalar(const ConeClusterSpheres& spheres,
                                               std::uint32_t first, std::uint32_t count,
                                               const ConeRay& ray, float reach, float t_min,
                                               float t_max) {
    std::uint32_t mask = 0;
    for (std::uint32_t k = 0; k < std::min(count, kConeClusterSize); ++k) {
        const std::size_t i = first + k;
        VertexInRayFrame centre;
        if (sphere_may_hold(ray, Vec3f(spheres.x[i], spheres.y[i], spheres.z[i]), spheres.radius[i],
                            reach, t_min, t_max, centre)) {
            mask |= 1u << k;
        }
    }
    return mask;
}

}  // namespace mrt
