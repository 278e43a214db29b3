#include "trace/cone/light_share.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace mrt {
namespace {

/// A shadow cone's frame from p toward the light's centre, as ConeTracer::visibility sets it.
FootprintCone cone_toward(const EllipticalAreaLight& light, const Vec3f& p) {
    FootprintCone cone;
    orthonormal_basis((light.center - p).normalized(), cone.u, cone.v);
    return cone;
}

/// The samples whose rays meet the light at disc points where `blocked` holds.
template <class Blocked>
CoverageMask samples_where(const EllipticalAreaLight& light, const FootprintCone& cone,
                           Blocked blocked) {
    const Mat2f map = *light_disc_map(light, cone);
    const CoverageSamples& s = coverage_samples(SamplePattern::LightDisc);
    CoverageMask mask = 0;
    for (int k = 0; k < kCoverageSamples; ++k) {
        const auto i = static_cast<std::size_t>(k);
        if (blocked(Vec2f(map * Vec2f(s.x[i], s.y[i])))) {
            mask |= CoverageMask{1} << k;
        }
    }
    return mask;
}

/// ∫ cos θ · cos θ′ / r² over the disc points z of the light where `free` holds, by the
/// midpoint rule on a fine polar grid in double precision (the independent reference).
template <class Free>
double irradiance_where(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                        Free free) {
    const int rings = 400;
    const int sectors = 800;
    const Eigen::Vector3d normal = light.normal().cast<double>();
    double sum = 0.0;
    for (int a = 0; a < rings; ++a) {
        const double radius = (a + 0.5) / rings;
        for (int b = 0; b < sectors; ++b) {
            const double angle = 2.0 * std::numbers::pi * (b + 0.5) / sectors;
            const Vec2f z(static_cast<float>(radius * std::cos(angle)),
                          static_cast<float>(radius * std::sin(angle)));
            if (!free(z)) {
                continue;
            }
            const Eigen::Vector3d point =
                (light.center + z.x() * light.semi_axis_u + z.y() * light.semi_axis_v)
                    .cast<double>();
            const Eigen::Vector3d d = point - p.cast<double>();
            const double r2 = d.squaredNorm();
            const double cos_receiver = std::max(0.0, n.cast<double>().dot(d) / std::sqrt(r2));
            const double cos_light = std::max(0.0, -normal.dot(d) / std::sqrt(r2));
            sum += cos_receiver * cos_light / r2 * radius;  // the polar area element's r
        }
    }
    return sum;
}

EllipticalAreaLight light_overhead(float radius, float height) {
    EllipticalAreaLight light;
    light.center = Vec3f(0.0f, height, 0.0f);
    light.semi_axis_u = Vec3f(radius, 0.0f, 0.0f);
    light.semi_axis_v = Vec3f(0.0f, 0.0f, radius);  // u × v points down, at the receiver
    return light;
}

TEST(LightShare, SamplesMeetTheLightEvenlyInsideItsDisc) {
    const EllipticalAreaLight light = light_overhead(2.0f, 3.0f);
    const Vec3f p(0.7f, 0.0f, -0.4f);
    const FootprintCone cone = cone_toward(light, p);
    const Mat2f map = *light_disc_map(light, cone);
    const CoverageSamples& s = coverage_samples(SamplePattern::LightDisc);
    Vec2f mean = Vec2f::Zero();
    int inner = 0;
    for (std::size_t i = 0; i < kCoverageSamples; ++i) {
        const Vec2f z = map * Vec2f(s.x[i], s.y[i]);
        EXPECT_LE(z.norm(), 1.0f + 1e-4f) << "sample " << i;
        mean += z / kCoverageSamples;
        inner += z.norm() < std::sqrt(0.5f) ? 1 : 0;
    }
    EXPECT_LT(mean.norm(), 0.05f);
    EXPECT_NEAR(inner, kCoverageSamples / 2, 1);  // half of the area, half of the samples
}

TEST(LightShare, NothingCoveredPassesAllAndEverythingNothing) {
    const EllipticalAreaLight light = light_overhead(1.0f, 2.0f);
    const Vec3f p = Vec3f::Zero();
    const Vec3f n(0.0f, 1.0f, 0.0f);
    const FootprintCone cone = cone_toward(light, p);
    EXPECT_EQ(unblocked_light_share(light, p, n, cone, 0), 1.0f);
    EXPECT_EQ(unblocked_light_share(light, p, n, cone, kFullCoverage), 0.0f);
}

TEST(LightShare, AnOverheadLightsCentreDeliversMoreThanItsShareOfArea) {
    // A disc of radius a at height h = a over the receiver; its inner half radius is a quarter
    // of its area but F(a/2)/F(a) = 0.4 of its irradiance, F(R) = R²/(h² + R²).
    const EllipticalAreaLight light = light_overhead(1.0f, 1.0f);
    const Vec3f p = Vec3f::Zero();
    const Vec3f n(0.0f, 1.0f, 0.0f);
    const FootprintCone cone = cone_toward(light, p);
    const CoverageMask rim =
        samples_where(light, cone, [](const Vec2f& z) { return z.norm() > 0.5f; });
    EXPECT_EQ(std::popcount(rim), 48);
    EXPECT_NEAR(unblocked_light_share(light, p, n, cone, rim), 0.4f, 0.02f);
}

TEST(LightShare, APenumbrasVisiblePartWeighsAsTheDistributedTracersSamplesDo) {
    // A large tilted ellipse off to one side of a tilted receiver, part of it hidden beyond a
    // line through it: the free part's share of the irradiance against a fine quadrature.
    EllipticalAreaLight light;
    light.center = Vec3f(1.5f, 2.0f, 0.5f);
    light.semi_axis_u = Vec3f(1.6f, 0.3f, 0.0f);
    light.semi_axis_v = Vec3f(0.0f, -0.2f, 0.9f);  // facing down-ish, at the receiver
    const Vec3f p(0.0f, 0.0f, 0.0f);
    const Vec3f n = Vec3f(-0.2f, 1.0f, 0.1f).normalized();
    const FootprintCone cone = cone_toward(light, p);
    const double whole = irradiance_where(light, p, n, [](const Vec2f&) { return true; });
    for (const float line : {-0.4f, 0.0f, 0.5f}) {
        const auto blocked = [line](const Vec2f& z) { return z.x() + 0.3f * z.y() > line; };
        const CoverageMask covered = samples_where(light, cone, blocked);
        const double exact =
            irradiance_where(light, p, n, [&](const Vec2f& z) { return !blocked(z); }) / whole;
        const float counted = 1.0f - mask_coverage(covered);
        const float weighed = unblocked_light_share(light, p, n, cone, covered);
        EXPECT_NEAR(weighed, exact, 0.03) << "line " << line << ", counted " << counted;
        // Not vacuous: weighing moves the share by more than the tolerance somewhere.
        if (line == 0.0f) {
            EXPECT_GT(std::abs(counted - exact), 0.04) << "exact " << exact;
        }
    }
}

}  // namespace
}  // namespace mrt
