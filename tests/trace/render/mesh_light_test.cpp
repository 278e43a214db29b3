// Mesh area lights (trace/render/mesh_light.h): the exact projected solid angle against the
// closed-form rectangle form factor and high-count quadrature, sampling against its density and
// the exact irradiance, the Phong highlight against brute-force quadrature, and the equivalent
// ellipse against the light's own moments and far-field irradiance.

#include "trace/render/mesh_light.h"
#include "common/math/random.h"
#include "trace/render/area_light.h"
#include "trace/render/shading.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <tuple>
#include <vector>

namespace mrt {
namespace {

constexpr double kPiD = 3.14159265358979323846;

/// A parallelogram light: corner, corner + u, corner + u + v, corner + v as two triangles wound
/// about u × v, which is the side it emits towards.
MeshAreaLight parallelogram_light(const Vec3f& corner, const Vec3f& u, const Vec3f& v,
                                  const Rgb& radiance = Rgb(2.0f, 1.0f, 0.5f)) {
    return MeshAreaLight(
        {{corner, corner + u, corner + u + v}, {corner, corner + u + v, corner + v}},
        u.cross(v).normalized(), radiance);
}

/// An a × b rectangle in the plane y = height spanning [x0, x0 + a] × [z0, z0 + b], facing down
/// (x × z = −y) towards receivers below it.
MeshAreaLight rectangle_light(float x0, float z0, float a, float b, float height) {
    return parallelogram_light(Vec3f(x0, height, z0), Vec3f(a, 0.0f, 0.0f), Vec3f(0.0f, 0.0f, b));
}

/// Two triangles of unequal areas (1.5 and 0.5) sharing an edge, in the plane y = 2, facing
/// down: an irregular quadrilateral.
MeshAreaLight unequal_light() {
    const Vec3f a(0.0f, 2.0f, 0.0f);
    const Vec3f b(1.5f, 2.0f, 0.0f);
    const Vec3f c(0.0f, 2.0f, 2.0f);
    const Vec3f d(-0.5f, 2.0f, 0.5f);
    // (b − a) × (c − a) = (1.5, 0, 0) × (0, 0, 2) points down; (c − a) × (d − a) too.
    return MeshAreaLight({{a, b, c}, {a, c, d}}, -Vec3f::UnitY(), Rgb(1.0f, 2.0f, 3.0f));
}

/// ∫ g(ω) dω over the light's emitting directions from p in double precision: each triangle cut
/// into n² similar sub-triangles, each evaluated at its centroid (dω = cos θ_light·dA / d²).
template <typename Integrand>
double quadrature_over_light(const MeshAreaLight& light, const Vec3f& p, int n, Integrand&& g) {
    const Eigen::Vector3d origin = p.cast<double>();
    const Eigen::Vector3d facing = light.normal().cast<double>().normalized();
    double sum = 0.0;
    for (const MeshAreaLight::Triangle& t : light.triangles()) {
        const Eigen::Vector3d a = t[0].cast<double>() - origin;
        const Eigen::Vector3d ab = t[1].cast<double>() - t[0].cast<double>();
        const Eigen::Vector3d ac = t[2].cast<double>() - t[0].cast<double>();
        const double cell = 0.5 * ab.cross(ac).norm() / (static_cast<double>(n) * n);
        const auto add = [&](double i, double j) {
            const Eigen::Vector3d to = a + (i / n) * ab + (j / n) * ac;
            const double d2 = to.squaredNorm();
            const Eigen::Vector3d w = to / std::sqrt(d2);
            const double cos_light = -w.dot(facing);
            if (cos_light > 0.0) {
                sum += g(w) * cos_light / d2 * cell;
            }
        };
        for (int i = 0; i < n; ++i) {
            for (int j = 0; i + j < n; ++j) {
                add(i + 1.0 / 3.0, j + 1.0 / 3.0);
                if (i + j < n - 1) {
                    add(i + 2.0 / 3.0, j + 2.0 / 3.0);
                }
            }
        }
    }
    return sum;
}

double quadrature_solid_angle(const MeshAreaLight& light, const Vec3f& p, const Vec3f& n) {
    const Eigen::Vector3d nd = n.cast<double>();
    return quadrature_over_light(
        light, p, 1500, [&](const Eigen::Vector3d& w) { return std::max(0.0, nd.dot(w)); });
}

double quadrature_highlight(const MeshAreaLight& light, const Vec3f& p, const Vec3f& n,
                            const Vec3f& wo, double e) {
    const Eigen::Vector3d nd = n.cast<double>().normalized();
    const Eigen::Vector3d wd = wo.cast<double>();
    // Unit in double: the float n and wo are unit to 1e-7, which e = 500 would raise to 3e-5.
    const Eigen::Vector3d r = (2.0 * wd.dot(nd) * nd - wd).normalized();
    return quadrature_over_light(light, p, 1500, [&](const Eigen::Vector3d& w) {
        const double lobe = r.dot(w);
        return lobe > 0.0 ? (e + 2.0) / (2.0 * kPiD) * std::pow(lobe, e) * std::max(0.0, nd.dot(w))
                          : 0.0;
    });
}

/// The rectangle form factor from a differential area to a parallel a × b rectangle at distance
/// c, the area element facing it below one corner (Howell's catalogue, C-11):
/// F = 1/(2π)·[X/√(1+X²)·atan(Y/√(1+X²)) + Y/√(1+Y²)·atan(X/√(1+Y²))], X = a/c, Y = b/c.
/// F = E/(πL), so the projected solid angle is π·F.
double corner_form_factor(double a, double b, double c) {
    const double x = a / c;
    const double y = b / c;
    const double sx = std::sqrt(1.0 + x * x);
    const double sy = std::sqrt(1.0 + y * y);
    return (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2.0 * kPiD);
}

TEST(MeshLightSolidAngle, RectangleBelowACornerAndTheCentreMatchesTheFormFactor) {
    for (const auto& [a, b, c] : {std::tuple{1.0f, 1.0f, 1.0f},
                                  {2.0f, 0.5f, 3.0f},
                                  {0.47f, 0.38f, 1.5f},
                                  {8.0f, 4.0f, 0.25f},
                                  {0.01f, 0.02f, 100.0f},
                                  {2e6f, 2e6f, 1.0f}}) {
        const double corner = kPiD * corner_form_factor(a, b, c);
        const double below_corner = mesh_light_projected_solid_angle(
            rectangle_light(0.0f, 0.0f, a, b, c), Vec3f::Zero(), Vec3f::UnitY());
        EXPECT_NEAR(below_corner, corner, 1e-9 * corner) << a << " × " << b << " at " << c;
        // Below the centre: four a/2 × b/2 rectangles meeting above the point.
        const double centre = 4.0 * kPiD * corner_form_factor(0.5 * a, 0.5 * b, c);
        const double below_centre = mesh_light_projected_solid_angle(
            rectangle_light(-0.5f * a, -0.5f * b, a, b, c), Vec3f::Zero(), Vec3f::UnitY());
        EXPECT_NEAR(below_centre, centre, 1e-9 * centre) << a << " × " << b << " at " << c;
        std::printf("  %g × %g at %g: relative error %.2g below a corner, %.2g below the centre\n",
                    a, b, c, std::abs(below_corner - corner) / corner,
                    std::abs(below_centre - centre) / centre);
    }
}

TEST(MeshLightSolidAngle, TiltedReceiverMatchesQuadrature) {
    const Vec3f tilted = Vec3f(0.3f, 1.0f, 0.2f).normalized();
    const MeshAreaLight slanted =
        parallelogram_light(Vec3f(1.0f, 3.0f, -0.5f), Vec3f(2.0f, 0.3f, 0.0f),
                            Vec3f(0.4f, -0.2f, 1.0f));  // faces down, not a rectangle
    ASSERT_LT(slanted.normal().y(), 0.0f);
    for (const auto& [light, p, n] :
         {std::tuple{rectangle_light(-0.5f, -0.5f, 1.0f, 1.0f, 1.0f), Vec3f(1.5f, 0.0f, 0.3f),
                     tilted},
          std::tuple{unequal_light(), Vec3f(0.2f, 0.0f, 0.4f), tilted},
          std::tuple{slanted, Vec3f(-1.0f, 0.5f, 2.0f), tilted},
          std::tuple{slanted, Vec3f(2.0f, -4.0f, 0.0f), Vec3f::UnitY().eval()}}) {
        const double expected = quadrature_solid_angle(light, p, n);
        const double got = mesh_light_projected_solid_angle(light, p, n);
        std::printf("  tilted: %.9g against %.9g (relative %.2g)\n", got, expected,
                    std::abs(got - expected) / expected);
        EXPECT_GT(expected, 0.01);
        EXPECT_NEAR(got, expected, 1e-5 * expected) << "p " << p.transpose();
    }
}

TEST(MeshLightSolidAngle, TangentPlaneCuttingTheLightCountsOnlyThePartAbove) {
    // A 4 × 3 rectangle at height 1, seen by receivers tilted so that their tangent plane cuts
    // it (through one triangle, both, or near a corner).
    const MeshAreaLight light = rectangle_light(-2.0f, -1.5f, 4.0f, 3.0f, 1.0f);
    const double full = mesh_light_projected_solid_angle(light, Vec3f::Zero(), Vec3f::UnitY());
    for (const auto& [tilt, turn] :
         {std::pair{0.6f, 0.0f}, {1.2f, 0.0f}, {1.5f, 0.0f}, {1.0f, 0.7f}, {1.3f, 2.5f}}) {
        const Vec3f n(std::sin(tilt) * std::cos(turn), std::cos(tilt),
                      std::sin(tilt) * std::sin(turn));
        const double expected = quadrature_solid_angle(light, Vec3f::Zero(), n);
        const double got = mesh_light_projected_solid_angle(light, Vec3f::Zero(), n);
        std::printf("  cut by the tangent plane: %.9g against %.9g (relative %.2g)\n", got,
                    expected, std::abs(got - expected) / expected);
        EXPECT_NEAR(got, expected, 1e-5 * expected) << "tilt " << tilt << " turn " << turn;
        EXPECT_LT(got, full);
    }
    // Wholly behind the tangent plane: nothing.
    EXPECT_EQ(mesh_light_projected_solid_angle(light, Vec3f::Zero(), -Vec3f::UnitY()), 0.0);
}

TEST(MeshLightSolidAngle, NothingBehindTheEmittingFaceNorInItsPlane) {
    // The light at height 1 faces down; above it, facing it, a receiver sees its back.
    const MeshAreaLight light = rectangle_light(-0.5f, -0.5f, 1.0f, 1.0f, 1.0f);
    EXPECT_EQ(mesh_light_projected_solid_angle(light, Vec3f(0.0f, 2.0f, 0.0f), -Vec3f::UnitY()),
              0.0);
    EXPECT_EQ(mesh_light_projected_solid_angle(light, Vec3f(3.0f, 1.0f, 0.0f), -Vec3f::UnitX()),
              0.0);
    EXPECT_EQ(sample_mesh_light(light, Vec3f(0.0f, 2.0f, 0.0f), 0.3f, 0.6f).irradiance[0], 0.0f);
    EXPECT_EQ(sample_mesh_light_centre(light, Vec3f(0.0f, 2.0f, 0.0f)).irradiance[0], 0.0f);
    EXPECT_EQ(mesh_light_phong_highlight(light, Vec3f(0.0f, 2.0f, 0.0f), -Vec3f::UnitY(),
                                         -Vec3f::UnitY(), 1.0f),
              0.0f);
}

TEST(MeshLightSolidAngle, InvariantUnderRotatingAndTranslatingTheScene) {
    const MeshAreaLight light = unequal_light();
    const Vec3f p(0.3f, 0.1f, 0.2f);
    const Vec3f n = Vec3f(1.0f, 0.3f, -0.6f).normalized();  // its tangent plane cuts the light
    const double reference = mesh_light_projected_solid_angle(light, p, n);
    ASSERT_GT(reference, 0.0);
    for (const auto& [angle, axis, offset] :
         {std::tuple{0.7f, Vec3f(1.0f, 2.0f, 3.0f), Vec3f(10.0f, -20.0f, 5.0f)},
          {2.5f, Vec3f(0.0f, 0.0f, 1.0f), Vec3f(-3.0f, 0.5f, 100.0f)},
          {3.0f, Vec3f(-1.0f, 0.2f, 0.1f), Vec3f(0.0f, 0.0f, 0.0f)}}) {
        const Mat3f rotation = Eigen::AngleAxisf(angle, axis.normalized()).toRotationMatrix();
        const auto move = [&](const Vec3f& x) -> Vec3f { return rotation * x + offset; };
        std::vector<MeshAreaLight::Triangle> triangles;
        for (const MeshAreaLight::Triangle& t : light.triangles()) {
            triangles.push_back({move(t[0]), move(t[1]), move(t[2])});
        }
        const MeshAreaLight moved(triangles, (rotation * light.normal()).normalized(),
                                  light.radiance());
        // The moved vertices are rounded to float at up to 100: a relative error of about 1e-5
        // of the light's size.
        const double got =
            mesh_light_projected_solid_angle(moved, move(p), (rotation * n).normalized());
        std::printf("  moved by %g: relative change %.2g\n", offset.norm(),
                    std::abs(got - reference) / reference);
        EXPECT_NEAR(got, reference, 1e-4 * reference) << "angle " << angle;
    }
}

// ---------------------------------------------------------------------------------------------
// Sampling.

/// Mean of the estimator times the receiver cosine over an n×n stratified grid of midpoints.
Rgb estimate_irradiance(const MeshAreaLight& light, const Vec3f& p, const Vec3f& n, int grid) {
    Rgb sum = Rgb::Zero();
    for (int i = 0; i < grid; ++i) {
        for (int j = 0; j < grid; ++j) {
            const LightSample s = sample_mesh_light(
                light, p, (static_cast<float>(i) + 0.5f) / static_cast<float>(grid),
                (static_cast<float>(j) + 0.5f) / static_cast<float>(grid));
            sum += s.irradiance * std::max(0.0f, s.wi.dot(n));
        }
    }
    return sum / static_cast<float>(grid * grid);
}

TEST(MeshLightSampling, StratifiedMeanConvergesToTheExactIrradiance) {
    const Vec3f tilted = Vec3f(0.3f, 1.0f, 0.2f).normalized();
    for (const auto& [light, p, n] :
         {std::tuple{unequal_light(), Vec3f(0.2f, 0.0f, 0.4f), tilted},
          std::tuple{unequal_light(), Vec3f(3.0f, 1.0f, -1.0f), Vec3f::UnitY().eval()},
          std::tuple{rectangle_light(-0.235f, -0.19f, 0.47f, 0.38f, 1.0f), Vec3f::Zero().eval(),
                     Vec3f::UnitY().eval()}}) {
        const Rgb e = estimate_irradiance(light, p, n, 512);
        const Rgb expected =
            light.radiance() * static_cast<float>(mesh_light_projected_solid_angle(light, p, n));
        std::printf("  512² stratified samples: relative error %.2g\n",
                    std::abs(e[0] - expected[0]) / expected[0]);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(e[c], expected[c], 1e-3f * expected[c]) << "p " << p.transpose();
        }
    }
}

TEST(MeshLightSampling, PicksTrianglesByAreaAndPointsUniformlyWithin) {
    // Chi-square over 8 bins of equal area within their triangle: each triangle of
    // unequal_light (areas 1.5 and 0.5) cut into its 4 midpoint sub-triangles, identified by
    // barycentric coordinates.
    const MeshAreaLight light = unequal_light();
    const Vec3f p(0.3f, -1.0f, 0.2f);
    constexpr int kSamples = 80000;
    std::array<int, 8> counts{};
    for (int i = 0; i < kSamples; ++i) {
        SampleRng rng(11, 0, 0, static_cast<std::uint32_t>(i));
        const float u = rng.uniform();
        const float v = rng.uniform();
        const LightSample s = sample_mesh_light(light, p, u, v);
        const Vec3f q = p + s.distance * s.wi;
        int bin = -1;
        for (std::size_t t = 0; t < light.triangles().size() && bin < 0; ++t) {
            const MeshAreaLight::Triangle& tri = light.triangles()[t];
            // Barycentric coordinates in the plane y = 2 (x, z).
            const Vec2f a(tri[0].x(), tri[0].z());
            const Vec2f e1 = Vec2f(tri[1].x(), tri[1].z()) - a;
            const Vec2f e2 = Vec2f(tri[2].x(), tri[2].z()) - a;
            const Vec2f d = Vec2f(q.x(), q.z()) - a;
            const float det = e1.x() * e2.y() - e1.y() * e2.x();
            const float b1 = (d.x() * e2.y() - d.y() * e2.x()) / det;
            const float b2 = (e1.x() * d.y() - e1.y() * d.x()) / det;
            const float b0 = 1.0f - b1 - b2;
            constexpr float kSlack = -1e-5f;
            if (b0 < kSlack || b1 < kSlack || b2 < kSlack) {
                continue;
            }
            const int sub = b0 > 0.5f ? 0 : b1 > 0.5f ? 1 : b2 > 0.5f ? 2 : 3;
            bin = static_cast<int>(t) * 4 + sub;
        }
        ASSERT_GE(bin, 0) << "sample off the light: " << q.transpose();
        ++counts[static_cast<std::size_t>(bin)];
    }
    const std::array<double, 2> share = {1.5 / 2.0, 0.5 / 2.0};
    double chi2 = 0.0;
    for (std::size_t bin = 0; bin < counts.size(); ++bin) {
        const double expected = kSamples * share[bin / 4] / 4.0;
        chi2 += (counts[bin] - expected) * (counts[bin] - expected) / expected;
    }
    std::printf("  chi-square %.3g over 8 bins (first triangle %d of %d)\n", chi2,
                counts[0] + counts[1] + counts[2] + counts[3], kSamples);
    // 7 degrees of freedom: P(χ² > 24.32) = 0.001.
    EXPECT_LT(chi2, 24.32);
}

TEST(MeshLightSampling, CentreIsAPointEmitterOfTheLightsIntensity) {
    const MeshAreaLight light = unequal_light();
    const Vec3f p(1.0f, -1.0f, 3.0f);
    const LightSample s = sample_mesh_light_centre(light, p);
    // Area-weighted centroid: (1.5·(0.5, 2, 2/3) + 0.5·(−1/6, 2, 5/6)) / 2.
    const Vec3d centroid(1.5 * 0.5 / 2.0 + 0.5 * (-1.0 / 6.0) / 2.0, 2.0,
                         1.5 * (2.0 / 3.0) / 2.0 + 0.5 * (5.0 / 6.0) / 2.0);
    const Vec3d to = centroid - p.cast<double>();
    const double d = to.norm();
    EXPECT_NEAR(s.distance, d, 1e-5 * d);
    EXPECT_NEAR((s.wi.cast<double>() - to / d).norm(), 0.0, 1e-6);
    const double intensity = 2.0 * (to.y() / d);  // L·A·cos θ per unit radiance, A = 2
    for (int c = 0; c < 3; ++c) {
        const double expected = light.radiance()[c] * intensity / (d * d);
        EXPECT_NEAR(s.irradiance[c], expected, 1e-5 * expected);
    }
}

// ---------------------------------------------------------------------------------------------
// The Phong highlight.

TEST(MeshLightHighlight, MatchesBruteForceQuadratureForWideAndNarrowLobes) {
    const Vec3f wo = Vec3f(0.5f, 1.0f, 0.2f).normalized();
    const Vec3f n = Vec3f(-0.1f, 1.0f, 0.05f).normalized();
    // The mirror direction of wo meets the plane y = 5 near (−3.85, 5, −0.59).
    const MeshAreaLight cornell = rectangle_light(-4.08f, -0.78f, 0.47f, 0.38f, 5.0f);
    const MeshAreaLight around = rectangle_light(-7.0f, -3.5f, 6.0f, 6.0f, 5.0f);
    const MeshAreaLight beside = rectangle_light(-3.85f, -3.5f, 6.0f, 6.0f, 5.0f);
    const MeshAreaLight flank = rectangle_light(-2.5f, -1.0f, 1.0f, 1.0f, 5.0f);
    // The Cornell box's light ten times as far: its edges nearly cancel.
    const MeshAreaLight far = rectangle_light(-38.7f, -6.1f, 0.47f, 0.38f, 50.0f);
    for (const auto& [light, exponent] : {
             // The Cornell box's light (0.47 × 0.38) around the mirror direction, from a wide
             // lobe to a near mirror.
             std::pair{cornell, 1.0f},
             {cornell, 10.0f},
             {cornell, 37.3f},
             {cornell, 500.0f},
             {cornell, 3000.0f},
             // A large light around the lobe, then with its edge through the lobe's axis.
             {around, 0.5f},
             {around, 1.0f},
             {around, 500.0f},
             {beside, 50.0f},
             {beside, 500.0f},
             // Off the lobe's axis, on its flank.
             {flank, 2.5f},
             {flank, 50.0f},
             {far, 1.0f},
             {far, 300.0f},
         }) {
        const double expected = quadrature_highlight(light, Vec3f::Zero(), n, wo, exponent);
        const float got = mesh_light_phong_highlight(light, Vec3f::Zero(), n, wo, exponent);
        std::printf("  exponent %g, area %g: %.7g against %.7g (relative %.2g)\n", exponent,
                    light.area(), got, expected, std::abs(got - expected) / expected);
        EXPECT_GT(expected, 1e-6);
        EXPECT_NEAR(got, expected, 1e-4 * expected)
            << "exponent " << exponent << " area " << light.area();
    }
}

TEST(MeshLightHighlight, LightsCutByTheMirrorPlaneOrTheTangentPlaneMatchQuadrature) {
    // A 6 × 4 light at height 1 over a receiver at the origin. Seen at grazing incidence the
    // lobe's own plane (r·ω = 0) crosses the light; a tilted normal's tangent plane does too.
    const MeshAreaLight light = rectangle_light(-3.0f, -2.0f, 6.0f, 4.0f, 1.0f);
    const Vec3f grazing = Vec3f(1.0f, 0.15f, 0.1f).normalized();
    const Vec3f tilted = Vec3f(0.8f, 0.6f, 0.0f);
    for (const auto& [n, wo, exponent] : {std::tuple{Vec3f::UnitY().eval(), grazing, 0.5f},
                                          {Vec3f::UnitY().eval(), grazing, 1.0f},
                                          {Vec3f::UnitY().eval(), grazing, 7.5f},
                                          {tilted, Vec3f::UnitY().eval(), 1.0f},
                                          {tilted, Vec3f::UnitY().eval(), 20.0f},
                                          {tilted, grazing, 3.0f}}) {
        const double expected = quadrature_highlight(light, Vec3f::Zero(), n, wo, exponent);
        const float got = mesh_light_phong_highlight(light, Vec3f::Zero(), n, wo, exponent);
        std::printf("  cut, exponent %g: %.7g against %.7g (relative %.2g)\n", exponent, got,
                    expected, std::abs(got - expected) / expected);
        EXPECT_GT(expected, 1e-3);
        EXPECT_NEAR(got, expected, 1e-4 * expected)
            << "n " << n.transpose() << " wo " << wo.transpose() << " exponent " << exponent;
    }
}

TEST(MeshLightHighlight, ExponentZeroIsTheProjectedSolidAngleOverPi) {
    // Seen along the normal (r = n) every direction above the surface is in the lobe, whose
    // (0+2)/(2π) = 1/π makes the highlight the projected solid angle over π.
    for (const auto& [light, p] :
         {std::pair{rectangle_light(-0.235f, -0.19f, 0.47f, 0.38f, 1.0f), Vec3f::Zero().eval()},
          {rectangle_light(-2.0f, -1.5f, 4.0f, 3.0f, 1.0f), Vec3f(0.5f, 0.0f, 0.5f)},
          {unequal_light(), Vec3f(0.2f, 0.0f, 0.4f)}}) {
        const double expected = mesh_light_projected_solid_angle(light, p, Vec3f::UnitY()) / kPiD;
        const float got =
            mesh_light_phong_highlight(light, p, Vec3f::UnitY(), Vec3f::UnitY(), 0.0f);
        std::printf("  exponent 0: %.6g against %.6g (relative %.2g)\n", got, expected,
                    std::abs(got - expected) / expected);
        EXPECT_NEAR(got, expected, 1e-6 * expected);
    }
}

TEST(MeshLightHighlight, InfiniteEmitterGivesTheLobesIntegral) {
    // Seen along the normal, the lobe (e+2)/(2π)·cos^e·cos integrates to 1 over the hemisphere;
    // a 2e6 × 2e6 light one unit above misses 1e-6 of it.
    const MeshAreaLight light = rectangle_light(-1e6f, -1e6f, 2e6f, 2e6f, 1.0f);
    for (const float exponent : {0.0f, 0.5f, 10.0f, 80.0f, 3000.0f}) {
        EXPECT_NEAR(mesh_light_phong_highlight(light, Vec3f::Zero(), Vec3f::UnitY(), Vec3f::UnitY(),
                                               exponent),
                    1.0f, 1e-5f)
            << "exponent " << exponent;
    }
}

TEST(MeshLightHighlight, UnoccludedRadianceIsTheDiffuseAndSpecularTerms) {
    const MeshAreaLight light = unequal_light();
    const Vec3f p(0.2f, 0.0f, 0.4f);
    const Vec3f n = Vec3f(0.1f, 1.0f, 0.0f).normalized();
    const Vec3f wo = Vec3f(-0.3f, 1.0f, 0.1f).normalized();
    Material material;
    material.specular = Rgb(0.2f, 0.3f, 0.4f);
    material.phong_exponent = 20.0f;
    const Rgb albedo(0.5f, 0.25f, 0.125f);
    const double diffuse = mesh_light_projected_solid_angle(light, p, n) / kPiD;
    const double highlight = quadrature_highlight(light, p, n, wo, 20.0);
    const Rgb got = mesh_light_unoccluded(light, p, n, wo, material, albedo);
    for (int c = 0; c < 3; ++c) {
        const double expected =
            light.radiance()[c] * (albedo[c] * diffuse + material.specular[c] * highlight);
        EXPECT_NEAR(got[c], expected, 1e-4 * expected) << "channel " << c;
    }
    material.specular = Rgb::Zero();
    EXPECT_NEAR(mesh_light_unoccluded(light, p, n, wo, material, albedo)[0],
                light.radiance()[0] * albedo[0] * diffuse, 1e-6 * diffuse);
}

// ---------------------------------------------------------------------------------------------
// The equivalent ellipse.

TEST(MeshLightEllipse, RectangleGivesSemiAxesOverRootThreeAlongItsSides) {
    // A 2 × 0.5 rectangle along (1, 0, 1)/√2 and y, turned so that neither side is an axis.
    const Vec3f side_w = Vec3f(1.0f, 0.0f, 1.0f).normalized();
    const Vec3f side_h = Vec3f(0.0f, 1.0f, 0.0f);
    const MeshAreaLight light =
        parallelogram_light(Vec3f(1.0f, 2.0f, 3.0f), 2.0f * side_w, 0.5f * side_h);
    const EllipticalAreaLight ellipse = equivalent_ellipse(light);
    EXPECT_NEAR((ellipse.center - light.centroid()).norm(), 0.0f, 1e-6f);
    EXPECT_NEAR(ellipse.semi_axis_u.norm(), 2.0f / std::sqrt(3.0f), 1e-5f);
    EXPECT_NEAR(ellipse.semi_axis_v.norm(), 0.5f / std::sqrt(3.0f), 1e-5f);
    EXPECT_NEAR(std::abs(ellipse.semi_axis_u.normalized().dot(side_w)), 1.0f, 1e-6f);
    EXPECT_NEAR(std::abs(ellipse.semi_axis_v.normalized().dot(side_h)), 1.0f, 1e-6f);
    EXPECT_NEAR(ellipse.normal().dot(light.normal()), 1.0f, 1e-6f);
    EXPECT_FALSE(ellipse.two_sided);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(ellipse.radiance[c] * ellipse.area(), light.radiance()[c] * light.area(),
                    1e-5f * light.radiance()[c] * light.area());
    }
}

