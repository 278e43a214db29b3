// The SIMD block kernels (trace/cone/cone_block_simd.cpp) answer as their one-member-at-a-time
// references (the `_scalar` functions of trace/cone/cone_bound_block.h), under every instruction
// set Highway compiled them for that this CPU runs (hwy::TestWithParamTarget forces each in turn,
// down to the one-lane fallback): for random blocks of members near, on and far from the test's
// boundary, degenerate radii, every count from empty to full, plain, blurred and focusing cones,
// and damaged input. A kernel may fuse a multiply and an add where the reference does not (a
// build with MRT_NATIVE fuses the reference's instead), so a member within a relative 1e-5 of its
// test's boundary may get the other answer; no other may, and without fusion none does.

#include "trace/cone/cone_block_simd.h"

#include "common/footprint/footprint.h"
#include "common/footprint/point_weight.h"
#include "trace/cone/cone_bound_block.h"
#include "trace/cone/cone_bounds.h"
#include "trace/cone/cone_cluster_spheres.h"
#include "trace/cone/cone_ray.h"
#include "trace/cone/cone_triangle.h"
#include "trace/cone/cone_triangle_block.h"

#include <gtest/gtest.h>
#include <hwy/targets.h>
#include <hwy/tests/hwy_gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <random>
#include <vector>

namespace mrt {
namespace {

/// Members closer than this (relative) to a test's boundary may get either answer.
constexpr double kBoundaryTolerance = 1e-5;

/// Whether the kernels' arithmetic is the references' operation for operation: then even members
/// on the boundary agree.
#ifdef __FMA__
constexpr bool kExact = false;
#else
constexpr bool kExact = true;
#endif

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

/// One of the comparisons a test rejects a member by: `x > y` (or `x < y`), `scale` the
/// magnitude of the values its operands come from.
struct Rejection {
    double x = 0.0;
    double y = 0.0;
    double scale = 1.0;
    bool greater = true;

    bool holds() const { return greater ? x > y : x < y; }
    /// Whether rounding may decide it: its operands within kBoundaryTolerance, or not finite.
    bool marginal() const {
        const double gap = std::abs(x - y) / scale;
        return !(gap >= kBoundaryTolerance);
    }
};

/// The rejection `distance² > bound²` for a distance from coordinates whose rounding is relative
/// to `magnitude` (cancelling where the member lies near the axis of a far-away origin): the
/// squares differ by (distance − bound)(distance + bound), the first factor rounded with
/// `magnitude`.
Rejection beyond(double squared, double bound, double magnitude) {
    return {squared, bound * bound, (std::sqrt(squared) + bound) * (magnitude + bound), true};
}

/// Whether a test that rejects a member when any of `rejections` holds answers the same however
/// rounding decides the marginal ones: one clearly holds, or none is marginal.
bool decided(std::initializer_list<Rejection> rejections) {
    bool marginal = false;
    for (const Rejection& r : rejections) {
        if (!r.marginal() && r.holds()) {
            return true;
        }
        marginal = marginal || r.marginal();
    }
    return !marginal;
}

/// What a comparison of masks found.
struct Agreement {
    int members = 0;        ///< Members in use compared.
    int set = 0;            ///< Of them, with the reference's bit set.
    int near_boundary = 0;  ///< Whose answer rounding may decide.
    int disagreements = 0;  ///< Of those, with the other answer.

    /// Checks that both answers are the same unless rounding may decide the member's (not
    /// `decided`), and counts it.
    ::testing::AssertionResult add(bool simd, bool scalar, bool is_decided) {
        ++members;
        set += scalar ? 1 : 0;
        if (!is_decided) {
            ++near_boundary;
            disagreements += simd != scalar ? 1 : 0;
            return ::testing::AssertionSuccess();
        }
        if (simd != scalar) {
            return ::testing::AssertionFailure() << "SIMD " << simd << ", scalar " << scalar;
        }
        return ::testing::AssertionSuccess();
    }

    /// Rounding may flip a member on the boundary, but not many (a comparison the wrong way
    /// round would flip half), and none when the arithmetic is the reference's; both answers
    /// are common.
    void expect_consistent() const {
        if (kExact) {
            EXPECT_EQ(disagreements, 0);
        }
        EXPECT_LE(disagreements, near_boundary / 10);
        EXPECT_GT(set, members / 10);
        EXPECT_GT(members - set, members / 10);
        EXPECT_GT(near_boundary, 0) << "no member tested the boundary";
    }
};

/// A ray cone of the kinds the tracer makes: a pinhole cone diverging from its apex, a thin
/// lens's cone focusing through zero, nearly collinear columns (grazing reflections), each with
/// a blur (shadow, aperture, roughness) half the time; footprints from 1e-3 to 1e3.
ConeRay random_ray(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    ConeRay ray;
    ray.origin = Vec3f(unit(rng), unit(rng), unit(rng)) * 10.0f;
    ray.direction = Vec3f(unit(rng), unit(rng), unit(rng)).normalized();
    orthonormal_basis(ray.direction, ray.cone.u, ray.cone.v);
    FootprintCone& cone = ray.cone;
    const float scale = std::pow(10.0f, 3.0f * unit(rng));
    cone.incr_dev << unit(rng), unit(rng), unit(rng), unit(rng);
    cone.incr_dev *= 0.01f * scale;
    const int kind = static_cast<int>(positive(rng) * 3.0f);
    if (kind == 1) {
        const float focus = 10.0f * positive(rng);
        cone.start_dev = -focus * cone.incr_dev;
    } else if (kind == 2) {
        cone.incr_dev.col(1) = cone.incr_dev.col(0) * (1.0f + 1e-4f * unit(rng));
    }
    if (positive(rng) < 0.5f) {
        cone.blurred = true;
        cone.blur_start << unit(rng), unit(rng), unit(rng), unit(rng);
        cone.blur_start *= 0.01f * scale * positive(rng);
        cone.blur_incr << unit(rng), unit(rng), unit(rng), unit(rng);
        cone.blur_incr *= 0.01f * scale * positive(rng);
    }
    return ray;
}

/// A radius of the kinds bounding spheres have, degenerate ones included.
float random_radius(std::mt19937_64& rng, float scale) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_int_distribution<int> kind(0, 9);
    switch (kind(rng)) {
        case 0:
            return 0.0f;
        case 1:
            return std::numeric_limits<float>::denorm_min();
        case 2:
            return 1e3f * scale;
        default:
            return scale * std::pow(10.0f, unit(rng));
    }
}

/// How far a member lies from the axis relative to where the test's answer changes: well inside,
/// on the boundary up to a few ulps, or well outside.
float random_reach_factor(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_int_distribution<int> kind(0, 3);
    switch (kind(rng)) {
        case 0:
            return 1.0f + 1e-6f * unit(rng);
        case 1:
            return 0.5f * (1.0f + unit(rng));
        case 2:
            return 2.0f + 10.0f * (1.0f + unit(rng));
        default:
            return 1.0f + 0.1f * unit(rng);
    }
}

/// The blocks' bits ≥ count: the kernels must clear them.
std::uint32_t unused_bits(std::uint32_t count, std::uint32_t size) {
    return ((1u << size) - 1u) & ~((1u << std::min(count, size)) - 1u);
}

class ConeBlockKernels : public hwy::TestWithParamTarget {};
HWY_TARGET_INSTANTIATE_TEST_SUITE_P(ConeBlockKernels);

TEST_P(ConeBlockKernels, DispatchRunsTheTargetUnderTest) {
    EXPECT_STREQ(block_kernel_target(), hwy::TargetName(GetParam()));
}

/// A cone's reach about its axis and its depth range, on a random scale from 1e-2 to 1e2.
struct RandomReach {
    float scale;
    float reach;
    float t_min;
    float t_max;

