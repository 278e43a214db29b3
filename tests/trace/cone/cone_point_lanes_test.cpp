// Weighing a cluster's points in lanes (trace/cone/cone_point_lanes.h): the SIMD kernel answers as
// the scalar reference bit for bit under every instruction set Highway compiled it for, and the
// reference places, tests and weighs each point as an independent computation does from the
// point's own records (point_position, intersect_cone_point in the ray's frame, the closed
// surface's back-face test and the leaving test written out), up to rounding at the tests'
// boundaries.

#include "trace/cone/cone_point_lanes.h"

#include "common/footprint/point_weight.h"
#include "common/hierarchy/hierarchy_file.h"
#include "trace/cone/closed_surfaces.h"
#include "trace/cone/cone_block_simd.h"

#include <gtest/gtest.h>
#include <hwy/targets.h>
#include <hwy/tests/hwy_gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

namespace mrt {
namespace {

/// Closed surfaces of either winding, for the back-face and entering tests.
const ClosedSurface kOutward{{}, {}, 1.0f, 0.0f};
const ClosedSurface kInward{{}, {}, -1.0f, 0.0f};

/// A random case: a node of spacing h at `origin`, a cone looking at it, and a cluster of points
/// in it with random codes.
struct Case {
    ConeRay ray;
    Vec3f origin = Vec3f::Zero();
    float h = 1.0f;
    PointWeightFrame frame;
    PointLanesInput in;
    ConeVoxelBlock block;
};

Case random_case(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    std::uniform_int_distribution<int> byte(0, 255);
    std::uniform_int_distribution<int> offset(-127, 127);
    std::uniform_int_distribution<int> normal(0, 65535);
    Case c;
    c.h = std::pow(10.0f, unit(rng));
    // A grid of 16 voxels a side, the cone's axis through it from a few node sides away.
    c.origin = Vec3f(unit(rng), unit(rng), unit(rng)) * 10.0f;
    const Vec3f middle = c.origin + Vec3f::Constant(8.0f * c.h);
    c.ray.origin = middle + Vec3f(unit(rng), unit(rng), unit(rng)).normalized() * 40.0f * c.h;
    c.ray.direction =
        (middle + Vec3f(unit(rng), unit(rng), unit(rng)) * 4.0f * c.h - c.ray.origin).normalized();
    orthonormal_basis(c.ray.direction, c.ray.cone.u, c.ray.cone.v);
    Mat2f footprint;
    footprint << unit(rng), unit(rng), unit(rng), unit(rng);
    footprint *= 3.0f * c.h;
    c.frame = point_weight_frame(footprint, c.h);
    for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
        c.block.x[k] = static_cast<std::uint8_t>(byte(rng) % 16);
        c.block.y[k] = static_cast<std::uint8_t>(byte(rng) % 16);
        c.block.z[k] = static_cast<std::uint8_t>(byte(rng) % 16);
        c.block.offset[k] = static_cast<std::int8_t>(offset(rng));
        c.block.normal_u[k] = static_cast<std::uint16_t>(normal(rng));
        c.block.normal_v[k] = static_cast<std::uint16_t>(normal(rng));
    }
    // The input as the traversal forms it (Walk::points, VoxelsInRayFrame).
    PointLanesInput& in = c.in;
    const VertexInRayFrame first = c.ray.frame_of(c.origin + Vec3f::Constant(0.5f * c.h));
    in.first = {first.t, first.offset.x(), first.offset.y()};
    for (std::size_t a = 0; a < 3; ++a) {
        const auto i = static_cast<Eigen::Index>(a);
        in.step[a] = {c.h * c.ray.direction[i], c.h * c.ray.cone.u[i], c.h * c.ray.cone.v[i]};
    }
    in.direction = c.ray.direction;
    in.u = c.ray.cone.u;
    in.v = c.ray.cone.v;
    in.spacing = c.h;
    in.inverse = c.frame.inverse;
    in.t_min = positive(rng) < 0.3f ? 0.0f : 40.0f * c.h * positive(rng);
    in.t_max = positive(rng) < 0.3f ? std::numeric_limits<float>::infinity()
                                    : in.t_min + 60.0f * c.h * positive(rng);
    const auto either = [&] { return positive(rng) < 0.5f ? &kOutward : &kInward; };
    in.closed = positive(rng) < 0.5f ? either() : nullptr;
    in.start = positive(rng) < 0.3f ? 0.0f : c.h * positive(rng);
    in.leaving = in.t_min > 0.0f;
    in.coplanar = 0.1f * c.h;
    in.near = 2.0f * c.h + 10.0f * in.start;
    in.entered = positive(rng) < 0.5f ? either() : nullptr;
    in.entering_cosine = 0.1f;
    const float side = positive(rng);
    in.leaving_side = side < 0.3f ? 0.0f : side < 0.65f ? 1.0f : -1.0f;
    return c;
}

class ConePointLanesKernel : public hwy::TestWithParamTarget {};
HWY_TARGET_INSTANTIATE_TEST_SUITE_P(ConePointLanesKernel);

TEST_P(ConePointLanesKernel, AnswersAsTheScalarReferenceBitForBit) {
    std::mt19937_64 rng(61);
    std::uniform_int_distribution<std::uint32_t> mask(0, 0xffffu);
    int hits = 0;
    int lanes_compared = 0;
    for (int i = 0; i < 5000; ++i) {
        const Case c = random_case(rng);
        const std::uint32_t candidates = i % 7 == 0 ? 0xffffu : mask(rng);
        PointLanes simd;
        PointLanes scalar;
        const std::uint32_t simd_hits = weigh_points(c.block, candidates, c.in, simd);
        const std::uint32_t scalar_hits = weigh_points_scalar(c.block, candidates, c.in, scalar);
        ASSERT_EQ(simd_hits, scalar_hits) << "case " << i;
        ASSERT_EQ(simd.back_faces, scalar.back_faces) << "case " << i;
        ASSERT_EQ(simd_hits & ~candidates, 0u);
        for (std::uint32_t bits = scalar_hits; bits != 0; bits &= bits - 1) {
            const auto k = static_cast<std::size_t>(std::countr_zero(bits));
            ++hits;
            for (const auto member :
                 {&PointLanes::nx, &PointLanes::ny, &PointLanes::nz, &PointLanes::along,
                  &PointLanes::t, &PointLanes::q, &PointLanes::u, &PointLanes::v}) {
                ++lanes_compared;
                ASSERT_EQ(std::bit_cast<std::uint32_t>((simd.*member)[k]),
                          std::bit_cast<std::uint32_t>((scalar.*member)[k]))
                    << "case " << i << " point " << k;
            }
        }
    }
    // Not vacuous: about a tenth of the candidates hit.
    EXPECT_GT(hits, 2000);
    EXPECT_GT(lanes_compared, 8 * 2000);
}

TEST_P(ConePointLanesKernel, DamagedInputHitsNothing) {
    std::mt19937_64 rng(62);
    Case c = random_case(rng);
    c.in.t_min = 0.0f;
    c.in.t_max = std::numeric_limits<float>::infinity();
    PointLanes lanes;
    c.in.inverse(0, 0) = std::numeric_limits<float>::quiet_NaN();
    EXPECT_EQ(weigh_points(c.block, 0xffffu, c.in, lanes),
              weigh_points_scalar(c.block, 0xffffu, c.in, lanes));
    EXPECT_EQ(weigh_points(c.block, 0xffffu, c.in, lanes), 0u);
    c = random_case(rng);
    c.in.first[0] = std::numeric_limits<float>::quiet_NaN();
    EXPECT_EQ(weigh_points(c.block, 0xffffu, c.in, lanes), 0u);
    EXPECT_EQ(weigh_points_scalar(c.block, 0xffffu, c.in, lanes), 0u);
}

/// One point by an independent route: its position from its records (point_position), the
/// generic intersect_cone_point (projecting position and normal with the ray's frame_of), the
/// back-face and leaving tests from their definitions. Rounding differs from the lanes' affine
/// steps, so each comparison reports how far from its boundary it was.
struct Independent {
    bool hit = false;
    float t = 0.0f;
    float weight = 0.0f;
    Vec2f offset = Vec2f::Zero();  ///< The position's offset from the axis.
    double margin = 0.0;           ///< Relative distance of the nearest decision to its boundary.
};

Independent independent(const Case& c, std::size_t k) {
    const PointCore core{VoxelCode{c.block.x[k], c.block.y[k], c.block.z[k]}, 255,
                         NormalCode{c.block.normal_u[k], c.block.normal_v[k]}};
    const Vec3f normal = decode_normal(core.normal);
    const Vec3f centre =
        c.origin + (Vec3f(c.block.x[k], c.block.y[k], c.block.z[k]) + Vec3f::Constant(0.5f)) * c.h;
    const Vec3f position = point_position(centre, c.h, normal, PointOffset{c.block.offset[k]});
    const Eigen::Vector3d apart = (position - c.ray.origin).cast<double>();
    const double plane = normal.cast<double>().dot(apart);
    const double scale = apart.norm() + c.h;
    Independent r;
    r.margin = 1.0;
    const auto decided = [&](double x, double bound, double magnitude) {
        r.margin = std::min(r.margin, std::abs(x - bound) / magnitude);
        return x > bound;
    };
    const PointLanesInput& in = c.in;
    if (in.closed != nullptr && decided(in.closed->outward * plane, in.start, scale)) {
        return r;
    }
    const double along = normal.cast<double>().dot(c.ray.direction.cast<double>());
    const bool enters =
        in.entered != nullptr && decided(-in.entering_cosine, in.entered->outward * along, 1.0);
    // Facing the cone from beyond its start: n·d of the other sign than leaving_side.
    const bool beyond =
        in.leaving_side != 0.0f && decided(0.0, static_cast<double>(in.leaving_side) * along, 1.0);
    if (in.leaving && !enters && !beyond) {
        const double distance = std::abs(plane);
        if (!decided(distance, in.coplanar, scale) ||
            (!decided(distance, in.start, scale) &&
             !decided(apart.squaredNorm(), static_cast<double>(in.near) * in.near,
                      scale * scale))) {
            return r;
        }
    }
    const auto hit = intersect_cone_point(c.ray, c.frame, position, normal, 1.0f, in.t_min);
    const VertexInRayFrame p = c.ray.frame_of(position);
    const double q = (c.frame.inverse * p.offset).squaredNorm();
    decided(q, kPointWeightClipExponent, 10.0 * (1.0 + q));
    decided(p.t, in.t_min, scale);
    if (!hit) {
        return r;
    }
    decided(hit->t, in.t_min, scale);
    decided(hit->t, in.t_max, scale);
    if (hit->t > in.t_max) {
        return r;
    }
    r.hit = true;
    r.t = hit->t;
    r.offset = p.offset;
    r.weight = hit->weight;
    return r;
}

TEST(ConePointLanes, PlaceTestAndWeighAsEachPointOnItsOwn) {
    std::mt19937_64 rng(63);
    int hits = 0;
    int misses = 0;
    int marginal = 0;
    for (int i = 0; i < 3000; ++i) {
        const Case c = random_case(rng);
        PointLanes lanes;
        const std::uint32_t lane_hits = weigh_points_scalar(c.block, 0xffffu, c.in, lanes);
        for (std::size_t k = 0; k < kConeClusterSize; ++k) {
            const Independent r = independent(c, k);
            const bool lane_hit = ((lane_hits >> k) & 1u) != 0;
            if (r.margin < 1e-4) {
                ++marginal;
                continue;
            }
            ASSERT_EQ(lane_hit, r.hit) << "case " << i << " point " << k;
            if (!r.hit) {
                ++misses;
                continue;
            }
            ++hits;
            const float weight = c.frame.scale * std::abs(lanes.along[k]) * std::exp(-lanes.q[k]);
            EXPECT_NEAR(lanes.t[k], r.t, 1e-3f * (std::abs(r.t) + c.h)) << "case " << i;
            EXPECT_NEAR(lanes.u[k], r.offset.x(), 1e-3f * (std::abs(r.t) + c.h)) << "case " << i;
            EXPECT_NEAR(lanes.v[k], r.offset.y(), 1e-3f * (std::abs(r.t) + c.h)) << "case " << i;
            EXPECT_NEAR(weight, r.weight, 1e-3f * r.weight + 1e-6f) << "case " << i;
        }
    }
    EXPECT_GT(hits, 1000);
    EXPECT_GT(misses, 1000);
    EXPECT_LT(marginal, (hits + misses) / 100);
}

}  // namespace
}  // namespace mrt