TEST(MeshLightEllipse, SecondMomentsOfATriangleMatch) {
    // A lone triangle has no symmetry: its covariance by quadrature against the ellipse's
    // (a²/4)·ûûᵀ + (b²/4)·v̂v̂ᵀ.
    const MeshAreaLight::Triangle triangle = {Vec3f(0.0f, 1.0f, 0.0f), Vec3f(3.0f, 1.5f, 0.0f),
                                              Vec3f(0.5f, 1.2f, 1.0f)};
    const MeshAreaLight light(
        {triangle}, (triangle[1] - triangle[0]).cross(triangle[2] - triangle[0]).normalized(),
        Rgb::Ones());
    const MeshAreaLight::Triangle& t = light.triangles()[0];
    const EllipticalAreaLight ellipse = equivalent_ellipse(light);
    const Eigen::Vector3d c = light.centroid().cast<double>();
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    constexpr int kCells = 400;
    const Eigen::Vector3d a = t[0].cast<double>();
    const Eigen::Vector3d ab = t[1].cast<double>() - a;
    const Eigen::Vector3d ac = t[2].cast<double>() - a;
    int count = 0;
    for (int i = 0; i < kCells; ++i) {
        for (int j = 0; i + j < kCells; ++j) {
            for (const double shift : {1.0 / 3.0, 2.0 / 3.0}) {
                if (shift > 0.5 && i + j == kCells - 1) {
                    continue;
                }
                const Eigen::Vector3d x =
                    a + ((i + shift) / kCells) * ab + ((j + shift) / kCells) * ac - c;
                covariance += x * x.transpose();
                ++count;
            }
        }
    }
    covariance /= count;
    const Eigen::Vector3d u = ellipse.semi_axis_u.cast<double>();
    const Eigen::Vector3d v = ellipse.semi_axis_v.cast<double>();
    const Eigen::Matrix3d ellipse_covariance = 0.25 * (u * u.transpose() + v * v.transpose());
    EXPECT_NEAR((covariance - ellipse_covariance).norm(), 0.0, 1e-4 * covariance.norm())
        << "mesh\n"
        << covariance << "\nellipse\n"
        << ellipse_covariance;
}