    explicit RandomReach(std::mt19937_64& rng) {
        std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
        scale = std::pow(10.0f, 2.0f * unit(rng));
        reach = scale * 0.5f * (1.0f + unit(rng));
        t_min = scale * (2.0f + unit(rng));
        t_max = scale * (10.0f + 5.0f * unit(rng));
    }
};

struct RandomSphere {
    std::array<float, 3> centre;
    float radius;
};

/// A sphere on or near a boundary of `range` about `ray`: its depth at one of the depth limits
/// four times in ten, otherwise its side at the reach, each within a random factor of it.
RandomSphere random_sphere_at_reach(std::mt19937_64& rng, const ConeRay& ray,
                                    const RandomReach& range) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    const float radius = random_radius(rng, 0.3f * range.scale);
    const bool at_depth_limit = unit(rng) > 0.6f;
    const float t = at_depth_limit
                        ? (unit(rng) < 0.0f ? range.t_min - radius : range.t_max + radius) *
                              random_reach_factor(rng)
                        : range.scale * 8.0f * (1.0f + unit(rng));
    const Vec2f across = Vec2f(unit(rng), unit(rng)).normalized() * (range.reach + radius) *
                         random_reach_factor(rng);
    const Vec3f centre =
        ray.origin + t * ray.direction + across.x() * ray.cone.u + across.y() * ray.cone.v;
    return {{centre.x(), centre.y(), centre.z()}, radius};
}

TEST_P(ConeBlockKernels, SpheresNearAxisAgreeWithScalar) {
    std::mt19937_64 rng(41);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    Agreement agreement;
    for (int i = 0; i < 20000; ++i) {
        const ConeRay ray = random_ray(rng);
        const RandomReach range(rng);
        const auto [scale, reach, t_min, t_max] = range;
        const std::uint32_t count = static_cast<std::uint32_t>(i) % (kConeClusterSize + 1);
        // Every slot holds a sphere, so that the bits of those past `count` would be set.
        ConeBoundBlock block;
        for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
            const RandomSphere sphere = random_sphere_at_reach(rng, ray, range);
            block.x[k] = sphere.centre[0];
            block.y[k] = sphere.centre[1];
            block.z[k] = sphere.centre[2];
            block.radius[k] = sphere.radius;
        }
        const std::uint32_t simd = spheres_near_axis(block, count, ray, reach, t_min, t_max);
        const std::uint32_t scalar =
            spheres_near_axis_scalar(block, count, ray, reach, t_min, t_max);
        ASSERT_EQ(simd & unused_bits(count, kConeClusterSize), 0u) << "case " << i;
        for (std::uint32_t k = 0; k < count; ++k) {
            const Vec3f p = Vec3f(block.x[k], block.y[k], block.z[k]) - ray.origin;
            const double t = p.dot(ray.direction);
            const double a = p.dot(ray.cone.u);
            const double b = p.dot(ray.cone.v);
            const double r = block.radius[k];
            const double within = reach + r;
            const double depth_scale = p.norm() + r + std::abs(t_min) + std::abs(t_max);
            const bool is_decided = decided({{t + r, t_min, depth_scale, false},
                                             {t - r, t_max, depth_scale, true},
                                             beyond(a * a + b * b, within, p.norm())});
            ASSERT_TRUE(
                agreement.add(((simd >> k) & 1u) != 0, ((scalar >> k) & 1u) != 0, is_decided))
                << "case " << i << " sphere " << k;
        }
    }
    agreement.expect_consistent();
}

