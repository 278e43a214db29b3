// The block tests of trace/cone/cone_bound_block.h as Highway kernels. hwy/foreach_target.h
// includes this file once per instruction set Highway compiles for (AVX-512, AVX2, SSE4, SSSE3
// and a one-lane fallback on x86-64), each copy in its own namespace with that set's target
// attributes; HWY_DYNAMIC_DISPATCH then calls the copy for the best set the CPU has, picked on
// the first call and cached (one indirect call per block afterwards).
//
// Every kernel evaluates the expressions of its scalar reference (the `_scalar` functions of
// cone_bound_block.h, and ConeSphereTest::circle_may_touch) in the same order, min and max as
// std::min and std::max select (which operand wins on NaN), and this file is compiled without
// contracting multiplies and adds into fused multiply-adds (trace/cone/CMakeLists.txt): the masks
// and depths are the reference's bit for bit, so the traversal's choices, and its images, do not
// depend on the CPU.

#include "trace/cone/cone_block_simd.h"

#include "common/footprint/point_weight.h"
#include "trace/cone/cone_bound_block.h"
#include "trace/cone/cone_bounds.h"
#include "trace/cone/cone_cluster_spheres.h"
#include "trace/cone/cone_point_lanes.h"
#include "trace/cone/cone_ray.h"
#include "trace/cone/cone_triangle_block.h"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "trace/cone/cone_block_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace mrt {
namespace HWY_NAMESPACE {
namespace {

namespace hn = hwy::HWY_NAMESPACE;

/// Bit i set for lane i of `inside` (at most 16 lanes).
template <class D>
std::uint32_t lane_bits(D d, hn::Mask<D> inside) {
    static_assert(hn::MaxLanes(D()) <= 16);
    // StoreMaskBits writes whole bytes, (lanes + 7) / 8 of them.
    std::array<std::uint8_t, 8> bytes{};
    hn::StoreMaskBits(d, inside, bytes.data());
    return static_cast<std::uint32_t>(bytes[0]) | (static_cast<std::uint32_t>(bytes[1]) << 8);
}

/// The bits below `count`: the members in use.
std::uint32_t bits_below(std::uint32_t count) {
    static_assert(kConeClusterSize < 32);
    return (1u << count) - 1u;
}

/// A ray's origin, direction and footprint axes u, v, each coordinate in every lane: what
/// placing a vector of sphere centres in the ray's frame needs.
template <class D>
struct RayLanes {
    std::array<hn::Vec<D>, 12> lanes;

    RayLanes(D d, const ConeRay& ray)
        : lanes{hn::Set(d, ray.origin.x()),    hn::Set(d, ray.origin.y()),
                hn::Set(d, ray.origin.z()),    hn::Set(d, ray.direction.x()),
                hn::Set(d, ray.direction.y()), hn::Set(d, ray.direction.z()),
                hn::Set(d, ray.cone.u.x()),    hn::Set(d, ray.cone.u.y()),
                hn::Set(d, ray.cone.u.z()),    hn::Set(d, ray.cone.v.x()),
                hn::Set(d, ray.cone.v.y()),    hn::Set(d, ray.cone.v.z())} {}
};

/// A cone's reach about its axis and its depth range, in every lane.
template <class D>
struct ReachLanes {
    hn::Vec<D> reach;
    hn::Vec<D> t_min;
    hn::Vec<D> t_max;

    ReachLanes(D d, float reach_, float t_min_, float t_max_)
        : reach(hn::Set(d, reach_)), t_min(hn::Set(d, t_min_)), t_max(hn::Set(d, t_max_)) {}