TEST(MeshLightEllipse, FarFieldIrradianceMatchesTheRectangle) {
    // A 1 × 0.6 rectangle, receivers five sizes away in several directions and orientations.
    const MeshAreaLight light = rectangle_light(-0.5f, -0.3f, 1.0f, 0.6f, 0.0f);
    const EllipticalAreaLight ellipse = equivalent_ellipse(light);
    for (const auto& [p, n] :
         {std::pair{Vec3f(0.0f, -5.0f, 0.0f), Vec3f::UnitY().eval()},
          {Vec3f(3.0f, -4.0f, 0.0f), Vec3f(-0.6f, 0.8f, 0.0f)},
          {Vec3f(0.0f, -3.0f, 4.0f), Vec3f(0.0f, 1.0f, 0.0f)},
          {Vec3f(2.0f, -4.0f, 2.5f), Vec3f(-0.2f, 1.0f, -0.5f).normalized()}}) {
        const double mesh = light.radiance()[0] * mesh_light_projected_solid_angle(light, p, n);
        const double from_ellipse =
            ellipse.radiance[0] * area_light_projected_solid_angle(ellipse, p, n);
        std::printf("  far field: ellipse %.8g against rectangle %.8g (relative %.2g)\n",
                    from_ellipse, mesh, std::abs(from_ellipse - mesh) / mesh);
        EXPECT_NEAR(from_ellipse, mesh, 1e-3 * mesh) << "p " << p.transpose();
    }
}