TEST_P(ConeBlockKernels, SpheresNearAxisInASquareAgreeWithScalar) {
    // The triangle cull's square (GaussianSquare) on top of the circle: spheres whose mapped
    // centres lie inside, on and beyond its sides, for frames of every orientation and
    // anisotropy.
    std::mt19937_64 rng(47);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    Agreement agreement;
    for (int i = 0; i < 20000; ++i) {
        const ConeRay ray = random_ray(rng);
        const float scale = std::pow(10.0f, 2.0f * unit(rng));
        GaussianFrame frame;
        const float angle = 3.14159265f * unit(rng);
        frame.axis = Vec2f(std::cos(angle), std::sin(angle));
        frame.inverse_semi_axes = Vec2f(1.0f, std::pow(10.0f, 0.9f * (1.0f + unit(rng)))) / scale;
        const float units = 2.5f;
        const GaussianSquare square = frame.square(units);
        const std::uint32_t count = static_cast<std::uint32_t>(i) % (kConeClusterSize + 1);
        ConeBoundBlock block;
        for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
            const float radius = random_radius(rng, 0.3f * scale);
            // A direction in the frame's units, scaled so that its larger coordinate lies at
            // the square's side widened by the radius (times a factor around 1), and back.
            const Vec2f g = Vec2f(unit(rng), unit(rng));
            const float side = (units + square.stretch * radius) * random_reach_factor(rng) /
                               g.cwiseAbs().maxCoeff();
            const Mat2f m = (Mat2f() << square.m00, square.m01, square.m01, square.m11).finished();
            const Vec2f across = m.inverse() * (side * g);
            const Vec3f centre = ray.origin +
                                 scale * 8.0f * (1.0f + 0.5f * unit(rng)) * ray.direction +
                                 across.x() * ray.cone.u + across.y() * ray.cone.v;
            block.x[k] = centre.x();
            block.y[k] = centre.y();
            block.z[k] = centre.z();
            block.radius[k] = radius;
        }
        const float reach = std::numeric_limits<float>::max();
        const std::uint32_t simd = spheres_near_axis(block, count, ray, reach, 0.0f, 1e30f, square);
        const std::uint32_t scalar =
            spheres_near_axis_scalar(block, count, ray, reach, 0.0f, 1e30f, square);
        ASSERT_EQ(simd & unused_bits(count, kConeClusterSize), 0u) << "case " << i;
        for (std::uint32_t k = 0; k < count; ++k) {
            const Vec3f p = Vec3f(block.x[k], block.y[k], block.z[k]) - ray.origin;
            const double t = p.dot(ray.direction);
            const double a = p.dot(ray.cone.u);
            const double b = p.dot(ray.cone.v);
            const double r = block.radius[k];
            const double gx = square.m00 * a + square.m01 * b;
            const double gy = square.m01 * a + square.m11 * b;
            const double size = std::abs(t) + std::abs(a) + std::abs(b) + r;
            const double slack =
                square.reach + square.stretch * r + kGaussianSquareRounding * square.stretch * size;
            // The mapped coordinates round with the ray-frame coordinates they come from.
            const double mapped_scale = square.stretch * (p.norm() + r) + slack;
            const bool is_decided = decided({{std::abs(gx), slack, mapped_scale, true},
                                             {std::abs(gy), slack, mapped_scale, true}});
            ASSERT_TRUE(
                agreement.add(((simd >> k) & 1u) != 0, ((scalar >> k) & 1u) != 0, is_decided))
                << "case " << i << " sphere " << k;
        }
    }
    agreement.expect_consistent();
}

TEST_P(ConeBlockKernels, VoxelsWithinClipAgreeWithScalar) {
    std::mt19937_64 rng(43);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_int_distribution<int> code(0, 255);
    Agreement agreement;
    for (int i = 0; i < 20000; ++i) {
        VoxelGaussian voxels;
        const float scale = std::pow(10.0f, unit(rng));
        voxels.first = Vec2f(unit(rng), unit(rng)) * 4.0f * scale;
        for (Vec2f& step : voxels.step) {
            step = Vec2f(unit(rng), unit(rng)) * 0.05f * scale;
        }
        voxels.clip = std::sqrt(kPointWeightClipExponent);
        voxels.offset_stretch = unit(rng) < -0.8f ? 0.0f : 0.01f * (1.0f + unit(rng));
        const std::uint32_t count = static_cast<std::uint32_t>(i) % (kConeClusterSize + 1);
        ConeVoxelBlock block;
        for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
            block.x[k] = static_cast<std::uint8_t>(code(rng));
            block.y[k] = static_cast<std::uint8_t>(code(rng));
            block.z[k] = static_cast<std::uint8_t>(code(rng));
            block.offset[k] = static_cast<std::int8_t>(code(rng) - 128);
        }
        // Some cases put voxel 0 on the clip: the first voxel's centre where the reach ends.
        if (unit(rng) > 0.5f) {
            block.x[0] = block.y[0] = block.z[0] = 0;
            const float reach =
                voxels.clip + voxels.offset_stretch * std::abs(static_cast<float>(block.offset[0]));
            voxels.first = Vec2f(unit(rng), unit(rng)).normalized() * reach;
        }
        const std::uint32_t simd = voxels_within_clip(block, count, voxels);
        const std::uint32_t scalar = voxels_within_clip_scalar(block, count, voxels);
        ASSERT_EQ(simd & unused_bits(count, kConeClusterSize), 0u) << "case " << i;
        for (std::uint32_t k = 0; k < count; ++k) {
            Eigen::Vector2d g = voxels.first.cast<double>();
            const std::array<int, 3> index{block.x[k], block.y[k], block.z[k]};
            for (std::size_t axis = 0; axis < 3; ++axis) {
                g += index[axis] * voxels.step[axis].cast<double>();
            }
            const double reach = voxels.clip + voxels.offset_stretch *
                                                   std::abs(static_cast<double>(block.offset[k]));
            double magnitude = voxels.first.cast<double>().norm();
            for (std::size_t axis = 0; axis < 3; ++axis) {
                magnitude += index[axis] * voxels.step[axis].cast<double>().norm();
            }
            const bool is_decided = decided({beyond(g.squaredNorm(), reach, magnitude)});
            ASSERT_TRUE(
                agreement.add(((simd >> k) & 1u) != 0, ((scalar >> k) & 1u) != 0, is_decided))
                << "case " << i << " point " << k;
        }
    }
    agreement.expect_consistent();
}