    /// The spheres (centres at depth t and offsets a, b from the axis, radii r) that may hold
    /// something within reach and the depths. Comparisons with a NaN are false: a damaged
    /// sphere is never before, after or beside.
    hn::Mask<D> may_hold(hn::Vec<D> t, hn::Vec<D> a, hn::Vec<D> b, hn::Vec<D> r) const {
        const auto within = reach + r;
        const auto before = t + r < t_min;
        const auto after = t - r > t_max;
        const auto beside = a * a + b * b > within * within;
        return hn::Not(hn::Or(hn::Or(before, after), beside));
    }
};

/// spheres_near_axis_scalar, a vector of spheres at a time.
std::uint32_t spheres_near_axis_simd(const ConeBoundBlock& block, std::uint32_t count,
                                     const ConeRay& ray, float reach, float t_min, float t_max,
                                     const GaussianSquare& square) {
    const hn::CappedTag<float, kConeClusterSize> d;
    const std::uint32_t lanes = static_cast<std::uint32_t>(hn::Lanes(d));
    const std::uint32_t used = std::min(count, kConeClusterSize);
    const RayLanes<decltype(d)> ray_lanes(d, ray);
    const auto& [ox, oy, oz, dx, dy, dz, ux, uy, uz, vx, vy, vz] = ray_lanes.lanes;
    const ReachLanes<decltype(d)> range(d, reach, t_min, t_max);
    const auto m00 = hn::Set(d, square.m00);
    const auto m01 = hn::Set(d, square.m01);
    const auto m11 = hn::Set(d, square.m11);
    const auto square_reach = hn::Set(d, square.reach);
    const auto stretch = hn::Set(d, square.stretch);
    const auto rounding = hn::Set(d, kGaussianSquareRounding);
    // The default square keeps everything (its slack is +∞ or NaN): its lanes are not worked.
    const bool squared = square.reach < std::numeric_limits<float>::infinity();
    std::uint32_t mask = 0;
    for (std::uint32_t k = 0; k < used; k += lanes) {
        const auto px = hn::Load(d, block.x.data() + k) - ox;
        const auto py = hn::Load(d, block.y.data() + k) - oy;
        const auto pz = hn::Load(d, block.z.data() + k) - oz;
        const auto t = px * dx + py * dy + pz * dz;
        const auto a = px * ux + py * uy + pz * uz;
        const auto b = px * vx + py * vy + pz * vz;
        const auto r = hn::Load(d, block.radius.data() + k);
        // A damaged sphere is never outside the square either (comparisons with a NaN).
        auto inside = range.may_hold(t, a, b, r);
        if (squared) {
            const auto gx = m00 * a + m01 * b;
            const auto gy = m01 * a + m11 * b;
            const auto size = hn::Abs(t) + hn::Abs(a) + hn::Abs(b) + r;
            const auto slack = square_reach + stretch * r + rounding * stretch * size;
            const auto outside_square = hn::Or(hn::Abs(gx) > slack, hn::Abs(gy) > slack);
            inside = hn::AndNot(outside_square, inside);
        }
        mask |= lane_bits(d, inside) << k;
    }
    return mask & bits_below(used);
}

/// A vector of the codes at `codes` (unsigned or signed bytes) as floats.
template <class D, typename Code>
hn::Vec<D> codes_as_floats(D d, const Code* codes) {
    const hn::Rebind<Code, D> d_code;
    const hn::RebindToSigned<D> d_int;
    return hn::ConvertTo(d, hn::PromoteTo(d_int, hn::LoadU(d_code, codes)));
}

/// voxels_within_clip_scalar, a vector of points at a time.
std::uint32_t voxels_within_clip_simd(const ConeVoxelBlock& block, std::uint32_t count,
                                      const VoxelGaussian& voxels) {
    const hn::CappedTag<float, kConeClusterSize> d;
    const std::uint32_t lanes = static_cast<std::uint32_t>(hn::Lanes(d));
    const std::uint32_t used = std::min(count, kConeClusterSize);
    const auto first_x = hn::Set(d, voxels.first.x());
    const auto first_y = hn::Set(d, voxels.first.y());
    const auto step_ix = hn::Set(d, voxels.step[0].x());
    const auto step_iy = hn::Set(d, voxels.step[0].y());
    const auto step_jx = hn::Set(d, voxels.step[1].x());
    const auto step_jy = hn::Set(d, voxels.step[1].y());
    const auto step_lx = hn::Set(d, voxels.step[2].x());
    const auto step_ly = hn::Set(d, voxels.step[2].y());
    const auto clip = hn::Set(d, voxels.clip);
    const auto offset_stretch = hn::Set(d, voxels.offset_stretch);
    std::uint32_t mask = 0;
    for (std::uint32_t k = 0; k < used; k += lanes) {
        const auto i = codes_as_floats(d, block.x.data() + k);
        const auto j = codes_as_floats(d, block.y.data() + k);
        const auto l = codes_as_floats(d, block.z.data() + k);
        const auto gx = first_x + i * step_ix + j * step_jx + l * step_lx;
        const auto gy = first_y + i * step_iy + j * step_jy + l * step_ly;
        const auto reach =
            clip + offset_stretch * hn::Abs(codes_as_floats(d, block.offset.data() + k));
        // False for a NaN centre: its bit clears.
        const auto inside = gx * gx + gy * gy <= reach * reach;
        mask |= lane_bits(d, inside) << k;
    }
    return mask & bits_below(used);
}

/// ConeSphereTest::frobenius_squared at the depths `t`, from the test's coefficients.
template <class D>
hn::Vec<D> frobenius_squared(D d, const ConeSphereTest::CircleCoefficients& c, hn::Vec<D> t) {
    const auto constant = hn::Set(d, c.constant);
    const auto linear = hn::Set(d, c.linear);
    const auto quadratic = hn::Set(d, c.quadratic);
    const auto value = constant + t * (linear + t * quadratic);
    const auto magnitude = constant + hn::Abs(t) * (hn::Abs(linear) + hn::Abs(t) * quadratic);
    const auto zero = hn::Zero(d);
    // std::max(0, value): 0 when value is NaN (overflowed coefficients).
    const auto clamped = hn::IfThenElse(zero < value, value, zero);
    return clamped + hn::Set(d, ConeSphereTest::kQuadraticRounding) * magnitude;
}

/// children_near_cone_scalar, a vector of children at a time: ConeRay::sphere_of and
/// ConeSphereTest::circle_may_touch written out.
std::uint32_t children_near_cone_simd(const ConeChildBlock& block, std::uint32_t count,
                                      const ConeRay& ray, const ConeSphereTest& test, float t_min,
                                      float t_max, std::array<float, kConeChildCount>& nearest) {
    const hn::CappedTag<float, kConeChildCount> d;
    const std::uint32_t lanes = static_cast<std::uint32_t>(hn::Lanes(d));
    const ConeSphereTest::CircleCoefficients circle = test.circle();
    const RayLanes<decltype(d)> ray_lanes(d, ray);
    const auto& [ox, oy, oz, dx, dy, dz, ux, uy, uz, vx, vy, vz] = ray_lanes.lanes;
    const auto t_min_v = hn::Set(d, t_min);
    const auto t_max_v = hn::Set(d, t_max);
    const auto anisotropy_widening = hn::Set(d, 1.0f + circle.inverse_anisotropy_squared);
    const auto clip_exponent = hn::Set(d, kPointWeightClipExponent);
    std::uint32_t mask = 0;
    for (std::uint32_t k = 0; k < kConeChildCount; k += lanes) {
        const auto px = hn::Load(d, block.x.data() + k) - ox;
        const auto py = hn::Load(d, block.y.data() + k) - oy;
        const auto pz = hn::Load(d, block.z.data() + k) - oz;
        // Eigen sums a 3-vector's dot product as x + (y + z).
        const auto t = px * dx + (py * dy + pz * dz);
        const auto a = px * ux + (py * uy + pz * uz);
        const auto b = px * vx + (py * vy + pz * vz);
        const auto r = hn::Load(d, block.radius.data() + k);
        const auto w = hn::Load(d, block.widening.data() + k);
        const auto front = t - r;
        hn::StoreU(front, d, nearest.data() + k);
        // std::max(t − r, t_min) and std::min(t + r, t_max): a NaN t_min or t_max is passed
        // over, a NaN depth kept (and answered below).
        const auto near = hn::IfThenElse(front < t_min_v, t_min_v, front);
        const auto back = t + r;
        const auto far = hn::IfThenElse(t_max_v < back, t_max_v, back);
        const auto finite =
            hn::And(hn::And(hn::IsFinite(near), hn::IsFinite(far)),
                    hn::And(hn::And(hn::IsFinite(a), hn::IsFinite(b)), hn::IsFinite(w)));
        const auto frobenius_near = frobenius_squared(d, circle, near);
        const auto frobenius_far = frobenius_squared(d, circle, far);
        const auto frobenius =
            hn::IfThenElse(frobenius_near < frobenius_far, frobenius_far, frobenius_near);
        const auto circle_reach =
            hn::Sqrt(clip_exponent * (frobenius * anisotropy_widening + w * w)) + r;
        const auto outside = hn::Or(near > far, a * a + b * b > circle_reach * circle_reach);
        // Damaged input may touch: the sphere is kept.
        mask |= lane_bits(d, hn::Or(hn::Not(finite), hn::Not(outside))) << k;
    }
    if (!circle.finite) {
        mask = ~0u;
    }
    return mask & bits_below(std::min(count, kConeChildCount));
}

/// HWY_TARGET of the copy that runs.
const char* target_name() {
    return hwy::TargetName(HWY_TARGET);
}

/// weigh_points_scalar, a vector of points at a time. Lanes without a candidate are worked too
/// (their bits are cleared); a vector without any is skipped.
std::uint32_t weigh_points_simd(const ConeVoxelBlock& block, std::uint32_t candidates,
                                const PointLanesInput& in, PointLanes& out) {
    const hn::CappedTag<float, kConeClusterSize> d;
    const hn::RebindToSigned<decltype(d)> di;
    const hn::Rebind<std::uint16_t, decltype(d)> d16;
    const std::uint32_t lanes = static_cast<std::uint32_t>(hn::Lanes(d));
    const std::uint32_t vector_bits = lanes >= 32 ? ~0u : (1u << lanes) - 1u;
    const auto dx = hn::Set(d, in.direction.x());
    const auto dy = hn::Set(d, in.direction.y());
    const auto dz = hn::Set(d, in.direction.z());
    const auto ux = hn::Set(d, in.u.x());
    const auto uy = hn::Set(d, in.u.y());
    const auto uz = hn::Set(d, in.u.z());
    const auto vx = hn::Set(d, in.v.x());
    const auto vy = hn::Set(d, in.v.y());
    const auto vz = hn::Set(d, in.v.z());
    const auto centre = hn::Set(di, NormalCode::kCentre);
    const auto code_max = hn::Set(di, 2 * NormalCode::kCentre);
    const auto zero_i = hn::Zero(di);
    const auto offset_scale = hn::Set(d, 127.0f);
    const auto spacing = hn::Set(d, in.spacing);
    const auto m00 = hn::Set(d, in.inverse(0, 0));
    const auto m01 = hn::Set(d, in.inverse(0, 1));
    const auto m10 = hn::Set(d, in.inverse(1, 0));
    const auto m11 = hn::Set(d, in.inverse(1, 1));
    const auto clip = hn::Set(d, kPointWeightClipExponent);
    const auto t_min = hn::Set(d, in.t_min);
    const auto t_max = hn::Set(d, in.t_max);
    const auto outward = hn::Set(d, in.closed != nullptr ? in.closed->outward : 0.0f);
    const auto start = hn::Set(d, in.start);
    const auto coplanar = hn::Set(d, in.coplanar);
    const auto near_squared = hn::Set(d, in.near * in.near);
    const auto solid_outward = hn::Set(d, in.entered != nullptr ? in.entered->outward : 0.0f);
    const auto entering = hn::Set(d, -in.entering_cosine);
    const auto leaving_side = hn::Set(d, in.leaving_side);
    const auto one = hn::Set(d, 1.0f);
    const auto two = hn::Set(d, 2.0f);
    const auto three = hn::Set(d, 3.0f);
    const auto plane_cosine = hn::Set(d, kPlaneDepthCosine);
    const auto plane_blend = hn::Set(d, kPlaneDepthBlend);
    const auto none = hn::FirstN(d, 0);
    std::uint32_t hits = 0;
    std::uint32_t back_faces = 0;
    for (std::uint32_t k = 0; k < kConeClusterSize; k += lanes) {
        if (((candidates >> k) & vector_bits) == 0) {
            continue;
        }
        // decode_normal, on the integer grid.
        const auto a =
            hn::Min(hn::PromoteTo(di, hn::LoadU(d16, block.normal_u.data() + k)), code_max) -
            centre;
        const auto b =
            hn::Min(hn::PromoteTo(di, hn::LoadU(d16, block.normal_v.data() + k)), code_max) -
            centre;
        const auto zi = centre - hn::Abs(a) - hn::Abs(b);
        const auto fold = hn::Max(hn::Neg(zi), zero_i);
        const auto xi = hn::IfThenElse(hn::Lt(a, zero_i), a + fold, a - fold);
        const auto yi = hn::IfThenElse(hn::Lt(b, zero_i), b + fold, b - fold);
        const auto fx = hn::ConvertTo(d, xi);
        const auto fy = hn::ConvertTo(d, yi);
        const auto fz = hn::ConvertTo(d, zi);
        const auto norm = hn::Sqrt(fx * fx + (fy * fy + fz * fz));
        const auto nx = fx / norm;
        const auto ny = fy / norm;
        const auto nz = fz / norm;
        const auto along = nx * dx + (ny * dy + nz * dz);
        const auto across_u = nx * ux + (ny * uy + nz * uz);
        const auto across_v = nx * vx + (ny * vy + nz * vz);
        // The voxel's centre (VoxelsInRayFrame::centre) moved along the normal.
        const auto along_normal =
            codes_as_floats(d, block.offset.data() + k) / offset_scale * spacing;
        auto t = hn::Set(d, in.first[0]);
        auto ou = hn::Set(d, in.first[1]);
        auto ov = hn::Set(d, in.first[2]);
        const std::array<hn::Vec<decltype(d)>, 3> code{codes_as_floats(d, block.x.data() + k),
                                                       codes_as_floats(d, block.y.data() + k),
                                                       codes_as_floats(d, block.z.data() + k)};
        for (std::size_t axis = 0; axis < 3; ++axis) {
            t = t + code[axis] * hn::Set(d, in.step[axis][0]);
            ou = ou + code[axis] * hn::Set(d, in.step[axis][1]);
            ov = ov + code[axis] * hn::Set(d, in.step[axis][2]);
        }
        t = t + along_normal * along;
        ou = ou + along_normal * across_u;
        ov = ov + along_normal * across_v;
        const auto plane = t * along + (ou * across_u + ov * across_v);
        const auto length = hn::Sqrt(nx * nx + (ny * ny + nz * nz));
        // ClosedSurface::back_facing and entered_through.
        const auto back = in.closed != nullptr ? hn::Gt(outward * plane, start * length) : none;
        const auto enters =
            in.entered != nullptr ? hn::Lt(solid_outward * along, entering * length) : none;
        const auto distance = hn::Abs(plane);
        const auto squared = t * t + (ou * ou + ov * ov);
        const auto near_plane =
            hn::Or(hn::Le(distance, coplanar),
                   hn::And(hn::Le(distance, start), hn::Le(squared, near_squared)));
        // A point facing the cone from beyond its start (PointLanesInput::leaving_side).
        const auto beyond =
            in.leaving_side != 0.0f ? hn::Lt(leaving_side * along, hn::Zero(d)) : none;
        const auto leaves = in.leaving ? hn::AndNot(hn::Or(enters, beyond), near_plane) : none;
        const auto g0 = m00 * ou + m01 * ov;
        const auto g1 = m10 * ou + m11 * ov;
        const auto q = g0 * g0 + g1 * g1;
        // point_depth: where the axis meets the tangent plane, blended in from the point's own
        // depth over the grazing cosines.
        const auto c = hn::Abs(along);
        const auto meets = t + (across_u * ou + across_v * ov) / along;
        const auto s = hn::Min(one, (c - plane_cosine) / plane_blend);
        const auto blended = t + s * s * (three - two * s) * (meets - t);
        const auto depth = hn::IfThenElse(hn::Gt(c, plane_cosine), blended, t);
        // NaN fails every comparison that keeps a point.
        const auto kept = hn::And(hn::And(hn::Ge(t, t_min), hn::Le(q, clip)),
                                  hn::AndNot(hn::Gt(depth, t_max), hn::Ge(depth, t_min)));
        const auto hit = hn::AndNot(hn::Or(back, leaves), kept);
        hn::Store(nx, d, out.nx.data() + k);
        hn::Store(ny, d, out.ny.data() + k);
        hn::Store(nz, d, out.nz.data() + k);
        hn::Store(along, d, out.along.data() + k);
        hn::Store(depth, d, out.t.data() + k);
        hn::Store(q, d, out.q.data() + k);
        hn::Store(ou, d, out.u.data() + k);
        hn::Store(ov, d, out.v.data() + k);
        hits |= lane_bits(d, hit) << k;
        back_faces |= lane_bits(d, back) << k;
    }
    out.back_faces = back_faces & candidates;
    return hits & candidates;
}

/// clusters_near_axis_scalar, a vector of spheres at a time: sphere_may_hold's ConeRay::frame_of
/// sums its dot products as Eigen does, x + (y + z).
std::uint32_t clusters_near_axis_simd(const ConeClusterSpheres& spheres, std::uint32_t first,
                                      std::uint32_t count, const ConeRay& ray, float reach,
                                      float t_min, float t_max) {
    const hn::CappedTag<float, kConeClusterSize> d;
    const std::uint32_t lanes = static_cast<std::uint32_t>(hn::Lanes(d));
    const std::uint32_t used = std::min(count, kConeClusterSize);
    const RayLanes<decltype(d)> ray_lanes(d, ray);
    const auto& [ox, oy, oz, dx, dy, dz, ux, uy, uz, vx, vy, vz] = ray_lanes.lanes;
    const ReachLanes<decltype(d)> range(d, reach, t_min, t_max);
    std::uint32_t mask = 0;
    for (std::uint32_t k = 0; k < used; k += lanes) {
        const std::size_t i = first + k;
        const auto px = hn::LoadU(d, spheres.x.data() + i) - ox;
        const auto py = hn::LoadU(d, spheres.y.data() + i) - oy;
        const auto pz = hn::LoadU(d, spheres.z.data() + i) - oz;
        const auto t = px * dx + (py * dy + pz * dz);
        const auto a = px * ux + (py * uy + pz * uz);
        const auto b = px * vx + (py * vy + pz * vz);
        const auto r = hn::LoadU(d, spheres.radius.data() + i);
        mask |= lane_bits(d, range.may_hold(t, a, b, r)) << k;
    }
    return mask & bits_below(used);
}

/// triangles_within_cull_scalar, a vector of triangles at a time: TriangleInRayFrame's
/// placement and map written out. Where the reference takes a minimum or maximum over the three
/// vertices, the kernel asks whether all three compare beyond the bound: the same answer for
/// finite vertices, and a NaN vertex keeps the triangle (for the reference to decide).
std::uint32_t triangles_within_cull_simd(const ConeTriangleBlock& block, std::uint32_t candidates,
                                         const ConeRay& ray, const TriangleCull& cull) {
    const hn::CappedTag<float, kConeClusterSize> d;
    const std::uint32_t lanes = static_cast<std::uint32_t>(hn::Lanes(d));
    const std::uint32_t vector_bits = lanes >= 32 ? ~0u : (1u << lanes) - 1u;
    const RayLanes<decltype(d)> ray_lanes(d, ray);
    const auto& [ox, oy, oz, dx, dy, dz, ux, uy, uz, vx, vy, vz] = ray_lanes.lanes;
    const auto t_min = hn::Set(d, cull.t_min);
    const auto t_max = hn::Set(d, cull.t_max);
    const float axis_x = cull.frame.axis.x();
    const float axis_y = cull.frame.axis.y();
    const auto ax = hn::Set(d, axis_x);
    const auto ay = hn::Set(d, axis_y);
    const auto minus_ay = hn::Set(d, -axis_y);
    const auto major = hn::Set(d, cull.frame.inverse_semi_axes.x());
    const auto minor = hn::Set(d, cull.frame.inverse_semi_axes.y());
    const auto reach = hn::Set(d, cull.reach);
    const auto minus_reach = hn::Set(d, -cull.reach);
    const auto all = hn::FirstN(d, lanes);
    std::uint32_t kept = 0;
    for (std::uint32_t k = 0; k < kConeClusterSize; k += lanes) {
        if (((candidates >> k) & vector_bits) == 0) {
            continue;
        }
        auto before = all;
        auto after = all;
        auto right = all;
        auto left = all;
        auto above = all;
        auto below = all;
        for (std::size_t i = 0; i < 3; ++i) {
            const auto px = hn::Load(d, block.position[3 * i].data() + k) - ox;
            const auto py = hn::Load(d, block.position[3 * i + 1].data() + k) - oy;
            const auto pz = hn::Load(d, block.position[3 * i + 2].data() + k) - oz;
            const auto t = px * dx + (py * dy + pz * dz);
            const auto u = px * ux + (py * uy + pz * uz);
            const auto v = px * vx + (py * vy + pz * vz);
            const auto along = (u * ax + v * ay) * major;
            const auto across = (u * minus_ay + v * ax) * minor;
            const auto x = along * ax + across * minus_ay;
            const auto y = along * ay + across * ax;
            before = hn::And(before, t < t_min);
            after = hn::And(after, t > t_max);
            right = hn::And(right, x > reach);
            left = hn::And(left, x < minus_reach);
            above = hn::And(above, y > reach);
            below = hn::And(below, y < minus_reach);
        }
        const auto culled =
            hn::Or(hn::Or(hn::Or(before, after), hn::Or(right, left)), hn::Or(above, below));
        kept |= lane_bits(d, hn::Not(culled)) << k;
    }
    return kept & candidates;
}

}  // namespace
}  // namespace HWY_NAMESPACE
}  // namespace mrt
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mrt {

HWY_EXPORT(spheres_near_axis_simd);
HWY_EXPORT(voxels_within_clip_simd);
HWY_EXPORT(children_near_cone_simd);
HWY_EXPORT(weigh_points_simd);
HWY_EXPORT(clusters_near_axis_simd);
HWY_EXPORT(triangles_within_cull_simd);
HWY_EXPORT(target_name);

std::uint32_t spheres_near_axis(const ConeBoundBlock& block, std::uint32_t count,
                                const ConeRay& ray, float reach, float t_min, float t_max,
                                const GaussianSquare& square) {
    return HWY_DYNAMIC_DISPATCH(spheres_near_axis_simd)(block, count, ray, reach, t_min, t_max,
                                                        square);
}

std::uint32_t voxels_within_clip(const ConeVoxelBlock& block, std::uint32_t count,
                                 const VoxelGaussian& voxels) {
    return HWY_DYNAMIC_DISPATCH(voxels_within_clip_simd)(block, count, voxels);
}

std::uint32_t children_near_cone(const ConeChildBlock& block, std::uint32_t count,
                                 const ConeRay& ray, const ConeSphereTest& test, float t_min,
                                 float t_max, std::array<float, kConeChildCount>& nearest) {
    return HWY_DYNAMIC_DISPATCH(children_near_cone_simd)(block, count, ray, test, t_min, t_max,
                                                         nearest);
}

std::uint32_t weigh_points(const ConeVoxelBlock& block, std::uint32_t candidates,
                           const PointLanesInput& in, PointLanes& lanes) {
    return HWY_DYNAMIC_DISPATCH(weigh_points_simd)(block, candidates, in, lanes);
}

std::uint32_t clusters_near_axis(const ConeClusterSpheres& spheres, std::uint32_t first,
                                 std::uint32_t count, const ConeRay& ray, float reach, float t_min,
                                 float t_max) {
    return HWY_DYNAMIC_DISPATCH(clusters_near_axis_simd)(spheres, first, count, ray, reach, t_min,
                                                         t_max);
}

std::uint32_t triangles_within_cull(const ConeTriangleBlock& block, std::uint32_t candidates,
                                    const ConeRay& ray, const TriangleCull& cull) {
    return HWY_DYNAMIC_DISPATCH(triangles_within_cull_simd)(block, candidates, ray, cull);
}

const char* block_kernel_target() {
    return HWY_DYNAMIC_DISPATCH(target_name)();
}

}  // namespace mrt
#endif  // HWY_ONCE
