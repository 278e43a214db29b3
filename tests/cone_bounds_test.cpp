// The cone–bounding-sphere test of §4.6 never skips a sphere the cone touches (checked against
// an exact, double-precision membership test of points inside random spheres, for random,
// anisotropic, nearly degenerate and focusing cones), skips what lies beside the minor axis of
// an anisotropic cone (where a circular test would not), and handles depth limits and damaged
// input conservatively.

#include "trace/cone_bounds.h"

#include "common/point_weight.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <random>

namespace mrt {
namespace {

/// Whether (t, x) lies inside the cone's clip ellipse at t, the footprint clamped to the
/// anisotropy limit and widened as the points are weighed: computed anew in double.
bool inside_cone(const FootprintCone& cone, double t, const Eigen::Vector2d& x,
                 double max_anisotropy, double widening) {
    const Eigen::Matrix2d f = cone.start_dev.cast<double>() + t * cone.incr_dev.cast<double>();
    const Eigen::Matrix2d c = f * f.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(c);
    const double minor = eigen.eigenvalues()(0), major = eigen.eigenvalues()(1);
    const Eigen::Vector2d minor_axis = eigen.eigenvectors().col(0);
    const double floor = major / (max_anisotropy * max_anisotropy);
    Eigen::Matrix2d m = c;
    if (minor < floor) {
        m += (floor - minor) * minor_axis * minor_axis.transpose();
    }
    m += widening * widening * Eigen::Matrix2d::Identity();
    if (std::abs(m.determinant()) < 1e-300) {
        return x.norm() == 0.0;
    }
    return x.dot(m.inverse() * x) <= static_cast<double>(kPointWeightClipExponent);
}

struct Case {
    FootprintCone cone;
    SphereInRayFrame sphere;
    float max_anisotropy;
    float widening;
};

/// Random cones of every kind the tracer makes: diverging from zero (pinhole), focusing
/// through zero (thin lens), nearly collinear columns (grazing reflections), and spheres placed
/// around the cone's edge, where the test has to be right.
Case random_case(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    Case c;
    const float scale = std::pow(10.0f, 3.0f * unit(rng));  // pixel footprints from 1e-3 to 1e3
    c.cone.incr_dev << unit(rng), unit(rng), unit(rng), unit(rng);
    c.cone.incr_dev *= 0.01f * scale;
    const int kind = static_cast<int>(positive(rng) * 3.0f);
    if (kind == 1) {
        // Focus at t = focus: zero footprint there, growing on both sides.
        const float focus = 10.0f * positive(rng);
        c.cone.start_dev = -focus * c.cone.incr_dev;
    } else if (kind == 2) {
        // Nearly collinear columns.
        c.cone.incr_dev.col(1) = c.cone.incr_dev.col(0) * (1.0f + 1e-4f * unit(rng));
    }
    c.max_anisotropy = 1.0f + 15.0f * positive(rng);
    c.widening = positive(rng) < 0.5f ? 0.0f : 0.01f * scale * positive(rng);
    c.sphere.t = 20.0f * positive(rng) - 2.0f;
    c.sphere.radius = 0.02f * scale * std::pow(10.0f, unit(rng));
    // Around the clip ellipse's edge at the sphere's depth.
    const Mat2f f = c.cone.at(std::max(c.sphere.t, 0.0f));
    const Vec2f direction = Vec2f(unit(rng), unit(rng)).normalized();
    const float reach = std::sqrt(kPointWeightClipExponent) * (f.transpose() * direction).norm();
    c.sphere.offset = direction * (reach + c.sphere.radius) * (0.5f + positive(rng));
    return c;
}

TEST(ConeBounds, NeverSkipsASphereTheConeTouches) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    int touching = 0, culled = 0;
    for (int n = 0; n < 6000; ++n) {
        const Case c = random_case(rng);
        const float t_min = 0.0f, t_max = 15.0f;
        bool touches = false;
        for (int i = 0; i < 400 && !touches; ++i) {
            Eigen::Vector3d q(unit(rng), unit(rng), unit(rng));
            if (q.squaredNorm() > 1.0) {
                continue;
            }
            q *= c.sphere.radius;
            const double t = c.sphere.t + q.z();
            const Eigen::Vector2d x = c.sphere.offset.cast<double>() + q.head<2>();
            touches =
                t >= t_min && t <= t_max && inside_cone(c.cone, t, x, c.max_anisotropy, c.widening);
        }
        const bool may =
            cone_may_touch_sphere(c.sphere, c.cone, c.max_anisotropy, c.widening, t_min, t_max);
        if (touches) {
            ++touching;
            EXPECT_TRUE(may) << c.sphere << " start " << c.cone.start_dev << " incr "
                             << c.cone.incr_dev << " anisotropy " << c.max_anisotropy
                             << " widening " << c.widening;
        }
        culled += may ? 0 : 1;
    }
    // Both outcomes occur often, so the check above is not vacuous and the test does cull.
    EXPECT_GT(touching, 1000);
    EXPECT_GT(culled, 1000);
}

TEST(ConeBounds, SkipsWhatLiesBesideTheMinorAxisOfAnAnisotropicCone) {
    // An 8:1 cone along u; the points' clip ellipse at t = 10 reaches ρ·8 along u, ρ·1 along v.
    FootprintCone cone;
    cone.incr_dev << 0.8f, 0.0f, 0.0f, 0.1f;
    const float rho = std::sqrt(kPointWeightClipExponent);
    const float r = 0.05f;
    SphereInRayFrame beside{10.0f, Vec2f(0.0f, 3.0f * rho + r), r};
    // A circular test with the major reach would accept it: it lies well within ρ·8.
    EXPECT_LT(beside.offset.norm(), rho * 8.0f);
    EXPECT_FALSE(cone_may_touch_sphere(beside, cone, 8.0f, 0.0f, 0.0f, 100.0f));
    // Along the major axis at the same distance it is inside.
    const SphereInRayFrame along{10.0f, Vec2f(3.0f * rho + r, 0.0f), r};
    EXPECT_TRUE(cone_may_touch_sphere(along, cone, 8.0f, 0.0f, 0.0f, 100.0f));
    // A tighter anisotropy limit widens the minor axis, and the same sphere may be touched.
    EXPECT_TRUE(cone_may_touch_sphere(beside, cone, 2.0f, 0.0f, 0.0f, 100.0f));
}

TEST(ConeBounds, RespectsTheDepthRangeAndThePinholeApex) {
    FootprintCone cone;
    cone.incr_dev = 0.01f * Mat2f::Identity();
    // On the axis but wholly behind the origin, or beyond t_max.
    EXPECT_FALSE(cone_may_touch_sphere({-5.0f, Vec2f::Zero(), 1.0f}, cone, 8.0f, 0.0f, 0.0f, 1e9f));
    EXPECT_FALSE(
        cone_may_touch_sphere({50.0f, Vec2f::Zero(), 1.0f}, cone, 8.0f, 0.0f, 0.0f, 40.0f));
    // Straddling t_min: the part in front counts.
    EXPECT_TRUE(cone_may_touch_sphere({-0.5f, Vec2f::Zero(), 1.0f}, cone, 8.0f, 0.0f, 0.0f, 1e9f));
    // At the apex the footprint is zero: only what the sphere itself covers is touched.
    EXPECT_TRUE(
        cone_may_touch_sphere({0.0f, Vec2f(0.9f, 0.0f), 1.0f}, cone, 8.0f, 0.0f, 0.0f, 1.0f));
    EXPECT_FALSE(
        cone_may_touch_sphere({0.0f, Vec2f(1.1f, 0.0f), 1.0f}, cone, 8.0f, 0.0f, 0.0f, 1.0f));
    // Far away (1e12) the footprint dominates and the test still decides without overflow.
    EXPECT_TRUE(
        cone_may_touch_sphere({1e12f, Vec2f(1e10f, 0.0f), 1.0f}, cone, 8.0f, 0.0f, 0.0f, 2e12f));
    EXPECT_FALSE(
        cone_may_touch_sphere({1e12f, Vec2f(1e11f, 0.0f), 1.0f}, cone, 8.0f, 0.0f, 0.0f, 2e12f));
}

TEST(ConeBounds, DamagedInputNeverHidesGeometry) {
    FootprintCone cone;
    cone.incr_dev = 0.01f * Mat2f::Identity();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    const SphereInRayFrame far_off{10.0f, Vec2f(100.0f, 0.0f), 1.0f};
    EXPECT_FALSE(cone_may_touch_sphere(far_off, cone, 8.0f, 0.0f, 0.0f, 100.0f));
    EXPECT_TRUE(
        cone_may_touch_sphere({nan, Vec2f(100.0f, 0.0f), 1.0f}, cone, 8.0f, 0.0f, 0.0f, 100.0f));
    EXPECT_TRUE(
        cone_may_touch_sphere({10.0f, Vec2f(inf, 0.0f), 1.0f}, cone, 8.0f, 0.0f, 0.0f, 100.0f));
    FootprintCone broken = cone;
    broken.incr_dev(1, 0) = nan;
    EXPECT_TRUE(cone_may_touch_sphere(far_off, broken, 8.0f, 0.0f, 0.0f, 100.0f));
    EXPECT_TRUE(cone_may_touch_sphere(far_off, cone, nan, 0.0f, 0.0f, 100.0f));
    EXPECT_TRUE(cone_may_touch_sphere(far_off, cone, 8.0f, inf, 0.0f, 100.0f));
}

}  // namespace
}  // namespace mrt
