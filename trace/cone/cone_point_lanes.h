#pragma once
// The arithmetic of weighing one cluster's points against a cone, sixteen at a time: each point's
// normal decoded, its position on the surface placed in the ray's frame, the closed surface's
// back-face test, the test of the surface the cone leaves, the Gaussian's exponent and the depth
// where the axis meets the tangent plane. What is left for one point at a time is what only a
// hit needs: the exponential, the attributes and the A-buffer's insertion.
//
// Two forms, as for the block tests (cone_bound_block.h): `weigh_points` runs a Highway kernel
// (trace/cone/cone_block_simd.cpp) dispatched at run time, `weigh_points_scalar` one point at a
// time is the reference, and calls what the per-point code it replaced called (decode_normal,
// point_weight_exponent, point_depth, is_surface_left, the closed surface's back_facing and
// entered_through; the voxel centre affine in its codes). The kernel evaluates the same
// expressions in the same order, Eigen's three-term sums as x + (y + z), without fused
// multiply-adds: the traversal's images did not change.

#include "common/footprint/point_weight.h"
#include "common/math/math.h"
#include "common/math/quantization.h"
#include "trace/cone/closed_surfaces.h"
#include "trace/cone/cone_bound_block.h"
#include "trace/cone/cone_ray.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>

namespace mrt {

/// What weighing a node's points needs, per cone and node.
struct PointLanesInput {
    /// The centre of voxel (0, 0, 0) in ray coordinates (depth, u, v), and one voxel along
    /// x, y and z (VoxelsInRayFrame).
    std::array<float, 3> first{};
    std::array<std::array<float, 3>, 3> step{};
    Vec3f direction = Vec3f::UnitZ();  ///< The ray's axes.
    Vec3f u = Vec3f::UnitX();
    Vec3f v = Vec3f::UnitY();
    float spacing = 0.0f;           ///< h: an offset code's step is h/127.
    Mat2f inverse = Mat2f::Zero();  ///< G⁻¹ of the point weight's frame.
    float t_min = 0.0f;             ///< The look's depths.
    float t_max = 0.0f;
    /// The closed surface whose back faces the cone cannot see (nullptr: none): back_facing with
    /// the cone's starting radius as margin.
    const ClosedSurface* closed = nullptr;
    float start = 0.0f;  ///< The cone's starting radius.
    /// The test of the surface a cone leaves (a cone with t_min > 0), is_surface_left with the
    /// plane within `coplanar` of the apex, or within the start while the point lies within
    /// `near` of it.
    bool leaving = false;
    float coplanar = 0.0f;
    float near = 0.0f;
    /// The solid a shadow cone may enter through the points (nullptr: none), by more than
    /// `entering_cosine`: a point it enters through is never the surface it leaves.
    const ClosedSurface* entered = nullptr;
    float entering_cosine = 0.0f;
    /// The sign of d·n where the cone starts (ConeTraversal::trace): a point whose n·d has the
    /// other sign faces the cone from beyond its start and is never the surface it leaves.
    float leaving_side = 0.0f;
};

/// The per-point results, lane k for the cluster's point k (meaningful where its hit bit is set).
struct alignas(64) PointLanes {
    std::array<float, kConeClusterSize> nx{};  ///< The decoded unit normal.
    std::array<float, kConeClusterSize> ny{};
    std::array<float, kConeClusterSize> nz{};
    std::array<float, kConeClusterSize> along{};  ///< n·d.
    std::array<float, kConeClusterSize> t{};      ///< Depth where the axis meets the point.
    std::array<float, kConeClusterSize> q{};      ///< |G⁻¹·offset|², the Gaussian's exponent.
    /// The point's offset from the axis along u and v (ConeRay::frame_of of its position): where
    /// its coverage mask's disc lies.
    std::array<float, kConeClusterSize> u{};
    std::array<float, kConeClusterSize> v{};
    std::uint32_t back_faces = 0;  ///< Candidates on a closed surface's back.
};

/// Bits of `candidates` (points of `block` in use) whose point passes every test before its
/// weight: not a back face, not of the surface the cone leaves, within the clip and between the
/// depths. `lanes` receives each point's normal, n·d, depth, exponent and offset from the axis.
/// The SIMD kernel.
std::uint32_t weigh_points(const ConeVoxelBlock& block, std::uint32_t candidates,
                           const PointLanesInput& in, PointLanes& lanes);

/// weigh_points one point at a time: the reference, in the traversal's own expressions.
inline std::uint32_t weigh_points_scalar(const ConeVoxelBlock& block, std::uint32_t candidates,
                                         const PointLanesInput& in, PointLanes& lanes) {
    std::uint32_t hits = 0;
    lanes.back_faces = 0;
    for (std::uint32_t bits = candidates; bits != 0; bits &= bits - 1) {
        const auto k = static_cast<std::size_t>(std::countr_zero(bits));
        const Vec3f normal = decode_normal(NormalCode{block.normal_u[k], block.normal_v[k]});
        const float along = normal.dot(in.direction);
        const Vec2f across(normal.dot(in.u), normal.dot(in.v));
        const float along_normal = decode_offset8(block.offset[k]) * in.spacing;
        const std::array<float, 3> code{static_cast<float>(block.x[k]),
                                        static_cast<float>(block.y[k]),
                                        static_cast<float>(block.z[k])};
        float t = in.first[0];
        Vec2f offset(in.first[1], in.first[2]);
        for (std::size_t a = 0; a < 3; ++a) {
            t += code[a] * in.step[a][0];
            offset += code[a] * Vec2f(in.step[a][1], in.step[a][2]);
        }
        t += along_normal * along;
        offset += along_normal * across;
        const float plane = t * along + offset.dot(across);
        const float length = normal.norm();
        lanes.nx[k] = normal.x();
        lanes.ny[k] = normal.y();
        lanes.nz[k] = normal.z();
        lanes.along[k] = along;
        if (in.closed != nullptr && in.closed->back_facing(plane, length, in.start)) {
            lanes.back_faces |= 1u << k;
            continue;
        }
        const bool enters =
            in.entered != nullptr && in.entered->entered_through(along, length, in.entering_cosine);
        const bool beyond = in.leaving_side * along < 0.0f;
        if (in.leaving && !enters && !beyond &&
            is_surface_left(std::abs(plane), t * t + offset.squaredNorm(), in.coplanar, in.start,
                            in.near)) {
            continue;
        }
        if (!(t >= in.t_min)) {
            continue;
        }
        const float q = point_weight_exponent(in.inverse, offset);
        if (!(q <= kPointWeightClipExponent)) {
            continue;
        }
        const float depth = point_depth({t, offset}, {along, across});
        if (!(depth >= in.t_min) || depth > in.t_max) {
            continue;
        }
        lanes.t[k] = depth;
        lanes.q[k] = q;
        lanes.u[k] = offset.x();
        lanes.v[k] = offset.y();
        hits |= 1u << k;
    }
    return hits;
}

}  // namespace mrt
