// The sixteen-wide sphere test answers as one sphere's test does (a scalar reference in double,
// with the traversal's circle test written out), for random cones, spheres around the test's
// boundaries, unused slots and damaged input.

#include "trace/cone/cone_bound_block.h"

#include "trace/cone/cone_triangle.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>

namespace mrt {
namespace {

/// One sphere's test in double: depths overlapping [t_min, t_max] and the centre within
/// reach + radius of the axis. `margin` (relative) widens or narrows it to bracket rounding.
bool near_axis(const ConeRay& ray, const Vec3f& centre, float radius, float reach, float t_min,
               float t_max, double margin) {
    const Eigen::Vector3d p = (centre - ray.origin).cast<double>();
    const double t = p.dot(ray.direction.cast<double>());
    const double a = p.dot(ray.cone.u.cast<double>());
    const double b = p.dot(ray.cone.v.cast<double>());
    const double r = radius * (1.0 + margin);
    const double within = (reach + static_cast<double>(radius)) * (1.0 + margin);
    return t + r >= t_min && t - r <= t_max && a * a + b * b <= within * within;
}

/// A ray from within 10 of the origin in a random direction (its cone is not read).
ConeRay random_axis(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    ConeRay ray;
    ray.origin = Vec3f(unit(rng), unit(rng), unit(rng)) * 10.0f;
    ray.direction = Vec3f(unit(rng), unit(rng), unit(rng)).normalized();
    orthonormal_basis(ray.direction, ray.cone.u, ray.cone.v);
    return ray;
}

TEST(ConeBoundBlock, EachBitIsThatSpheresTest) {
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    int set = 0;
    int clear = 0;
    for (int i = 0; i < 5000; ++i) {
        const ConeRay ray = random_axis(rng);
        const float reach = 0.5f * (1.0f + unit(rng));
        const float t_min = 2.0f + unit(rng);
        const float t_max = 10.0f + 5.0f * unit(rng);
        ConeBoundBlock block;
        const std::uint32_t count = 1 + static_cast<std::uint32_t>(i % kConeClusterSize);
        for (std::uint32_t k = 0; k < count; ++k) {
            // Around the axis's reach and the depth limits, where the answers change.
            const float t = 8.0f * (1.0f + unit(rng));
            const Vec3f across = ray.cone.u * unit(rng) + ray.cone.v * unit(rng);
            const Vec3f centre = ray.origin + t * ray.direction + 1.5f * across;
            block.x[k] = centre.x();
            block.y[k] = centre.y();
            block.z[k] = centre.z();
            block.radius[k] = 0.5f * (1.0f + unit(rng));
        }
        const std::uint32_t mask = spheres_near_axis(block, count, ray, reach, t_min, t_max);
        for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
            const bool bit = (mask >> k) & 1u;
            if (k >= count) {
                ASSERT_FALSE(bit) << "unused slot " << k;
                continue;
            }
            const Vec3f centre(block.x[k], block.y[k], block.z[k]);
            // Set wherever the sphere clearly may hold something, clear wherever it clearly
            // cannot; within rounding of the boundary either answer is right.
            if (near_axis(ray, centre, block.radius[k], reach, t_min, t_max, -1e-4)) {
                ASSERT_TRUE(bit) << "case " << i << " sphere " << k;
            }
            if (!near_axis(ray, centre, block.radius[k], reach, t_min, t_max, 1e-4)) {
                ASSERT_FALSE(bit) << "case " << i << " sphere " << k;
            }
            (bit ? set : clear) += 1;
        }
    }
    // The cases straddle the test: both answers are common.
    EXPECT_GT(set, 5000);
    EXPECT_GT(clear, 5000);
}

TEST(ConeBoundBlock, DamagedInputNeverClearsABit) {
    ConeRay ray;
    ConeBoundBlock block;
    block.x[0] = 100.0f;  // far off the axis: cleared when everything is finite
    block.z[0] = 5.0f;
    block.radius[0] = 1.0f;
    EXPECT_EQ(spheres_near_axis(block, 1, ray, 1.0f, 0.0f, 10.0f), 0u);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    EXPECT_EQ(spheres_near_axis(block, 1, ray, nan, 0.0f, 10.0f), 1u);
    ConeRay broken = ray;
    broken.direction.x() = nan;
    broken.cone.u.x() = nan;
    EXPECT_EQ(spheres_near_axis(block, 1, broken, 1.0f, 0.0f, 10.0f), 1u);
    // Unused slots stay clear even where the broken ray would set them.
    EXPECT_EQ(spheres_near_axis(block, 3, broken, 1.0f, 0.0f, 10.0f), 7u);
    block.x[0] = nan;
    EXPECT_EQ(spheres_near_axis(block, 1, ray, 1.0f, 0.0f, 10.0f), 1u);
}

/// A Gaussian frame of the kinds the traversal culls with: any orientation, anisotropy up to 8
/// and beyond, units from 1e-3 to 1e3 of the ray's.
GaussianFrame random_frame(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    const float angle = 3.14159265f * unit(rng);
    const float scale = std::pow(10.0f, 3.0f * unit(rng));
    GaussianFrame frame;
    frame.axis = Vec2f(std::cos(angle), std::sin(angle));
    frame.inverse_semi_axes = Vec2f(scale, scale * std::pow(10.0f, 1.2f * (1.0f + unit(rng)) / 2));
    return frame;
}

TEST(ConeBoundBlock, ASquareRejectsOnlyWhatTheTriangleCullRejects) {
    // Where the square clears a sphere's bit, every triangle inside the sphere lies beyond the
    // square on one side in the frame's units (misses_square on its vertices, as the traversal
    // maps them): the block rejects only what the per-triangle cull would have. Vertices are
    // drawn in the sphere and on its surface at the point the map brings nearest the square.
    std::mt19937_64 rng(29);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    int rejected = 0;
    int spheres = 0;
    for (int i = 0; i < 4000; ++i) {
        const ConeRay ray = random_axis(rng);
        const GaussianFrame frame = random_frame(rng);
        // The traversal's per-vertex cull: its margin over the coverage weight's clip radius.
        const float reach = 1.25f * triangle_clip_radius(TriangleWeight::Coverage);
        const GaussianSquare square = frame.square(reach);
        const float units = 1.0f / frame.inverse_semi_axes.minCoeff();  // the wider semi-axis
        ConeBoundBlock block;
        for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
            const float radius = units * std::pow(10.0f, unit(rng));
            const Vec2f across = Vec2f(unit(rng), unit(rng)) * 4.0f * units;
            const Vec3f centre = ray.origin + 5.0f * ray.direction + across.x() * ray.cone.u +
                                 across.y() * ray.cone.v;
            block.x[k] = centre.x();
            block.y[k] = centre.y();
            block.z[k] = centre.z();
            block.radius[k] = radius;
        }
        const float far = std::numeric_limits<float>::max();
        const std::uint32_t without =
            spheres_near_axis_scalar(block, kConeClusterSize, ray, far, 0.0f, 100.0f);
        const std::uint32_t with =
            spheres_near_axis_scalar(block, kConeClusterSize, ray, far, 0.0f, 100.0f, square);
        ASSERT_EQ(without, (1u << kConeClusterSize) - 1u);
        ASSERT_EQ(with, spheres_near_axis(block, kConeClusterSize, ray, far, 0.0f, 100.0f, square));
        for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
            ++spheres;
            if (((with >> k) & 1u) != 0) {
                continue;
            }
            ++rejected;
            const Vec3f centre(block.x[k], block.y[k], block.z[k]);
            const float r = block.radius[k];
            const auto mapped = [&](const Vec3f& p) { return frame.map(ray.frame_of(p).offset); };
            const Vec2f g = mapped(centre);
            // The surface point the map brings nearest the square along each axis.
            std::array<Vec3f, 4> extremes;
            for (int axis = 0; axis < 2; ++axis) {
                const Vec2f row =
                    axis == 0 ? Vec2f(square.m00, square.m01) : Vec2f(square.m01, square.m11);
                const Vec2f towards = -std::copysign(1.0f, g[axis]) * row.normalized() * r;
                extremes[static_cast<std::size_t>(2 * axis)] =
                    centre + towards.x() * ray.cone.u + towards.y() * ray.cone.v;
                extremes[static_cast<std::size_t>(2 * axis + 1)] =
                    centre + r * Vec3f(unit(rng), unit(rng), unit(rng)).normalized();
            }
            for (int triangle = 0; triangle < 4; ++triangle) {
                std::array<Vec2f, 3> y;
                for (std::size_t v = 0; v < 3; ++v) {
                    Vec3f inside = Vec3f(unit(rng), unit(rng), unit(rng));
                    if (inside.norm() > 1.0f) {
                        inside.normalize();
                    }
                    const Vec3f p = v == 0 ? extremes[static_cast<std::size_t>(triangle)]
                                           : centre + 0.999f * r * inside;
                    y[v] = mapped(p);
                }
                ASSERT_TRUE(misses_square(y, reach))
                    << "case " << i << " sphere " << k << ": centre maps to " << g.transpose()
                    << ", radius " << r << ", vertices " << y[0].transpose() << " / "
                    << y[1].transpose() << " / " << y[2].transpose();
            }
        }
    }
    // Not vacuous: the square rejects a good share of the spheres the circle let through.
    EXPECT_GT(rejected, spheres / 5);
    EXPECT_LT(rejected, spheres);
}