TEST_P(ConeBlockKernels, ChildrenNearConeAgreeWithScalar) {
    std::mt19937_64 rng(47);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    Agreement agreement;
    for (int i = 0; i < 20000; ++i) {
        const ConeRay ray = random_ray(rng);
        const float max_anisotropy = 1.0f + 15.0f * positive(rng);
        const ConeSphereTest test(ray.cone, max_anisotropy);
        const float t_min = 2.0f * positive(rng);
        // Sometimes an empty depth range: every child wholly before or after it.
        const float t_max = unit(rng) > -0.9f ? 10.0f + 10.0f * positive(rng) : t_min - 0.5f;
        const std::uint32_t count = static_cast<std::uint32_t>(i) % (kConeChildCount + 1);
        const float scale = std::pow(10.0f, 2.0f * unit(rng) - 1.0f);
        ConeChildBlock block;
        for (std::uint32_t k = 0; k < kConeChildCount; ++k) {
            const float radius = random_radius(rng, scale);
            const float widening = unit(rng) < 0.0f ? 0.0f : 0.1f * scale * positive(rng);
            const bool at_depth_limit = unit(rng) > 0.6f;
            const float t = at_depth_limit ? (unit(rng) < 0.0f ? t_min - radius : t_max + radius) *
                                                 random_reach_factor(rng)
                                           : 25.0f * positive(rng) - 2.0f;
            // Around the circle's reach at the centre's depth.
            const float circle_reach =
                std::sqrt(
                    kPointWeightClipExponent *
                    (test.frobenius_squared(t) * (1.0f + 1.0f / (max_anisotropy * max_anisotropy)) +
                     widening * widening)) +
                radius;
            const Vec2f across =
                Vec2f(unit(rng), unit(rng)).normalized() * circle_reach * random_reach_factor(rng);
            const Vec3f centre =
                ray.origin + t * ray.direction + across.x() * ray.cone.u + across.y() * ray.cone.v;
            block.x[k] = centre.x();
            block.y[k] = centre.y();
            block.z[k] = centre.z();
            block.radius[k] = radius;
            block.widening[k] = widening;
        }
        std::array<float, kConeChildCount> simd_nearest{};
        std::array<float, kConeChildCount> scalar_nearest{};
        const std::uint32_t simd =
            children_near_cone(block, count, ray, test, t_min, t_max, simd_nearest);
        const std::uint32_t scalar =
            children_near_cone_scalar(block, count, ray, test, t_min, t_max, scalar_nearest);
        ASSERT_EQ(simd & unused_bits(count, kConeChildCount), 0u) << "case " << i;
        const ConeSphereTest::CircleCoefficients circle = test.circle();
        for (std::uint32_t k = 0; k < kConeChildCount; ++k) {
            const Vec3f centre(block.x[k], block.y[k], block.z[k]);
            const float r = block.radius[k];
            const SphereInRayFrame sphere = ray.sphere_of(centre, r);
            const double depth_scale = (centre - ray.origin).norm() + r;
            if (kExact) {
                ASSERT_EQ(simd_nearest[k], scalar_nearest[k]) << "case " << i << " child " << k;
            } else {
                ASSERT_NEAR(simd_nearest[k], scalar_nearest[k], 1e-6 * depth_scale)
                    << "case " << i << " child " << k;
            }
            if (k >= count) {
                continue;
            }
            // circle_may_touch's two comparisons, in the same floats.
            const float near = std::max(sphere.t - r, t_min);
            const float far = std::min(sphere.t + r, t_max);
            const float frobenius =
                std::max(test.frobenius_squared(near), test.frobenius_squared(far));
            const double circle_reach =
                std::sqrt(kPointWeightClipExponent *
                          (frobenius * (1.0f + circle.inverse_anisotropy_squared) +
                           block.widening[k] * block.widening[k])) +
                r;
            const bool is_decided =
                decided({{near, far, depth_scale + std::abs(t_min) + std::abs(t_max), true},
                         beyond(sphere.offset.squaredNorm(), circle_reach, depth_scale)});
            ASSERT_TRUE(
                agreement.add(((simd >> k) & 1u) != 0, ((scalar >> k) & 1u) != 0, is_decided))
                << "case " << i << " child " << k << " " << sphere;
        }
    }
    agreement.expect_consistent();
}

TEST_P(ConeBlockKernels, EmptyAndFullBlocksAgreeWithScalar) {
    std::mt19937_64 rng(53);
    const ConeRay ray = random_ray(rng);
    ConeBoundBlock spheres;
    ConeVoxelBlock voxels;
    ConeChildBlock children;
    // Every sphere on the axis at depth 5, every voxel at the Gaussian's centre.
    for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
        const Vec3f centre = ray.origin + 5.0f * ray.direction;
        spheres.x[k] = centre.x();
        spheres.y[k] = centre.y();
        spheres.z[k] = centre.z();
        spheres.radius[k] = 1.0f;
        if (k < kConeChildCount) {
            children.x[k] = centre.x();
            children.y[k] = centre.y();
            children.z[k] = centre.z();
            children.radius[k] = 1.0f;
        }
    }
    const VoxelGaussian gaussian{Vec2f::Zero(), {}, 1.0f, 0.0f};
    const ConeSphereTest test(ray.cone, 8.0f);
    for (const std::uint32_t count : {0u, 1u, kConeChildCount, kConeClusterSize, 1000u}) {
        const std::uint32_t all = (1u << std::min(count, kConeClusterSize)) - 1u;
        EXPECT_EQ(spheres_near_axis(spheres, count, ray, 1.0f, 0.0f, 10.0f), all);
        EXPECT_EQ(spheres_near_axis_scalar(spheres, count, ray, 1.0f, 0.0f, 10.0f), all);
        EXPECT_EQ(voxels_within_clip(voxels, count, gaussian), all);
        EXPECT_EQ(voxels_within_clip_scalar(voxels, count, gaussian), all);
        std::array<float, kConeChildCount> nearest{};
        const std::uint32_t children_all = (1u << std::min(count, kConeChildCount)) - 1u;
        EXPECT_EQ(children_near_cone(children, count, ray, test, 0.0f, 10.0f, nearest),
                  children_all);
        EXPECT_EQ(children_near_cone_scalar(children, count, ray, test, 0.0f, 10.0f, nearest),
                  children_all);
    }
}

