#include "trace/cone/apex_ellipse.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mrt {
namespace {

constexpr float kMaxAnisotropy = 16.0f;

FootprintCone from_apex(const Mat2f& incr) {
    FootprintCone cone;
    cone.start_dev = Mat2f::Zero();
    cone.incr_dev = incr;
    return cone;
}

Mat2f random_footprint(std::mt19937& rng) {
    std::uniform_real_distribution<float> entry(-1.0f, 1.0f);
    std::uniform_real_distribution<float> exponent(-6.0f, 0.0f);
    Mat2f m;
    m << entry(rng), entry(rng), entry(rng), entry(rng);
    return std::pow(10.0f, exponent(rng)) * m;
}

TEST(ApexEllipse, IsTheDecompositionAtEveryDepthToRounding) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> depth_exponent(-3.0f, 5.0f);
    for (int i = 0; i < 2000; ++i) {
        const FootprintCone cone = from_apex(random_footprint(rng));
        const ApexEllipse apex = ApexEllipse::of(cone, kMaxAnisotropy);
        ASSERT_TRUE(apex.valid);
        const float t = std::pow(10.0f, depth_exponent(rng));
        ASSERT_TRUE(apex.covers(t));
        const SymmetricEigen2 exact = FootprintCone::ellipse_of(cone.at(t));
        const SymmetricEigen2 scaled = apex.ellipse(t);
        EXPECT_NEAR(scaled.major, exact.major, 1e-6f * exact.major);
        // The minor eigenvalue of F·Fᵀ in float is known to ~1e-7 of the major one.
        EXPECT_NEAR(scaled.minor, exact.minor, 1e-6f * exact.major);
        if (exact.major - exact.minor > 1e-3f * exact.major) {
            EXPECT_NEAR(std::abs(scaled.major_axis.dot(exact.major_axis)), 1.0f, 1e-5f);
        }
        // The frames map every offset to the same Gaussian coordinates: compare the quadratic
        // forms, which do not depend on which of ±axis either picked. Rounding F·Fᵀ's entries
        // turns either axis by ~1e-7, which moves a form of condition up to the clamp's
        // anisotropy squared by that much relative to its largest value.
        const GaussianFrame reference = GaussianFrame::of_clamped(cone.at(t), kMaxAnisotropy);
        const GaussianFrame frame = apex.frame(t);
        for (const Vec2f& offset : {Vec2f(1.0f, 0.0f), Vec2f(0.0f, 1.0f), Vec2f(0.6f, -0.8f)}) {
            const Vec2f x = std::sqrt(exact.major) * offset;
            const float expected = reference.map(x).squaredNorm();
            EXPECT_NEAR(frame.map(x).squaredNorm(), expected,
                        1e-6f * kMaxAnisotropy * kMaxAnisotropy * (1.0f + expected));
        }
    }
}

TEST(ApexEllipse, TheAnisotropyClampCommutesWithTheDepth) {
    Mat2f thin;
    thin << 1e-3f, 0.0f, 0.0f, 1e-6f;  // 1000:1, clamped to 16:1
    const FootprintCone cone = from_apex(thin);
    const ApexEllipse apex = ApexEllipse::of(cone, kMaxAnisotropy);
    ASSERT_TRUE(apex.valid);
    for (const float t : {0.01f, 1.0f, 250.0f}) {
        const Vec2f along_minor(0.0f, t * 1e-3f);
        const float expected =
            GaussianFrame::of_clamped(cone.at(t), kMaxAnisotropy).map(along_minor).squaredNorm();
        EXPECT_NEAR(expected, kMaxAnisotropy * kMaxAnisotropy, 1e-2f);
        EXPECT_NEAR(apex.frame(t).map(along_minor).squaredNorm(), expected, 1e-4f * expected);
    }
}

TEST(ApexEllipse, OnlyAConeThatGrowsFromNothingAtItsApex) {
    Mat2f d;
    d << 1e-3f, 2e-4f, -1e-4f, 5e-4f;
    FootprintCone started = from_apex(d);
    started.start_dev = 1e-9f * Mat2f::Identity();
    EXPECT_FALSE(ApexEllipse::of(started, kMaxAnisotropy).valid);
    FootprintCone blurred = from_apex(d);
    blurred.add_blur(Mat2f::Zero(), d);
    EXPECT_FALSE(ApexEllipse::of(blurred, kMaxAnisotropy).valid);
    EXPECT_FALSE(ApexEllipse::of(from_apex(Mat2f::Zero()), kMaxAnisotropy).valid);
    Mat2f infinite = d;
    infinite(0, 1) = std::numeric_limits<float>::infinity();
    EXPECT_FALSE(ApexEllipse::of(from_apex(infinite), kMaxAnisotropy).valid);
    const ApexEllipse apex = ApexEllipse::of(from_apex(d), kMaxAnisotropy);
    ASSERT_TRUE(apex.valid);
    // At the apex and behind it the footprint is not t·D's decomposition scaled (t = 0 is no
    // ellipse at all); nor where t² overflows the eigenvalues.
    EXPECT_FALSE(apex.covers(0.0f));
    EXPECT_FALSE(apex.covers(-1.0f));
    EXPECT_FALSE(apex.covers(std::numeric_limits<float>::quiet_NaN()));
    EXPECT_FALSE(apex.covers(1e30f));
    EXPECT_TRUE(apex.covers(1e6f));
}

}  // namespace
}  // namespace mrt