TEST(MeshLightEllipse, FarFieldErrorIsFourthOrderForARectangleAndThirdForATriangle) {
    // Doubling the distance divides the relative irradiance error by 2⁴ = 16 where the light is
    // centrally symmetric (its third moments vanish, like the ellipse's) and by 2³ = 8 for a
    // lone triangle, seen obliquely (straight below, the kernel's symmetry hides the third
    // order).
    const Vec3f corner(-0.5f, 0.0f, -0.3f);
    const MeshAreaLight rectangle =
        parallelogram_light(corner, Vec3f(1.0f, 0.0f, 0.0f), Vec3f(0.0f, 0.0f, 0.6f));
    const MeshAreaLight triangle(
        {{corner, corner + Vec3f(1.0f, 0.0f, 0.0f), corner + Vec3f(0.3f, 0.0f, 1.0f)}},
        -Vec3f::UnitY(), Rgb::Ones());
    const auto relative_error = [](const MeshAreaLight& light, const Vec3f& direction,
                                   float distance, const Vec3f& n) {
        const EllipticalAreaLight ellipse = equivalent_ellipse(light);
        const Vec3f p = light.centroid() + distance * direction.normalized();
        const double mesh = light.radiance()[0] * mesh_light_projected_solid_angle(light, p, n);
        const double from_ellipse =
            ellipse.radiance[0] * area_light_projected_solid_angle(ellipse, p, n);
        return std::abs(from_ellipse - mesh) / mesh;
    };
    for (const auto& [direction, n] :
         {std::pair{Vec3f(0.0f, -0.6f, 0.8f), Vec3f::UnitY().eval()},
          {Vec3f(0.4f, -0.8f, 0.5f), Vec3f(-0.2f, 1.0f, -0.5f).normalized()}}) {
        for (const auto& [light, order] : {std::pair{rectangle, 4}, {triangle, 3}}) {
            const double near = relative_error(light, direction, 5.0f, n);
            const double far = relative_error(light, direction, 10.0f, n);
            std::printf("  order %d: relative error %.3g at 5, %.3g at 10 (ratio %.3g)\n", order,
                        near, far, near / far);
            EXPECT_NEAR(near / far, std::ldexp(1.0, order), 0.2 * std::ldexp(1.0, order))
                << "direction " << direction.transpose();
        }
    }
}