TEST(ConeBoundBlock, TheDefaultSquareKeepsEverything) {
    ConeRay ray;
    ConeBoundBlock block;
    block.x[0] = 1e30f;
    block.z[0] = 5.0f;
    block.radius[0] = 0.0f;
    const float far = std::numeric_limits<float>::infinity();
    EXPECT_EQ(spheres_near_axis(block, 1, ray, far, 0.0f, 10.0f, GaussianSquare{}), 1u);
    EXPECT_EQ(spheres_near_axis_scalar(block, 1, ray, far, 0.0f, 10.0f, GaussianSquare{}), 1u);
    // A frame of zero units (GaussianFrame{}) maps everything to the origin.
    const GaussianSquare zero = GaussianFrame{}.square(1.0f);
    EXPECT_EQ(spheres_near_axis(block, 1, ray, far, 0.0f, 10.0f, zero), 1u);
    // A damaged frame never clears a bit.
    GaussianFrame broken;
    broken.inverse_semi_axes = Vec2f(std::numeric_limits<float>::quiet_NaN(), 1.0f);
    EXPECT_EQ(spheres_near_axis(block, 1, ray, far, 0.0f, 10.0f, broken.square(1.0f)), 1u);
    broken.inverse_semi_axes = Vec2f(far, far);
    EXPECT_EQ(spheres_near_axis(block, 1, ray, far, 0.0f, 10.0f, broken.square(1.0f)), 1u);
}

