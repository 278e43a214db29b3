// Area-light sampling against its stated density (chi-square) and against the closed-form
// irradiance of a disc light; the exact unoccluded irradiance and highlight of an area light
// against closed forms and high-count quadrature.

#include "common/math/random.h"
#include "trace/render/area_light.h"
#include "trace/render/shading.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <tuple>
#include <utility>
#include <vector>

namespace mrt {
namespace {

EllipticalAreaLight disc_light(float radius, float height) {
    EllipticalAreaLight light;
    light.center = Vec3f(0.0f, height, 0.0f);
    // u × v = (r,0,0) × (0,0,r) points down (−y): it faces the receiver at the origin.
    light.semi_axis_u = Vec3f(radius, 0.0f, 0.0f);
    light.semi_axis_v = Vec3f(0.0f, 0.0f, radius);
    light.radiance = Rgb(2.0f, 1.0f, 0.5f);
    return light;
}

/// Mean of the estimator times the receiver cosine over an n×n stratified grid of midpoints.
Rgb estimate_irradiance(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                        int grid) {
    Rgb sum = Rgb::Zero();
    for (int i = 0; i < grid; ++i) {
        for (int j = 0; j < grid; ++j) {
            const LightSample s = sample_area_light(
                light, p, (static_cast<float>(i) + 0.5f) / static_cast<float>(grid),
                (static_cast<float>(j) + 0.5f) / static_cast<float>(grid));
            sum += s.irradiance * std::max(0.0f, s.wi.dot(n));
        }
    }
    return sum / static_cast<float>(grid * grid);
}

TEST(AreaLightSampling, DiscIrradianceOnItsAxisMatchesTheClosedForm) {
    // E = π L r² / (r² + h²) at a receiver facing a disc of radius r at height h.
    for (const auto& [r, h] : {std::pair{1.0f, 1.0f}, {0.5f, 3.0f}, {2.0f, 0.25f}}) {
        const EllipticalAreaLight light = disc_light(r, h);
        const Rgb e = estimate_irradiance(light, Vec3f::Zero(), Vec3f::UnitY(), 512);
        const Rgb expected = light.radiance * (kPi * r * r / (r * r + h * h));
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(e[c], expected[c], 1e-3f * expected[c]) << "r " << r << " h " << h;
        }
    }
}

TEST(AreaLightSampling, OneSidedLightIsDarkBehindAndTwoSidedIsNot) {
    EllipticalAreaLight light = disc_light(1.0f, -1.0f);  // below the receiver, facing down
    EXPECT_EQ(estimate_irradiance(light, Vec3f::Zero(), -Vec3f::UnitY(), 16)[0], 0.0f);
    light.two_sided = true;
    EXPECT_NEAR(estimate_irradiance(light, Vec3f::Zero(), -Vec3f::UnitY(), 256)[0],
                2.0f * kPi * 0.5f, 2e-3f);
}

TEST(AreaLightSampling, PointsAreUniformOnTheEllipse) {
    // Chi-square over 8 equal-area rings × 8 sectors in the ellipse's own coordinates.
    EllipticalAreaLight light;
    light.center = Vec3f(1.0f, 2.0f, 3.0f);
    light.semi_axis_u = Vec3f(3.0f, 0.0f, 0.0f);
    light.semi_axis_v = Vec3f(0.0f, 0.5f, 0.5f);
    const Vec3f p(0.0f, -5.0f, 0.0f);
    constexpr int kRings = 8;
    constexpr int kSectors = 8;
    constexpr int kSamples = 64000;
    std::vector<int> counts(kRings * kSectors, 0);
    for (int i = 0; i < kSamples; ++i) {
        SampleRng rng(7, 0, 0, static_cast<std::uint32_t>(i));
        const float u = rng.uniform();
        const float v = rng.uniform();
        const LightSample s = sample_area_light(light, p, u, v);
        const Vec3f q = p + s.distance * s.wi - light.center;
        const float a = q.dot(light.semi_axis_u) / light.semi_axis_u.squaredNorm();
        const float b = q.dot(light.semi_axis_v) / light.semi_axis_v.squaredNorm();
        const float r2 = a * a + b * b;
        ASSERT_LE(r2, 1.0f + 1e-4f);
        const int ring = std::min(kRings - 1, static_cast<int>(r2 * kRings));
        const float angle = std::atan2(b, a) + kPi;
        const int sector =
            std::min(kSectors - 1, static_cast<int>(angle / (2.0f * kPi) * kSectors));
        ++counts[ring * kSectors + sector];
    }
    const double expected = static_cast<double>(kSamples) / (kRings * kSectors);
    double chi2 = 0.0;
    for (int c : counts) {
        chi2 += (c - expected) * (c - expected) / expected;
    }
    // 63 degrees of freedom: P(χ² > 103.4) = 0.001.
    EXPECT_LT(chi2, 103.4);
}

// ---------------------------------------------------------------------------------------------
// The exact unoccluded irradiance and highlight of an area light (trace/render/area_light.h).

/// ∫ g(ω) dω over the light's emitting directions from p, by the midpoint rule in the light's
/// polar coordinates (ρ, φ) in double precision: dω = |cos θ_light|·dA / d².
template <typename Integrand>
double quadrature_over_light(const EllipticalAreaLight& light, const Vec3f& p, int rings,
                             int sectors, Integrand&& g) {
    const Eigen::Vector3d c = light.center.cast<double>();
    const Eigen::Vector3d u = light.semi_axis_u.cast<double>();
    const Eigen::Vector3d v = light.semi_axis_v.cast<double>();
    const Eigen::Vector3d face = u.cross(v);
    const Eigen::Vector3d facing = face.normalized();
    const Eigen::Vector3d pd = p.cast<double>();
    double sum = 0.0;
    for (int i = 0; i < rings; ++i) {
        const double rho = (i + 0.5) / rings;
        for (int j = 0; j < sectors; ++j) {
            const double phi = 2.0 * 3.14159265358979323846 * (j + 0.5) / sectors;
            const Eigen::Vector3d to = c + rho * (std::cos(phi) * u + std::sin(phi) * v) - pd;
            const double d2 = to.squaredNorm();
            const Eigen::Vector3d w = to / std::sqrt(d2);
            const double cos_light = -w.dot(facing);
            if (!light.two_sided && cos_light <= 0.0) {
                continue;
            }
            sum += g(w) * std::abs(cos_light) / d2 * rho;
        }
    }
    return sum * face.norm() * (1.0 / rings) * (2.0 * 3.14159265358979323846 / sectors);
}

double quadrature_solid_angle(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n) {
    const Eigen::Vector3d nd = n.cast<double>();
    return quadrature_over_light(
        light, p, 1500, 1500, [&](const Eigen::Vector3d& w) { return std::max(0.0, nd.dot(w)); });
}

double quadrature_highlight(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                            const Vec3f& wo, double e) {
    const Eigen::Vector3d nd = n.cast<double>();
    const Eigen::Vector3d wd = wo.cast<double>();
    const Eigen::Vector3d r = 2.0 * wd.dot(nd) * nd - wd;
    return quadrature_over_light(light, p, 1500, 1500, [&](const Eigen::Vector3d& w) {
        const double lobe = std::max(0.0, r.dot(w));
        return (e + 2.0) / (2.0 * 3.14159265358979323846) * std::pow(lobe, e) *
               std::max(0.0, nd.dot(w));
    });
}

/// The highlight of a receiver at the origin facing up, seen from straight above.
float area_light_highlight_at_normal_incidence(const EllipticalAreaLight& light) {
    return area_light_phong_highlight(light, Vec3f::Zero(), Vec3f::UnitY(), Vec3f::UnitY(), 20.0f);
}

TEST(AreaLightIrradiance, DiscOnItsAxisMatchesTheClosedForm) {
    // E = π L r² / (r² + h²) at a receiver facing a disc of radius r at height h.
    for (const auto& [r, h] :
         {std::pair{1.0f, 1.0f}, {0.5f, 3.0f}, {2.0f, 0.25f}, {6.0f, 5.0f}, {0.01f, 100.0f}}) {
        const double expected =
            kPi * r * r / (static_cast<double>(r) * r + static_cast<double>(h) * h);
        EXPECT_NEAR(
            area_light_projected_solid_angle(disc_light(r, h), Vec3f::Zero(), Vec3f::UnitY()),
            expected, 1e-5 * expected)
            << "r " << r << " h " << h;
    }
}

TEST(AreaLightIrradiance, OffAxisAndTiltedMatchesQuadrature) {
    EllipticalAreaLight tilted;
    tilted.center = Vec3f(1.0f, 3.0f, -0.5f);
    tilted.semi_axis_u = Vec3f(2.0f, 0.3f, 0.0f);  // not orthogonal to v
    tilted.semi_axis_v = Vec3f(0.4f, -0.2f, 1.0f);
    if (tilted.normal().y() > 0.0f) {
        std::swap(tilted.semi_axis_u, tilted.semi_axis_v);  // face the receivers below
    }
    const Vec3f tilted_normal = Vec3f(0.3f, 1.0f, 0.2f).normalized();
    for (const auto& [light, p, n] :
         {std::tuple{disc_light(1.0f, 1.0f), Vec3f(1.5f, 0.0f, 0.3f), Vec3f::UnitY().eval()},
          std::tuple{disc_light(6.0f, 5.0f), Vec3f(4.0f, 0.0f, -3.0f), tilted_normal},
          std::tuple{tilted, Vec3f(-1.0f, 0.5f, 2.0f), tilted_normal},
          std::tuple{tilted, Vec3f(2.0f, -4.0f, 0.0f), Vec3f::UnitY().eval()}}) {
        const double expected = quadrature_solid_angle(light, p, n);
        EXPECT_GT(expected, 0.01);
        EXPECT_NEAR(area_light_projected_solid_angle(light, p, n), expected, 2e-4 * expected)
            << "p " << p.transpose() << " n " << n.transpose();
    }
}

TEST(AreaLightIrradiance, LightStraddlingTheTangentPlaneCountsOnlyThePartAbove) {
    // A disc of radius 2 at height 1, seen by receivers tilted so that their tangent plane cuts
    // it: only the directions above the plane count.
    const EllipticalAreaLight light = disc_light(2.0f, 1.0f);
    for (const float tilt : {0.6f, 1.2f, 1.5f}) {
        const Vec3f n(std::sin(tilt), std::cos(tilt), 0.0f);
        const double expected = quadrature_solid_angle(light, Vec3f::Zero(), n);
        const double full = quadrature_solid_angle(light, Vec3f::Zero(), Vec3f::UnitY());
        EXPECT_NEAR(area_light_projected_solid_angle(light, Vec3f::Zero(), n), expected,
                    5e-4 * expected)
            << "tilt " << tilt;
        EXPECT_LT(expected, full);
    }
    // Wholly behind the tangent plane: nothing.
    EXPECT_EQ(area_light_projected_solid_angle(light, Vec3f::Zero(), -Vec3f::UnitY()), 0.0);
}

TEST(AreaLightIrradiance, OneSidedLightGivesNothingBehindIt) {
    EllipticalAreaLight light = disc_light(1.0f, -1.0f);  // below the receiver, facing down
    EXPECT_EQ(area_light_projected_solid_angle(light, Vec3f::Zero(), -Vec3f::UnitY()), 0.0);
    EXPECT_EQ(area_light_highlight_at_normal_incidence(light), 0.0f);
    light.two_sided = true;
    EXPECT_NEAR(area_light_projected_solid_angle(light, Vec3f::Zero(), -Vec3f::UnitY()), kPi * 0.5,
                1e-6);
    // In its own plane a light covers no solid angle.
    EXPECT_EQ(area_light_projected_solid_angle(light, Vec3f(3.0f, -1.0f, 0.0f), Vec3f::UnitX()),
              0.0);
}

TEST(AreaLightIrradiance, InvariantUnderScalingTheScene) {
    EllipticalAreaLight light = disc_light(1.5f, 2.0f);
    light.center += Vec3f(0.7f, 0.0f, -0.4f);
    const Vec3f p(0.2f, 0.1f, 0.3f);
    const Vec3f n = Vec3f(0.2f, 1.0f, -0.1f).normalized();
    const double reference = area_light_projected_solid_angle(light, p, n);
    for (const float scale : {1e-6f, 1e-3f, 1e3f, 1e6f}) {
        EllipticalAreaLight scaled = light;
        scaled.center *= scale;
        scaled.semi_axis_u *= scale;
        scaled.semi_axis_v *= scale;
        EXPECT_NEAR(area_light_projected_solid_angle(scaled, scale * p, n), reference,
                    1e-5 * reference)
            << "scale " << scale;
    }
}

TEST(AreaLightIrradiance, InfiniteEmitterGivesPiTimesItsRadiance) {
    // A disc of radius 1e6 one unit above: π·r²/(r² + 1) = π to 1e-12; from off centre too.
    for (const Vec3f& p : {Vec3f(0.0f, 0.0f, 0.0f), Vec3f(1000.0f, 0.0f, -2000.0f)}) {
        EXPECT_NEAR(area_light_projected_solid_angle(disc_light(1e6f, 1.0f), p, Vec3f::UnitY()),
                    kPi, 1e-6);
    }
}

TEST(AreaLightHighlight, MatchesQuadratureForSmallAndLargeLightsAndLobes) {
    const Vec3f wo = Vec3f(0.5f, 1.0f, 0.2f).normalized();
    const Vec3f n = Vec3f(-0.1f, 1.0f, 0.05f).normalized();
    for (const auto& [radius, exponent] : {std::pair{0.3f, 0.0f},
                                           {0.3f, 10.0f},
                                           {0.3f, 300.0f},
                                           {3.0f, 10.0f},
                                           {3.0f, 80.0f},
                                           {3.0f, 300.0f},
                                           {12.0f, 80.0f}}) {
        EllipticalAreaLight light = disc_light(radius, 5.0f);
        light.center = Vec3f(-2.5f, 5.0f, -1.0f);  // around the mirror direction of wo
        const double expected = quadrature_highlight(light, Vec3f::Zero(), n, wo, exponent);
        const float got = area_light_phong_highlight(light, Vec3f::Zero(), n, wo, exponent);
        std::printf("  radius %g exponent %g: %.6g against %.6g\n", radius, exponent, got,
                    expected);
        EXPECT_NEAR(got, expected, 0.03 * expected + 1e-4)
            << "radius " << radius << " e " << exponent;
    }
}

TEST(AreaLightHighlight, InfiniteEmitterGivesTheLobesIntegral) {
    // Seen along the normal, the lobe (e+2)/(2π)·cos^e·cos integrates to 1 over the hemisphere.
    for (const float exponent : {0.0f, 10.0f, 80.0f, 300.0f}) {
        EXPECT_NEAR(area_light_phong_highlight(disc_light(1e6f, 1.0f), Vec3f::Zero(),
                                               Vec3f::UnitY(), Vec3f::UnitY(), exponent),
                    1.0f, 0.01f)
            << "exponent " << exponent;
    }
}
}  // namespace
}  // namespace mrt