TEST(MeshLightEllipse, DegenerateLightsGiveAFiniteEllipse) {
    const Vec3f a(1.0f, 2.0f, 3.0f);
    for (const MeshAreaLight& light :
         {MeshAreaLight({{a, a, a}}, -Vec3f::UnitY(), Rgb::Ones()),
          MeshAreaLight({{a, a + Vec3f(1.0f, 0.0f, 0.0f), a + Vec3f(2.0f, 0.0f, 0.0f)}},
                        -Vec3f::UnitY(), Rgb::Ones()),
          MeshAreaLight({{a, a + Vec3f(1.0f, 0.0f, 0.0f), a + Vec3f(2.0f, 0.0f, 1e-6f)}},
                        -Vec3f::UnitY(), Rgb::Ones())}) {
        const EllipticalAreaLight ellipse = equivalent_ellipse(light);
        EXPECT_TRUE(ellipse.center.allFinite());
        EXPECT_TRUE(ellipse.semi_axis_u.allFinite());
        EXPECT_TRUE(ellipse.semi_axis_v.allFinite());
        EXPECT_TRUE(ellipse.radiance.allFinite());
        EXPECT_GT(ellipse.area(), 0.0f);
        EXPECT_TRUE(ellipse.normal().allFinite());
        EXPECT_NEAR(ellipse.normal().dot(light.normal()), 1.0f, 1e-5f);
        EXPECT_NEAR(ellipse.radiance[0] * ellipse.area(), light.area(), 1e-6f);
        EXPECT_TRUE(std::isfinite(
            area_light_projected_solid_angle(ellipse, Vec3f::Zero(), Vec3f::UnitY())));
    }
}

}  // namespace
}  // namespace mrt