TEST_P(ConeBlockKernels, DamagedSpheresAnsweredAsScalar) {
    // Sphere k of the block is damaged in the k-th way; far off the axis, all would be cleared.
    ConeRay ray;
    ConeBoundBlock block;
    for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
        block.x[k] = 100.0f;
        block.z[k] = 5.0f;
        block.radius[k] = 1.0f;
    }
    block.x[1] = kNaN;
    block.y[2] = kNaN;
    block.z[3] = kNaN;
    block.radius[4] = kNaN;
    block.radius[5] = kInf;
    block.x[6] = kInf;
    block.z[7] = -kInf;
    block.radius[8] = -kInf;
    block.x[9] = std::numeric_limits<float>::max();
    const std::uint32_t damaged = 0b1111110u;
    const std::uint32_t mask = spheres_near_axis(block, kConeClusterSize, ray, 1.0f, 0.0f, 10.0f);
    EXPECT_EQ(mask, spheres_near_axis_scalar(block, kConeClusterSize, ray, 1.0f, 0.0f, 10.0f));
    // A NaN never clears the bit of a sphere in use.
    EXPECT_EQ(mask & damaged, damaged);
    ConeRay broken = ray;
    broken.direction.x() = kNaN;
    broken.cone.u.y() = kNaN;
    for (const std::uint32_t count : {0u, 3u, kConeClusterSize}) {
        EXPECT_EQ(spheres_near_axis(block, count, broken, 1.0f, 0.0f, 10.0f),
                  spheres_near_axis_scalar(block, count, broken, 1.0f, 0.0f, 10.0f));
        EXPECT_EQ(spheres_near_axis(block, count, ray, kNaN, 0.0f, 10.0f),
                  spheres_near_axis_scalar(block, count, ray, kNaN, 0.0f, 10.0f));
        EXPECT_EQ(spheres_near_axis(block, count, ray, 1.0f, kNaN, kNaN),
                  spheres_near_axis_scalar(block, count, ray, 1.0f, kNaN, kNaN));
        EXPECT_EQ(spheres_near_axis(block, count, ray, kInf, -kInf, kInf),
                  spheres_near_axis_scalar(block, count, ray, kInf, -kInf, kInf));
    }
    EXPECT_EQ(spheres_near_axis(block, 3, broken, 1.0f, 0.0f, 10.0f), 0b111u);
}

TEST_P(ConeBlockKernels, DamagedVoxelsAnsweredAsScalar) {
    ConeVoxelBlock block;
    for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
        block.x[k] = static_cast<std::uint8_t>(k);
        block.offset[k] = static_cast<std::int8_t>(k % 2 == 0 ? -128 : 127);
    }
    VoxelGaussian near_axis{
        Vec2f(0.1f, 0.0f), {Vec2f(0.01f, 0.0f), Vec2f::Zero(), Vec2f::Zero()}, 1.0f, 0.001f};
    EXPECT_EQ(voxels_within_clip(block, kConeClusterSize, near_axis), 0xffffu);
    const auto agree = [&](const VoxelGaussian& voxels) {
        for (const std::uint32_t count : {0u, 5u, kConeClusterSize}) {
            EXPECT_EQ(voxels_within_clip(block, count, voxels),
                      voxels_within_clip_scalar(block, count, voxels))
                << "count " << count;
        }
    };
    // A NaN centre clears its bit.
    VoxelGaussian nan_centre = near_axis;
    nan_centre.first.y() = kNaN;
    EXPECT_EQ(voxels_within_clip(block, kConeClusterSize, nan_centre), 0u);
    agree(nan_centre);
    VoxelGaussian nan_step = near_axis;
    nan_step.step[0].x() = kNaN;  // 0·NaN is NaN too: every centre, voxel 0's included
    EXPECT_EQ(voxels_within_clip(block, kConeClusterSize, nan_step), 0u);
    agree(nan_step);
    VoxelGaussian infinite_clip = near_axis;
    infinite_clip.clip = kInf;
    agree(infinite_clip);
    VoxelGaussian nan_clip = near_axis;
    nan_clip.clip = kNaN;
    agree(nan_clip);
    VoxelGaussian infinite_centre = near_axis;
    infinite_centre.first.x() = kInf;
    agree(infinite_centre);
}

