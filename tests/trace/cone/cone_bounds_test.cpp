// The cone–bounding-sphere test of §4.6 never skips a sphere the cone touches (checked against
// an exact, double-precision membership test of points inside random spheres, for random,
// anisotropic, nearly degenerate and focusing cones, and against the tracer's own point weight
// for blurred ones: shadow, aperture and rough cones), skips what lies beside the minor axis of
// an anisotropic cone (where a circular test would not), and handles depth limits and damaged
// input conservatively.

#include "trace/cone/cone_bounds.h"

#include "common/footprint/footprint.h"
#include "common/footprint/point_weight.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <ostream>
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

/// A blurred cone (FootprintCone::add_blur) of the kinds the tracer makes, a sphere around its
/// clip ellipse's edge and the points' spacing h (their kernel is the widening, β·h).
struct BlurredCase {
    FootprintCone cone;
    SphereInRayFrame sphere;
    float max_anisotropy = 1.0f;
    float spacing = 0.0f;
    float t_min = 0.0f;
    float t_max = 15.0f;
    int kind = 0;
};

std::ostream& operator<<(std::ostream& os, const BlurredCase& c) {
    return os << "kind " << c.kind << " " << c.sphere << "\nstart " << c.cone.start_dev << "\nincr "
              << c.cone.incr_dev << "\nblur start " << c.cone.blur_start << "\nblur incr "
              << c.cone.blur_incr << "\nanisotropy " << c.max_anisotropy << " spacing " << c.spacing
              << " t " << c.t_min << ".." << c.t_max;
}

BlurredCase random_blurred_case(std::mt19937_64& rng) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    const auto matrix = [&](float size) {
        Mat2f m;
        m << unit(rng), unit(rng), unit(rng), unit(rng);
        const float shape = positive(rng);
        if (shape < 0.15f) {
            m.col(1) = m.col(0) * unit(rng);  // singular
        } else if (shape < 0.3f) {
            m.col(1) = m.col(0) * (1.0f + 1e-4f * unit(rng));  // nearly collinear columns
        }
        return Mat2f(m * size);
    };
    BlurredCase c;
    const float scale = std::pow(10.0f, 3.0f * unit(rng));  // pixel footprints from 1e-3 to 1e3
    const float blur_size = 0.01f * scale * std::pow(10.0f, unit(rng));
    c.kind = std::min(static_cast<int>(positive(rng) * 5.0f), 4);
    c.cone.incr_dev = matrix(0.01f * scale);
    if (positive(rng) < 0.5f) {
        c.cone.start_dev = matrix(0.1f * scale);
    }
    switch (c.kind) {
        case 0:  // any linear blur
            c.cone.add_blur(positive(rng) < 0.3f ? Mat2f::Zero() : matrix(10.0f * blur_size),
                            matrix(blur_size));
            break;
        case 1: {  // a blur shrinking to nothing at L (start = −incr·L)
            const float length = 15.0f * positive(rng);
            const Mat2f incr = matrix(blur_size);
            c.cone.add_blur(-length * incr, incr);
            break;
        }
        case 2: {  // a shadow cone: the hit's footprint shrinking to nothing at the light, the
                   // light's ellipse growing from nothing at the hit
            const float distance = 0.5f + 14.5f * positive(rng);
            c.cone.start_dev = matrix(0.1f * scale);
            c.cone.incr_dev = -c.cone.start_dev / distance;
            c.cone.add_blur(Mat2f::Zero(),
                            matrix(10.0f * blur_size) / (std::sqrt(2.0f) * distance));
            c.t_min = std::min(0.1f * scale * positive(rng), 0.5f * distance);
            c.t_max = 0.999f * distance;
            break;
        }
        case 3: {  // depth of field: the lens disc at the lens, nothing in focus
            const float focus = 0.5f + 9.5f * positive(rng);
            const float b = 100.0f * blur_size;
            c.cone.start_dev = Mat2f::Zero();
            c.cone.add_blur(b * Mat2f::Identity(), (-b / focus) * Mat2f::Identity());
            break;
        }
        default:  // a rough reflection: a radial increment
            c.cone.add_blur(Mat2f::Zero(), std::sqrt(2.0f) * blur_size * Mat2f::Identity());
            break;
    }
    c.max_anisotropy = 1.0f + 15.0f * positive(rng);
    c.spacing = 0.02f * scale * std::pow(10.0f, -3.0f * positive(rng));
    c.sphere.t = (c.t_max + 5.0f) * positive(rng) - 2.0f;
    c.sphere.radius = 0.02f * scale * std::pow(10.0f, unit(rng));
    // Around the points' clip ellipse's edge at the sphere's depth.
    const Mat2f g = FootprintCone::widened(
        FootprintCone::clamp_anisotropy(c.cone.at(std::max(c.sphere.t, 0.0f)), c.max_anisotropy),
        kPointKernelRadius * c.spacing);
    const Vec2f direction = Vec2f(unit(rng), unit(rng)).normalized();
    const float reach = std::sqrt(kPointWeightClipExponent) * (g.transpose() * direction).norm();
    c.sphere.offset = direction * (reach + c.sphere.radius) * (0.5f + positive(rng));
    return c;
}

