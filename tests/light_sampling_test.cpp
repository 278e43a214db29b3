// Area-light sampling against its stated density (chi-square) and against the closed-form
// irradiance of a disc light.

#include "common/random.h"
#include "trace/shading.h"

#include <gtest/gtest.h>

#include <cmath>
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

}  // namespace
}  // namespace mrt
