// The A-buffer's fragment sums (trace/cone/cone_surface.h): a fragment that absorbs another
// (a merge by interval, a full buffer's forced merge) must average to what one fragment of all
// their contributions averages to, field by field, or a merge dilutes what it forgets.

#include "trace/cone/cone_surface.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace mrt {
namespace {

ConeSurface random_contribution(std::mt19937& rng) {
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    ConeSurface s;
    s.normal = Vec3f(unit(rng) - 0.5f, unit(rng) - 0.5f, unit(rng)).normalized();
    s.diffuse = Rgb(unit(rng), unit(rng), unit(rng));
    s.specular = Rgb(unit(rng), unit(rng), unit(rng));
    s.phong_exponent = 1.0f + 100.0f * unit(rng);
    s.reflectivity = unit(rng);
    s.transparency = unit(rng);
    s.roughness = unit(rng);
    s.ior = 1.0f + unit(rng);
    s.lobe_spread = 0.1f * unit(rng);
    for (float& h : s.highlights) {
        h = 10.0f * unit(rng);
    }
    s.shape = Mat3f::Identity() * unit(rng);
    return s;
}

void expect_same_average(const ConeSurface& a, const ConeSurface& b) {
    constexpr float kTolerance = 1e-5f;
    for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(a.normal[k], b.normal[k], kTolerance);
        EXPECT_NEAR(a.diffuse[k], b.diffuse[k], kTolerance);
        EXPECT_NEAR(a.specular[k], b.specular[k], kTolerance);
    }
    EXPECT_NEAR(a.normal_length, b.normal_length, kTolerance);
    EXPECT_NEAR(a.phong_exponent, b.phong_exponent, 1e-3f);
    EXPECT_NEAR(a.reflectivity, b.reflectivity, kTolerance);
    EXPECT_NEAR(a.transparency, b.transparency, kTolerance);
    EXPECT_NEAR(a.roughness, b.roughness, kTolerance);
    EXPECT_NEAR(a.ior, b.ior, kTolerance);
    EXPECT_NEAR(a.lobe_spread, b.lobe_spread, kTolerance);
    for (std::size_t l = 0; l < kHighlightLights; ++l) {
        EXPECT_NEAR(a.highlights[l], b.highlights[l], 1e-4f) << "highlight of light " << l;
    }
    EXPECT_TRUE(a.shape.isApprox(b.shape));
}

TEST(ConeSurface, MergedSumsAverageAsOneSumOfEveryContribution) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> weight(0.05f, 1.0f);
    for (int trial = 0; trial < 20; ++trial) {
        ConeSurface all;
        ConeSurface front;
        ConeSurface back;
        float total = 0.0f;
        const int count = 2 + trial % 7;
        for (int i = 0; i < count; ++i) {
            const ConeSurface c = random_contribution(rng);
            const float w = weight(rng);
            all.add(c, w);
            (i % 2 == 0 ? front : back).add(c, w);
            total += w;
        }
        front.merge(back);
        expect_same_average(front.averaged(total), all.averaged(total));
    }
}

}  // namespace
}  // namespace mrt