/// Whether a point at depth t and offset x weighs anything under the tracer's rule for the
/// footprint at `depth`: the cone's footprint there clamped, widened by the points' kernel.
bool weighs(const BlurredCase& c, float depth, const Vec2f& x) {
    const PointWeightFrame frame = point_weight_frame(
        FootprintCone::clamp_anisotropy(c.cone.at(depth), c.max_anisotropy), c.spacing);
    return point_weight(frame, x, 1.0f, 1.0f) > 0.0f;
}

TEST(ConeBounds, NeverSkipsASphereABlurredConeTouches) {
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    int touching = 0, culled = 0;
    std::array<int, 5> touching_per_kind{};
    for (int n = 0; n < 5000; ++n) {
        const BlurredCase c = random_blurred_case(rng);
        const float widening = kPointKernelRadius * c.spacing;
        ASSERT_TRUE(c.cone.blurred);
        // The traversal weighs a node's points with the footprint at the node's depth (within
        // the limits), points near a cone's apex with their own: both must be covered.
        const float node_depth = std::clamp(c.sphere.t, c.t_min, c.t_max);
        const PointWeightFrame node_frame = point_weight_frame(
            FootprintCone::clamp_anisotropy(c.cone.at(node_depth), c.max_anisotropy), c.spacing);
        bool touches = false;
        for (int i = 0; i < 300 && !touches; ++i) {
            const Eigen::Vector3d q(unit(rng), unit(rng), unit(rng));
            if (q.squaredNorm() > 1.0) {
                continue;
            }
            const float t = c.sphere.t + static_cast<float>(c.sphere.radius * q.z());
            const Vec2f x = c.sphere.offset + (c.sphere.radius * q.head<2>()).cast<float>();
            // Inside the sphere as rounded to float, and within the depth limits.
            const Eigen::Vector3d from_centre(static_cast<double>(x.x()) - c.sphere.offset.x(),
                                              static_cast<double>(x.y()) - c.sphere.offset.y(),
                                              static_cast<double>(t) - c.sphere.t);
            if (from_centre.norm() > c.sphere.radius || t < c.t_min || t > c.t_max) {
                continue;
            }
            touches = weighs(c, t, x) || point_weight(node_frame, x, 1.0f, 1.0f) > 0.0f;
        }
        const bool may =
            cone_may_touch_sphere(c.sphere, c.cone, c.max_anisotropy, widening, c.t_min, c.t_max);
        if (touches) {
            ++touching;
            ++touching_per_kind[static_cast<std::size_t>(c.kind)];
            EXPECT_TRUE(may) << c;
        }
        culled += may ? 0 : 1;
    }
    // Both outcomes occur often, for every kind of blur.
    EXPECT_GT(touching, 1000);
    EXPECT_GT(culled, 1000);
    for (const int count : touching_per_kind) {
        EXPECT_GT(count, 150);
    }
}

TEST(ConeBounds, ADepthOfFieldConeCullsBesideItsFocusOnly) {
    // The lens disc of radius b√2 at t = 0, nothing in focus at t = 10: a sphere 3 units off
    // the axis is touched near the lens, culled near the focus by the narrow pixel cone.
    FootprintCone cone;
    cone.incr_dev = 0.001f * Mat2f::Identity();
    const float b = 2.0f;
    cone.add_blur(b * Mat2f::Identity(), (-b / 10.0f) * Mat2f::Identity());
    const SphereInRayFrame near_lens{0.5f, Vec2f(3.0f, 0.0f), 0.1f};
    const SphereInRayFrame near_focus{10.0f, Vec2f(3.0f, 0.0f), 0.1f};
    EXPECT_TRUE(cone_may_touch_sphere(near_lens, cone, 8.0f, 0.005f, 0.0f, 100.0f));
    EXPECT_FALSE(cone_may_touch_sphere(near_focus, cone, 8.0f, 0.005f, 0.0f, 100.0f));
    // Without the blur the sphere near the lens lies far outside the pixel cone.
    FootprintCone sharp;
    sharp.incr_dev = cone.incr_dev;
    EXPECT_FALSE(cone_may_touch_sphere(near_lens, sharp, 8.0f, 0.005f, 0.0f, 100.0f));
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

/// A blur (an area light's, an aperture's) of random start and increment, entries up to `scale`.
void add_random_blur(FootprintCone& cone, std::mt19937_64& rng, float scale) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    Mat2f start;
    Mat2f incr;
    start << unit(rng), unit(rng), unit(rng), unit(rng);
    incr << unit(rng), unit(rng), unit(rng), unit(rng);
    cone.add_blur(scale * start, scale * incr);
}