TEST(ConeVoxelBlock, EachBitIsThatPointsCentreTest) {
    // Against the voxel centre computed anew in double: G⁻¹ times its offset from the axis,
    // within the clip plus what the point's offset code allows.
    std::mt19937_64 rng(29);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_int_distribution<int> code(0, 255);
    int set = 0;
    int clear = 0;
    for (int i = 0; i < 5000; ++i) {
        VoxelGaussian voxels;
        voxels.first = Vec2f(unit(rng), unit(rng)) * 4.0f;
        for (Vec2f& step : voxels.step) {
            step = Vec2f(unit(rng), unit(rng)) * 0.05f;
        }
        voxels.clip = 1.977883f;
        voxels.offset_stretch = 0.01f * (1.0f + unit(rng));
        ConeVoxelBlock block;
        const std::uint32_t count = 1 + static_cast<std::uint32_t>(i % kConeClusterSize);
        for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
            block.x[k] = static_cast<std::uint8_t>(code(rng));
            block.y[k] = static_cast<std::uint8_t>(code(rng));
            block.z[k] = static_cast<std::uint8_t>(code(rng));
            block.offset[k] = static_cast<std::int8_t>(code(rng) - 128);
        }
        const std::uint32_t mask = voxels_within_clip(block, count, voxels);
        for (std::uint32_t k = 0; k < kConeClusterSize; ++k) {
            const bool bit = (mask >> k) & 1u;
            if (k >= count) {
                ASSERT_FALSE(bit) << "unused slot " << k;
                continue;
            }
            Eigen::Vector2d g = voxels.first.cast<double>();
            const std::array<int, 3> index{block.x[k], block.y[k], block.z[k]};
            for (std::size_t a = 0; a < 3; ++a) {
                g += index[a] * voxels.step[a].cast<double>();
            }
            const double reach = voxels.clip + voxels.offset_stretch *
                                                   std::abs(static_cast<double>(block.offset[k]));
            if (g.norm() < reach * (1.0 - 1e-4)) {
                ASSERT_TRUE(bit) << "case " << i << " point " << k;
            }
            if (g.norm() > reach * (1.0 + 1e-4)) {
                ASSERT_FALSE(bit) << "case " << i << " point " << k;
            }
            (bit ? set : clear) += 1;
        }
    }
    EXPECT_GT(set, 2000);
    EXPECT_GT(clear, 2000);
}

}  // namespace
}  // namespace mrt
