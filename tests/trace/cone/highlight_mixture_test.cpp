// The highlight mixture (trace/cone/highlight_mixture.h): its lobe against the exact Phong
// highlight of an elliptical light (area_light_phong_highlight, a deterministic quadrature),
// one contributor's mixture as its own highlight, and a footprint of two facets whose mean
// normal misses the light's glint while the mixture keeps it.

#include "trace/cone/highlight_mixture.h"
#include "trace/render/area_light.h"
#include "trace/render/shading.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

namespace mrt {
namespace {

/// A round light of angular radius `radius` (radians) at distance 10 from the origin, in the
/// direction `towards`, facing the origin.
EllipticalAreaLight light_towards(const Vec3f& towards, float radius) {
    EllipticalAreaLight light;
    const Vec3f d = towards.normalized();
    light.center = 10.0f * d;
    Vec3f u;
    Vec3f v;
    orthonormal_basis(-d, u, v);
    const float r = 10.0f * std::tan(radius);
    // u × v along −d: the light faces the origin.
    light.semi_axis_u = r * u;
    light.semi_axis_v = r * v;
    return light;
}

Scene scene_with(const EllipticalAreaLight& light) {
    Scene scene;
    scene.area_lights.push_back(light);
    return scene;
}

/// The unit vector at angle `angle` from +z towards +x.
Vec3f tilted(float angle) {
    return {std::sin(angle), 0.0f, std::cos(angle)};
}

TEST(HighlightMixture, LobeIsTheExactHighlightOfTheLightWithinTenPerCentOfItsPeak) {
    // Light 40° from the normal; the eye placed so that the mirror direction misses the
    // light's centre by θ.
    const Vec3f n = Vec3f::UnitZ();
    const Vec3f to_light = tilted(0.7f);
    double worst = 0.0;
    for (const float exponent : {20.0f, 60.0f, 300.0f}) {
        for (const float radius : {0.005f, 0.05f, 0.15f}) {
            const EllipticalAreaLight light = light_towards(to_light, radius);
            const HighlightLights lights(scene_with(light));
            float peak = 0.0f;
            std::vector<std::pair<float, float>> values;
            for (const float offset : {0.0f, 0.5f, 1.0f, 2.0f, 3.0f}) {
                // The mirror direction r is the light's direction turned by θ about y; the eye
                // is r mirrored about n.
                const float theta = offset * (1.0f / std::sqrt(exponent) + radius);
                const Vec3f r = tilted(0.7f + theta);
                const Vec3f wo = reflect(-r, n);
                const float exact =
                    area_light_phong_highlight(light, Vec3f::Zero(), n, wo, exponent);
                const float approximate = lights.of_light(0, Vec3f::Zero(), n, wo, exponent);
                peak = std::max(peak, exact);
                values.emplace_back(exact, approximate);
            }
            for (const auto& [exact, approximate] : values) {
                const double error = std::abs(approximate - exact) / peak;
                worst = std::max(worst, error);
                EXPECT_LT(error, 0.1) << "exponent " << exponent << " radius " << radius
                                      << " exact " << exact << " approximate " << approximate;
            }
        }
    }
    std::printf("  worst error over the peak: %.4f\n", worst);
}

TEST(HighlightMixture, OneContributorsMixtureIsItsOwnWidenedHighlight) {
    // The surface at the origin, seen along `direction`; the light near its mirror direction.
    const Vec3f direction = Vec3f(0.1f, -0.05f, -1.0f).normalized();
    const Vec3f n = Vec3f(-0.3f, 0.05f, 1.0f).normalized();
    const EllipticalAreaLight light =
        light_towards(reflect(direction, n) + Vec3f(0.05f, 0.0f, 0.0f), 0.03f);
    const HighlightLights lights(scene_with(light));
    ASSERT_EQ(lights.count(), 1u);
    for (const float length : {1.0f, 0.99f, 0.9f}) {
        const float mixed = lights.at(Vec3f::Zero(), direction, length * n, 80.0f)[0];
        const float own =
            lights.of_light(0, Vec3f::Zero(), n, -direction, toksvig_exponent(80.0f, length));
        EXPECT_NEAR(mixed, own, 1e-4f * own) << length;  // the normal rescaled by its length
        EXPECT_GT(own, 0.0f);
    }
    // The lights past the first kHighlightLights are not mixed; none here.
    EXPECT_EQ(lights.at(Vec3f::Zero(), direction, n, 80.0f)[1], 0.0f);
}

TEST(HighlightMixture, TwoFacetsKeepTheGlintTheirMeanNormalMisses) {
    // A footprint half on a facet tilted +δ, half on one tilted −δ, under a small light whose
    // mirror direction the first facet catches: the reference is the average of the two facets'
    // exact highlights. The mean normal (tilt 0, Toksvig-widened by the facets' spread) sees a
    // dim smear; the mixture of the facets' own lobes the glint.
    const float exponent = 300.0f;
    const float delta = 0.12f;  // 2δ of mirror turn: well past the lobe's 1/√300 = 0.058
    const Vec3f wo = Vec3f::UnitZ();
    // The light in the mirror direction of the +δ facet: wo mirrored about it.
    const Vec3f plus = tilted(delta);
    const Vec3f minus = tilted(-delta);
    const EllipticalAreaLight light = light_towards(reflect(-wo, plus), 0.01f);
    const HighlightLights lights(scene_with(light));
    const double reference =
        0.5 * (area_light_phong_highlight(light, Vec3f::Zero(), plus, wo, exponent) +
               area_light_phong_highlight(light, Vec3f::Zero(), minus, wo, exponent));
    const float mixture = 0.5f * (lights.at(Vec3f::Zero(), -wo, plus, exponent)[0] +
                                  lights.at(Vec3f::Zero(), -wo, minus, exponent)[0]);
    const Vec3f mean = 0.5f * (plus + minus);
    const float mean_normal = area_light_phong_highlight(
        light, Vec3f::Zero(), mean.normalized(), wo, toksvig_exponent(exponent, mean.norm()));
    std::printf("  reference %.4f, mixture %.4f, mean normal %.4f\n", reference, mixture,
                mean_normal);
    EXPECT_NEAR(mixture / reference, 1.0, 0.1);
    EXPECT_LT(mean_normal / reference, 0.5);
}

}  // namespace
}  // namespace mrt