TEST_P(ConeBlockKernels, DamagedChildrenAnsweredAsScalar) {
    std::mt19937_64 rng(59);
    const ConeRay ray = random_ray(rng);
    const ConeSphereTest test(ray.cone, 8.0f);
    // Far beside the axis, every child would be cleared.
    ConeChildBlock block;
    for (std::uint32_t k = 0; k < kConeChildCount; ++k) {
        const Vec3f centre = ray.origin + 5.0f * ray.direction + 1e4f * ray.cone.u;
        block.x[k] = centre.x();
        block.y[k] = centre.y();
        block.z[k] = centre.z();
        block.radius[k] = 1.0f;
        block.widening[k] = 0.01f;
    }
    block.x[1] = kNaN;
    block.radius[2] = kNaN;
    block.radius[3] = kInf;
    block.widening[4] = kNaN;
    block.widening[5] = kInf;
    block.y[6] = -kInf;
    const std::uint32_t damaged = 0b1111110u;
    std::array<float, kConeChildCount> simd_nearest{};
    std::array<float, kConeChildCount> scalar_nearest{};
    const auto agree = [&](const ConeRay& r, const ConeSphereTest& t, float t_min, float t_max) {
        for (const std::uint32_t count : {0u, 3u, kConeChildCount}) {
            const std::uint32_t simd =
                children_near_cone(block, count, r, t, t_min, t_max, simd_nearest);
            const std::uint32_t scalar =
                children_near_cone_scalar(block, count, r, t, t_min, t_max, scalar_nearest);
            EXPECT_EQ(simd, scalar) << "count " << count << " t " << t_min << ".." << t_max;
            for (std::uint32_t k = 0; k < kConeChildCount; ++k) {
                // NaN == NaN is false; both NaN is the same answer. Fused multiply-adds may
                // round the depth differently.
                const bool both_nan = std::isnan(simd_nearest[k]) && std::isnan(scalar_nearest[k]);
                const float gap = std::abs(simd_nearest[k] - scalar_nearest[k]);
                const float magnitude =
                    (Vec3f(block.x[k], block.y[k], block.z[k]) - r.origin).norm() +
                    std::abs(block.radius[k]);
                EXPECT_TRUE(both_nan || simd_nearest[k] == scalar_nearest[k] ||
                            (!kExact && gap <= 1e-6f * magnitude))
                    << "child " << k;
            }
        }
    };
    // Non-finite input never clears a bit; what is finite and far beside the axis is cleared.
    EXPECT_EQ(children_near_cone(block, kConeChildCount, ray, test, 0.0f, 10.0f, simd_nearest),
              damaged);
    agree(ray, test, 0.0f, 10.0f);
    // A NaN depth limit is passed over by std::max and std::min, an infinite one is not finite.
    agree(ray, test, kNaN, 10.0f);
    agree(ray, test, 0.0f, kNaN);
    agree(ray, test, -kInf, kInf);
    // Wholly before or after the depth range: cleared unless damaged.
    agree(ray, test, 20.0f, 30.0f);
    agree(ray, test, -10.0f, -5.0f);
    // A damaged cone, and no cone yet: every child may touch.
    ConeRay broken = ray;
    broken.cone.incr_dev(0, 1) = kNaN;
    const ConeSphereTest broken_test(broken.cone, 8.0f);
    EXPECT_EQ(children_near_cone(block, 5, ray, broken_test, 0.0f, 10.0f, simd_nearest), 0b11111u);
    agree(ray, broken_test, 0.0f, 10.0f);
    agree(ray, ConeSphereTest(), 0.0f, 10.0f);
    // A cone so wide its coefficients overflow to infinity: conservative, not NaN.
    ConeRay huge = ray;
    huge.cone.incr_dev = Mat2f::Constant(1e30f);
    agree(huge, ConeSphereTest(huge.cone, 8.0f), 0.0f, 10.0f);
    agree(huge, ConeSphereTest(huge.cone, 8.0f), 0.0f, 0.0f);
    // A damaged ray direction.
    ConeRay damaged_ray = ray;
    damaged_ray.direction.z() = kNaN;
    agree(damaged_ray, test, 0.0f, 10.0f);
}

/// Bounding spheres around random rays' axes, near and on the test's boundaries: `n` of them in
/// the fields a ConeClusterSpheres is built from.
TEST_P(ConeBlockKernels, ClustersNearAxisAgreeWithScalar) {
    // A node's clusters are read from arrays of all of them, at any offset, the last block
    // short: every count from 0 to a full block at the arrays' end (where only the padding
    // follows) and in their middle.
    std::mt19937_64 rng(53);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    Agreement agreement;
    for (int i = 0; i < 4000; ++i) {
        const ConeRay ray = random_ray(rng);
        const RandomReach range(rng);
        const auto [scale, reach, t_min, t_max] = range;
        std::vector<RandomSphere> spheres(40);
        for (RandomSphere& sphere : spheres) {
            sphere = random_sphere_at_reach(rng, ray, range);
        }
        const ConeClusterSpheres block(spheres);
        ASSERT_EQ(block.size(), spheres.size());
        const std::uint32_t count = static_cast<std::uint32_t>(i) % (kConeClusterSize + 1);
        for (const std::uint32_t first :
             {0u, 3u, static_cast<std::uint32_t>(spheres.size()) - count}) {
            const std::uint32_t simd =
                clusters_near_axis(block, first, count, ray, reach, t_min, t_max);
            const std::uint32_t scalar =
                clusters_near_axis_scalar(block, first, count, ray, reach, t_min, t_max);
            ASSERT_EQ(simd & unused_bits(count, kConeClusterSize), 0u) << "case " << i;
            for (std::uint32_t k = 0; k < count; ++k) {
                const RandomSphere& sphere = spheres[first + k];
                const Vec3f p =
                    Vec3f(sphere.centre[0], sphere.centre[1], sphere.centre[2]) - ray.origin;
                const double t = p.dot(ray.direction);
                const double a = p.dot(ray.cone.u);
                const double b = p.dot(ray.cone.v);
                const double r = sphere.radius;
                const double within = reach + r;
                const double depth_scale = p.norm() + r + std::abs(t_min) + std::abs(t_max);
                const bool is_decided = decided({{t + r, t_min, depth_scale, false},
                                                 {t - r, t_max, depth_scale, true},
                                                 beyond(a * a + b * b, within, p.norm())});
                // The reference is the traversal's own test of one sphere, and the double-precision
                // answer where rounding cannot decide it.
                if (is_decided) {
                    const bool exact =
                        !(t + r < t_min || t - r > t_max || a * a + b * b > within * within);
                    ASSERT_EQ(((scalar >> k) & 1u) != 0, exact) << "case " << i << " sphere " << k;
                }
                ASSERT_TRUE(
                    agreement.add(((simd >> k) & 1u) != 0, ((scalar >> k) & 1u) != 0, is_decided))
                    << "case " << i << " sphere " << k;
            }
        }
    }
    agreement.expect_consistent();
}