TEST(ConeBounds, PerConeFrobeniusBoundHoldsAndStaysTight) {
    // The per-cone quadratic must bound ‖F(t)‖_F² + ‖B(t)‖_F² from above at every depth, also
    // where a focusing cone narrows to a point and the quadratic's terms cancel, and exceed it
    // by no more than its rounding margin.
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int i = 0; i < 20000; ++i) {
        Case c = random_case(rng);
        if (i % 2 == 1) {
            add_random_blur(c.cone, rng, 0.01f);
        }
        const ConeSphereTest test(c.cone, c.max_anisotropy);
        const auto exact = [&](double t) {
            const Eigen::Matrix2d f =
                c.cone.start_dev.cast<double>() + t * c.cone.incr_dev.cast<double>();
            const Eigen::Matrix2d b =
                c.cone.blur_start.cast<double>() + t * c.cone.blur_incr.cast<double>();
            return f.squaredNorm() + (c.cone.blurred ? b.squaredNorm() : 0.0);
        };
        const auto magnitude = [&](double t) {
            const double s = c.cone.start_dev.cast<double>().norm() +
                             std::abs(t) * c.cone.incr_dev.cast<double>().norm();
            const double b = c.cone.blur_start.cast<double>().norm() +
                             std::abs(t) * c.cone.blur_incr.cast<double>().norm();
            return s * s + b * b;
        };
        for (const float t : {0.0f, 0.37f, 1.0f, 3.3f, 9.99f, 25.0f, -1.0f}) {
            const double bound = test.frobenius_squared(t);
            ASSERT_GE(bound, exact(t)) << "t " << t << " case " << i;
            ASSERT_LE(bound, exact(t) + 1e-5 * magnitude(t)) << "t " << t << " case " << i;
        }
        // At the focus itself, where the exact value is (nearly) zero.
        const float focus =
            c.cone.incr_dev(0, 0) != 0.0f ? -c.cone.start_dev(0, 0) / c.cone.incr_dev(0, 0) : 0.0f;
        if (std::isfinite(focus)) {
            ASSERT_GE(test.frobenius_squared(focus), exact(focus)) << "case " << i;
        }
    }
}

TEST(ConeBounds, NoFrameAtADepthReachesBeyondTheLargestSemiAxisBound) {
    // The traversal skips a triangle cluster without its frame where none of its triangles'
    // spheres comes within the cull's reach of the largest semi-axis this bounds: the frame it
    // would have decomposed, clamped or not, must never reach farther. Blurred, focusing and
    // nearly degenerate cones, at depths through the focus, on scales from 1e-3 to 1e3.
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    int tight = 0;
    int tested = 0;
    for (int i = 0; i < 20000; ++i) {
        Case c = random_case(rng);
        if (i % 2 == 1) {
            add_random_blur(c.cone, rng,
                            std::pow(10.0f, 2.0f * unit(rng)) * c.cone.incr_dev.norm());
        }
        const ConeSphereTest test(c.cone, c.max_anisotropy);
        ASSERT_TRUE(test.circle().finite);
        for (int k = 0; k < 8; ++k) {
            const float t = 30.0f * positive(rng) - 2.0f;
            const Mat2f footprint = c.cone.at(t);
            SymmetricEigen2 ellipse = FootprintCone::ellipse_of(footprint);
            FootprintCone::clamp_decomposed(footprint, c.max_anisotropy, ellipse);
            const float semi_axis = std::sqrt(ellipse.major);
            const float bound = test.largest_semi_axis(t);
            ASSERT_LE(semi_axis, bound) << "t " << t << " case " << i;
            ++tested;
            tight += semi_axis > 0.99f * bound ? 1 : 0;
        }
    }
    // Thin footprints (grazing cones, the clamp's 16:1) come close to the bound.
    EXPECT_GT(tight, tested / 20);
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
    // A blurred cone: a finite blur still culls the far sphere, a damaged one never does.
    FootprintCone blurred = cone;
    blurred.add_blur(0.01f * Mat2f::Identity(), 0.01f * Mat2f::Identity());
    EXPECT_FALSE(cone_may_touch_sphere(far_off, blurred, 8.0f, 0.0f, 0.0f, 100.0f));
    for (const float bad : {nan, inf, -inf}) {
        for (int entry = 0; entry < 8; ++entry) {
            FootprintCone damaged = cone;
            Mat2f start = 0.01f * Mat2f::Identity(), incr = 0.01f * Mat2f::Identity();
            (entry < 4 ? start : incr)(entry % 2, (entry / 2) % 2) = bad;
            damaged.add_blur(start, incr);
            EXPECT_TRUE(cone_may_touch_sphere(far_off, damaged, 8.0f, 0.0f, 0.0f, 100.0f))
                << bad << " in entry " << entry;
        }
    }
}

}  // namespace
}  // namespace mrt
