// Sampling warps checked against their stated densities (chi-square) and moments.

#include "common/math/sampling.h"
#include "common/math/random.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace mrt {
namespace {

/// Standard normal CDF.
double phi(double x) {
    return 0.5 * std::erfc(-x / std::sqrt(2.0));
}

/// Chi-square of samples against N(0, 1) over `bins` equal-probability bins.
double chi_square_normal(const std::vector<double>& xs, int bins) {
    std::vector<int> counts(static_cast<std::size_t>(bins), 0);
    for (double x : xs) {
        const int bin = std::min(bins - 1, static_cast<int>(phi(x) * bins));
        ++counts[static_cast<std::size_t>(bin)];
    }
    const double expected = static_cast<double>(xs.size()) / bins;
    double chi2 = 0.0;
    for (int c : counts) {
        chi2 += (c - expected) * (c - expected) / expected;
    }
    return chi2;
}

TEST(Sampling, StandardNormalPairIsStandardNormalAndFinite) {
    std::vector<double> xs;
    std::vector<double> ys;
    for (std::uint32_t i = 0; i < 50000; ++i) {
        SampleRng rng(3, i, 0, 0);
        const Vec2f g = standard_normal_pair(rng.uniform(), rng.uniform());
        xs.push_back(g.x());
        ys.push_back(g.y());
    }
    // 39 degrees of freedom: P(χ² > 72.1) = 0.001.
    EXPECT_LT(chi_square_normal(xs, 40), 72.1);
    EXPECT_LT(chi_square_normal(ys, 40), 72.1);
    EXPECT_TRUE(standard_normal_pair(0.0f, 0.3f).allFinite());
    EXPECT_TRUE(standard_normal_pair(0x1.fffffep-1f, 0.3f).allFinite());
}

TEST(Sampling, GaussianSpreadHasTheStatedTangentPlaneDeviation) {
    const Vec3f axis = Vec3f(0.3f, -0.8f, 0.52f).normalized();
    Vec3f t;
    Vec3f b;
    orthonormal_basis(axis, t, b);
    for (float sigma : {0.01f, 0.2f, 1.0f}) {
        std::vector<double> xs;
        std::vector<double> ys;
        for (std::uint32_t i = 0; i < 40000; ++i) {
            SampleRng rng(11, i, 1, 0);
            const Vec3f d = gaussian_spread_direction(axis, sigma, rng.uniform(), rng.uniform());
            ASSERT_NEAR(d.norm(), 1.0f, 1e-5f);
            // Back to the plane at distance 1 along the axis, in units of sigma.
            xs.push_back(d.dot(t) / d.dot(axis) / sigma);
            ys.push_back(d.dot(b) / d.dot(axis) / sigma);
        }
        EXPECT_LT(chi_square_normal(xs, 40), 72.1) << "sigma " << sigma;
        EXPECT_LT(chi_square_normal(ys, 40), 72.1) << "sigma " << sigma;
    }
    EXPECT_EQ(gaussian_spread_direction(axis, 0.0f, 0.5f, 0.5f), axis);
}

TEST(Sampling, PermuteIndexIsABijectionForAnyLength) {
    for (std::uint32_t length : {1U, 2U, 3U, 5U, 7U, 16U, 17U, 100U, 1000U}) {
        for (std::uint32_t key : {0U, 1U, 0xdeadbeefU, 0x12345678U}) {
            std::vector<int> seen(length, 0);
            for (std::uint32_t i = 0; i < length; ++i) {
                const std::uint32_t p = permute_index(i, length, key);
                ASSERT_LT(p, length);
                ++seen[p];
            }
            for (std::uint32_t i = 0; i < length; ++i) {
                ASSERT_EQ(seen[i], 1) << "length " << length << " key " << key;
            }
        }
    }
}

TEST(Sampling, PixelSamplesAreStratifiedInBothAxes) {
    EXPECT_EQ(pixel_sample(1, 3, 4, 0, 1), Vec2f(0.5f, 0.5f));
    for (int count : {2, 3, 4, 5, 9, 12, 16, 33}) {
        const int side = static_cast<int>(std::lround(std::sqrt(count)));
        const bool grid = side * side == count;
        const int nx = grid ? side : count;
        std::vector<int> cells(static_cast<std::size_t>(nx * nx), 0);
        std::vector<int> rows(static_cast<std::size_t>(nx), 0);
        for (int i = 0; i < count; ++i) {
            const Vec2f s = pixel_sample(42, 17, 9, i, count);
            ASSERT_TRUE(s.x() >= 0.0f && s.x() < 1.0f && s.y() >= 0.0f && s.y() < 1.0f);
            const int cx = static_cast<int>(s.x() * static_cast<float>(nx));
            const int cy = static_cast<int>(s.y() * static_cast<float>(nx));
            ++cells[static_cast<std::size_t>(cy * nx + cx)];
            ++rows[static_cast<std::size_t>(cy)];
        }
        for (int c : cells) {
            // A grid fills every cell once; N-rooks at most once per cell and once per row.
            ASSERT_LE(c, 1) << "count " << count;
        }
        for (int r : rows) {
            ASSERT_EQ(r, grid ? side : 1) << "count " << count;
        }
    }
}

}  // namespace
}  // namespace mrt