TEST_P(ConeBlockKernels, ClustersNearAxisKeepDamagedSpheresAndNoPadding) {
    ConeRay ray;
    ray.cone.incr_dev = Mat2f::Identity() * 0.01f;
    // On the axis, beside it, damaged, and past the end (padding).
    const std::vector<RandomSphere> spheres{{{0.0f, 0.0f, 5.0f}, 0.1f},
                                            {{50.0f, 0.0f, 5.0f}, 0.1f},
                                            {{kNaN, 0.0f, 5.0f}, 0.1f},
                                            {{0.0f, 0.0f, 5.0f}, kNaN},
                                            {{0.0f, kInf, 5.0f}, 0.1f}};
    const ConeClusterSpheres block(spheres);
    // Only the sphere beside the axis is rejected: a NaN passes every test, and so does an
    // infinite coordinate (times the ray's zero components it is NaN).
    const std::uint32_t expected = 0b11101u;
    for (std::uint32_t count = 0; count <= kConeClusterSize; ++count) {
        const std::uint32_t used = std::min<std::uint32_t>(count, 5);
        const std::uint32_t mask = expected & ((1u << used) - 1u);
        EXPECT_EQ(clusters_near_axis(block, 0, used, ray, 1.0f, 0.0f, 10.0f), mask) << count;
        EXPECT_EQ(clusters_near_axis_scalar(block, 0, used, ray, 1.0f, 0.0f, 10.0f), mask) << count;
    }
    // A block read from the last sphere runs into the padding, which no finite depth range
    // holds (and whose bits are cleared besides).
    for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
        EXPECT_EQ(block.radius[block.size() + k], -kInf);
    }
    EXPECT_EQ(clusters_near_axis(block, static_cast<std::uint32_t>(block.size()), kConeClusterSize,
                                 ray, 1e30f, -1e30f, 1e30f),
              0u);
    EXPECT_EQ(clusters_near_axis(block, 4, 1, ray, 1e30f, -1e30f, 1e30f), 1u);
    const ConeClusterSpheres none;
    EXPECT_EQ(none.size(), 0u);
    EXPECT_EQ(clusters_near_axis(none, 0, 0, ray, 1e30f, -kInf, kInf), 0u);
}

/// A triangle cull of a random cone: its depths, the frame of its footprint somewhere between
/// them (anisotropy-clamped as the traversal's are), and the square's reach in the frame's units
/// (none, one time in eight).
TriangleCull random_triangle_cull(std::mt19937_64& rng, const ConeRay& ray,
                                  const RandomReach& range) {
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    TriangleCull cull;
    cull.t_min = range.t_min;
    cull.t_max = range.t_max;
    const float t = range.t_min + positive(rng) * (range.t_max - range.t_min);
    cull.frame = GaussianFrame::of(FootprintCone::clamp_anisotropy(ray.cone.at(t), 8.0f));
    cull.reach = positive(rng) < 0.125f ? kInf : 3.0f * positive(rng);
    return cull;
}

/// A vertex placed by its depth and its coordinates y in `cull`'s frame (the inverse of
/// GaussianFrame::map: U·Λ^(1/2)·Uᵀ·y).
Vec3f vertex_at(const ConeRay& ray, const TriangleCull& cull, float t, const Vec2f& y) {
    const Vec2f& axis = cull.frame.axis;
    const Vec2f minor(-axis.y(), axis.x());
    const Vec2f offset = y.dot(axis) / cull.frame.inverse_semi_axes.x() * axis +
                         y.dot(minor) / cull.frame.inverse_semi_axes.y() * minor;
    return ray.origin + t * ray.direction + offset.x() * ray.cone.u + offset.y() * ray.cone.v;
}

/// A triangle near one of the cull's boundaries: all three vertices around one depth limit or
/// around one side of the square (within a few ulps of it or well to either side), or
/// straddling the cone.
std::array<Vec3f, 3> random_triangle_at_cull(std::mt19937_64& rng, const ConeRay& ray,
                                             const TriangleCull& cull, float scale) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_int_distribution<int> side(0, 6);
    const float reach = std::isfinite(cull.reach) ? cull.reach : 3.0f;
    const int which = side(rng);
    std::array<Vec3f, 3> p;
    for (Vec3f& vertex : p) {
        float t = cull.t_min + (cull.t_max - cull.t_min) * 0.5f * (1.0f + unit(rng));
        Vec2f y(reach * unit(rng), reach * unit(rng));
        switch (which) {
            case 0:
                t = cull.t_min * random_reach_factor(rng) - 0.1f * scale * (1.0f + unit(rng));
                break;
            case 1:
                t = cull.t_max * random_reach_factor(rng);
                break;
            case 2:
            case 3:
            case 4:
            case 5: {
                const float sign = which % 2 == 0 ? 1.0f : -1.0f;
                y[which < 4 ? 0 : 1] = sign * reach * random_reach_factor(rng);
                break;
            }
            default:
                y *= 2.0f;
        }
        vertex = vertex_at(ray, cull, t, y);
    }
    return p;
}

TEST_P(ConeBlockKernels, TrianglesWithinCullAgreeWithScalar) {
    std::mt19937_64 rng(59);
    std::uniform_int_distribution<std::uint32_t> bits(0, (1u << kConeClusterSize) - 1u);
    Agreement agreement;
    for (int i = 0; i < 3000; ++i) {
        const ConeRay ray = random_ray(rng);
        const RandomReach range(rng);
        const TriangleCull cull = random_triangle_cull(rng, ray, range);
        if (!(cull.frame.inverse_semi_axes.minCoeff() > 0.0f)) {
            continue;
        }
        ConeTriangleBlock block;
        for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
            block.set(k, random_triangle_at_cull(rng, ray, cull, range.scale));
        }
        // Any subset of the members: the spheres' test lets some through.
        const std::uint32_t candidates = i % 4 == 0 ? (1u << kConeClusterSize) - 1u : bits(rng);
        const std::uint32_t simd = triangles_within_cull(block, candidates, ray, cull);
        const std::uint32_t scalar = triangles_within_cull_scalar(block, candidates, ray, cull);
        ASSERT_EQ(simd & ~candidates, 0u) << "case " << i;
        ASSERT_EQ(scalar & ~candidates, 0u) << "case " << i;
        for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
            if (((candidates >> k) & 1u) == 0) {
                continue;
            }
            // In double precision: culled where every vertex lies beyond one bound.
            std::array<bool, 6> beyond_all;
            beyond_all.fill(true);
            bool marginal = false;
            const std::array<Vec3f, 3> p = block.vertices(k);
            for (const Vec3f& vertex : p) {
                const Eigen::Vector3d d = (vertex - ray.origin).cast<double>();
                const double t = d.dot(ray.direction.cast<double>());
                const Eigen::Vector2d offset(d.dot(ray.cone.u.cast<double>()),
                                             d.dot(ray.cone.v.cast<double>()));
                const Eigen::Vector2d axis = cull.frame.axis.cast<double>();
                const Eigen::Vector2d minor(-axis.y(), axis.x());
                const Eigen::Vector2d y =
                    offset.dot(axis) * double{cull.frame.inverse_semi_axes.x()} * axis +
                    offset.dot(minor) * double{cull.frame.inverse_semi_axes.y()} * minor;
                const double depth_scale =
                    d.norm() + std::abs(double{cull.t_min}) + std::abs(double{cull.t_max});
                const double map_scale =
                    d.norm() * double{cull.frame.inverse_semi_axes.maxCoeff()} + cull.reach;
                const std::array<Rejection, 6> sides{
                    Rejection{t, cull.t_min, depth_scale, false},
                    Rejection{t, cull.t_max, depth_scale, true},
                    Rejection{y.x(), cull.reach, map_scale, true},
                    Rejection{y.x(), -double{cull.reach}, map_scale, false},
                    Rejection{y.y(), cull.reach, map_scale, true},
                    Rejection{y.y(), -double{cull.reach}, map_scale, false}};
                for (std::size_t s = 0; s < sides.size(); ++s) {
                    beyond_all[s] = beyond_all[s] && sides[s].holds();
                    // Without a square only the depths can be marginal.
                    marginal =
                        marginal || ((s < 2 || std::isfinite(cull.reach)) && sides[s].marginal());
                }
            }
            const bool exact_kept = std::none_of(beyond_all.begin(), beyond_all.end(),
                                                 [](bool culled) { return culled; });
            const bool simd_kept = ((simd >> k) & 1u) != 0;
            const bool scalar_kept = ((scalar >> k) & 1u) != 0;
            // The reference is the traversal's own test of one triangle; the kernel may keep
            // what it rejects only on a boundary, never reject what it keeps but there.
            if (!marginal) {
                ASSERT_EQ(scalar_kept, exact_kept) << "case " << i << " triangle " << k;
            }
            ASSERT_TRUE(agreement.add(simd_kept, scalar_kept, !marginal))
                << "case " << i << " triangle " << k;
        }
    }
    agreement.expect_consistent();
}

TEST_P(ConeBlockKernels, TrianglesWithinCullKeepDamagedTriangles) {
    ConeRay ray;
    ray.cone.incr_dev = Mat2f::Identity() * 0.01f;
    TriangleCull cull;
    cull.t_min = 1.0f;
    cull.t_max = 10.0f;
    cull.frame = GaussianFrame::of(ray.cone.at(5.0f));
    cull.reach = 2.0f;
    ConeTriangleBlock block;
    const Vec3f x = Vec3f::UnitX();
    const Vec3f y = Vec3f::UnitY();
    const Vec3f z = Vec3f::UnitZ();
    // Footprint 0.05 at depth 5: the square reaches 0.1 off the axis.
    const std::array<std::array<Vec3f, 3>, 8> triangles{{
        {5.0f * z - 0.2f * x, 5.0f * z + 0.2f * x, 5.0f * z + 0.2f * y},      // around the axis
        {5.0f * z + x, 5.0f * z + 2.0f * x, 5.0f * z + x + y},                // beside it
        {5.0f * z + x, Vec3f(kNaN, 0.0f, 5.0f), 5.0f * z + x + y},            // beside, damaged
        {0.5f * z, 0.6f * z, 0.7f * z + 0.01f * x},                           // before t_min
        {11.0f * z, 12.0f * z, 12.0f * z + 0.01f * x},                        // after t_max
        {0.5f * z, Vec3f(0.0f, 0.0f, kNaN), 0.7f * z},                        // before, damaged
        {5.0f * z - 3.0f * y, 5.0f * z - 3.0f * y + x, 5.0f * z - 4.0f * y},  // below
        {5.0f * z - 3.0f * y, 5.0f * z + 3.0f * y, 5.0f * z + 0.5f * x},      // across
    }};
    for (std::uint32_t k = 0; k < triangles.size(); ++k) {
        block.set(k, triangles[k]);
    }
    const std::uint32_t all = (1u << triangles.size()) - 1u;
    // The kernel keeps what has a NaN vertex (the reference decides); the rest as the
    // reference, which a NaN vertex does not stop from rejecting by the other two.
    EXPECT_EQ(triangles_within_cull(block, all, ray, cull), 0b10100101u);
    EXPECT_EQ(triangles_within_cull_scalar(block, all, ray, cull), 0b10000001u);
    EXPECT_EQ(triangles_within_cull(block, 0b10100000u, ray, cull), 0b10100000u);
    EXPECT_EQ(triangles_within_cull(block, 0, ray, cull), 0u);
    // Without a square only the depths reject.
    cull.reach = kInf;
    EXPECT_EQ(triangles_within_cull(block, all, ray, cull), 0b11100111u);
    EXPECT_EQ(triangles_within_cull_scalar(block, all, ray, cull), 0b11000111u);
}

}  // namespace
}  // namespace mrt
