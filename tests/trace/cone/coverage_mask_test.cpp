#include "trace/cone/coverage_mask.h"

#include "common/footprint/point_weight.h"
#include "trace/cone/cone_triangle.h"

#include <gtest/gtest.h>
#include <hwy/tests/hwy_gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace mrt {
namespace {

const double kKeptMass = 1.0 - static_cast<double>(kPointWeightClip);
const double kClipRadius = std::sqrt(-std::log(static_cast<double>(kPointWeightClip)));

/// The mass of exp(−|y|²)/π over {y : y_x ≥ d} inside the clip circle, as a share of the
/// clipped whole: ∫ e^{−x²}/√π · erf(√(R² − x²)) dx from max(d, −R) to R, by Simpson's rule in
/// double precision.
double clipped_half_plane_mass(double d) {
    const double lo = std::max(d, -kClipRadius);
    if (lo >= kClipRadius) {
        return 0.0;
    }
    const int n = 20000;
    const double h = (kClipRadius - lo) / n;
    double sum = 0.0;
    for (int i = 0; i <= n; ++i) {
        const double x = lo + i * h;
        const double f = std::exp(-x * x) / std::sqrt(std::numbers::pi) *
                         std::erf(std::sqrt(std::max(0.0, kClipRadius * kClipRadius - x * x)));
        sum += f * (i == 0 || i == n ? 1.0 : (i % 2 == 1 ? 4.0 : 2.0));
    }
    return sum * h / 3.0 / kKeptMass;
}

Vec2f rotated(const Vec2f& v, float angle) {
    return {std::cos(angle) * v.x() - std::sin(angle) * v.y(),
            std::sin(angle) * v.x() + std::cos(angle) * v.y()};
}

TEST(CoverageMask, EachSampleStandsForAnEqualShareOfTheClippedGaussian) {
    const CoverageSamples& s = coverage_samples();
    std::vector<double> mass;
    for (std::size_t i = 0; i < kCoverageSamples; ++i) {
        const double r2 =
            static_cast<double>(s.x[i]) * s.x[i] + static_cast<double>(s.y[i]) * s.y[i];
        mass.push_back(1.0 - std::exp(-r2));
    }
    std::sort(mass.begin(), mass.end());
    for (std::size_t i = 0; i < mass.size(); ++i) {
        // The i-th sample out from the centre sits where the clipped mass reaches (i + ½)/64.
        EXPECT_NEAR(mass[i] / kKeptMass, (static_cast<double>(i) + 0.5) / kCoverageSamples, 1e-5)
            << i;
    }
    // No two samples share a direction from the centre: each ray of the cone is its own.
    for (std::size_t i = 0; i < kCoverageSamples; ++i) {
        for (std::size_t j = i + 1; j < kCoverageSamples; ++j) {
            const double cross =
                static_cast<double>(s.x[i]) * s.y[j] - static_cast<double>(s.y[i]) * s.x[j];
            const double dot =
                static_cast<double>(s.x[i]) * s.x[j] + static_cast<double>(s.y[i]) * s.y[j];
            EXPECT_FALSE(std::abs(cross) < 1e-6 && dot > 0.0) << i << " " << j;
        }
    }
}

TEST(CoverageMask, LightDiscMasksCoverTheShareOfTheLightAHalfPlaneHides) {
    // A shadow cone's samples stand for equal areas of the uniform disc of radius √2: a
    // half-plane beyond y_x = d covers the disc's segment, (θ − sin θ)/(2π) with
    // θ = 2·acos(d/√2) — the share of the light an occluder's straight edge hides.
    const double radius = std::sqrt(2.0);
    const CoverageSamples& s = coverage_samples(SamplePattern::LightDisc);
    for (std::size_t i = 0; i < kCoverageSamples; ++i) {
        EXPECT_LT(std::hypot(s.x[i], s.y[i]), radius);
    }
    double worst = 0.0;
    double total = 0.0;
    int count = 0;
    for (int o = 0; o <= 80; ++o) {
        const double d = -1.5 + 3.0 * o / 80.0;
        const double clamped = std::clamp(d / radius, -1.0, 1.0);
        const double theta = 2.0 * std::acos(clamped);
        const double exact = (theta - std::sin(theta)) / (2.0 * std::numbers::pi);
        for (int a = 0; a < 96; ++a) {
            const float angle = 2.0f * std::numbers::pi_v<float> * static_cast<float>(a) / 96.0f;
            const Vec2f from = rotated(Vec2f(static_cast<float>(d), 1.0f), angle);
            const Vec2f to = rotated(Vec2f(static_cast<float>(d), 0.0f), angle);
            const double error =
                std::abs(mask_coverage(edge_mask(from, to, SamplePattern::LightDisc)) - exact);
            worst = std::max(worst, error);
            total += error;
            ++count;
        }
    }
    RecordProperty("light_disc_half_plane_worst", std::to_string(worst));
    RecordProperty("light_disc_half_plane_mean", std::to_string(total / count));
    EXPECT_LE(worst, kHalfPlaneMaskError);
    EXPECT_LE(total / count, 0.01);
    // Holes close in this pattern too.
    EXPECT_EQ(close_holes(kFullCoverage & ~(CoverageMask{1} << 40), SamplePattern::LightDisc),
              kFullCoverage);
}

TEST(CoverageMask, HalfPlaneMaskAreaIsItsClippedGaussianMass) {
    // Every direction and offset across the clip circle; the mass depends on the offset only.
    double worst = 0.0;
    double total = 0.0;
    int count = 0;
    for (int o = 0; o <= 80; ++o) {
        const double d = -2.0 + 4.0 * o / 80.0;
        const double exact = clipped_half_plane_mass(d);
        for (int a = 0; a < 96; ++a) {
            const float angle = 2.0f * std::numbers::pi_v<float> * static_cast<float>(a) / 96.0f;
            // The line y_x = d, directed so that y_x > d lies to its left, turned by `angle`.
            const Vec2f from = rotated(Vec2f(static_cast<float>(d), 1.0f), angle);
            const Vec2f to = rotated(Vec2f(static_cast<float>(d), 0.0f), angle);
            const double error = std::abs(mask_coverage(edge_mask(from, to)) - exact);
            worst = std::max(worst, error);
            total += error;
            ++count;
        }
    }
    EXPECT_LE(worst, kHalfPlaneMaskError);
    EXPECT_LE(total / count, 0.01);
    EXPECT_NEAR(clipped_half_plane_mass(-3.0), 1.0, 1e-6);
    EXPECT_NEAR(clipped_half_plane_mass(0.0), 0.5, 1e-6);
}

TEST(CoverageMask, TriangleMaskAreaIsItsGaussianMass) {
    // Triangles inside the clip circle, where the clipped mass is gaussian_triangle_mass's
    // (tested against quadrature in cone_triangle_test.cpp) over the clip's share.
    std::mt19937 random(7);
    std::uniform_real_distribution<float> angle(0.0f, 2.0f * std::numbers::pi_v<float>);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    double worst = 0.0;
    double total = 0.0;
    const int count = 4000;
    for (int i = 0; i < count; ++i) {
        std::array<Vec2f, 3> v;
        for (Vec2f& p : v) {
            const float r = static_cast<float>(kClipRadius) * std::sqrt(unit(random)) * 0.999f;
            p = rotated(Vec2f(r, 0.0f), angle(random));
        }
        const double exact = gaussian_triangle_mass(v[0], v[1], v[2]) / kKeptMass;
        const double error = std::abs(mask_coverage(triangle_mask(v[0], v[1], v[2])) - exact);
        worst = std::max(worst, error);
        total += error;
    }
    EXPECT_LE(worst, kTriangleMaskError);
    EXPECT_LE(total / count, 0.015);
}

TEST(CoverageMask, TriangleMaskIsTheSameForEveryOrderOfItsVertices) {
    const Vec2f a(-0.7f, -0.4f), b(1.1f, -0.2f), c(0.1f, 0.9f);
    const CoverageMask mask = triangle_mask(a, b, c);
    EXPECT_NE(mask, 0u);
    EXPECT_NE(mask, kFullCoverage);
    EXPECT_EQ(triangle_mask(b, c, a), mask);
    EXPECT_EQ(triangle_mask(c, a, b), mask);
    EXPECT_EQ(triangle_mask(a, c, b), mask);
    EXPECT_EQ(triangle_mask(c, b, a), mask);
    EXPECT_EQ(triangle_mask(b, a, c), mask);
}

TEST(CoverageMask, TrianglesSharingAnEdgeTakeEachSampleOnce) {
    const CoverageSamples& s = coverage_samples();
    // A quad that holds the whole clip circle, split along either diagonal: full coverage.
    const float big = 3.0f;
    const Vec2f p0(-big, -big), p1(big, -big), p2(big, big), p3(-big, big);
    EXPECT_EQ(triangle_mask(p0, p1, p2) | triangle_mask(p0, p2, p3), kFullCoverage);
    EXPECT_EQ(triangle_mask(p0, p1, p2) & triangle_mask(p0, p2, p3), 0u);
    EXPECT_EQ(triangle_mask(p1, p2, p3) | triangle_mask(p1, p3, p0), kFullCoverage);
    EXPECT_EQ(triangle_mask(p1, p2, p3) & triangle_mask(p1, p3, p0), 0u);
    // Fans around a point, far enough out to hold the clip circle: their masks partition the
    // samples. Half of them are centred on a sample, which then lies on every triangle's edges.
    std::mt19937 random(11);
    std::uniform_int_distribution<int> pick(0, kCoverageSamples - 1);
    std::uniform_real_distribution<float> spread(-2.5f, 2.5f);
    std::uniform_real_distribution<float> jitter(-0.2f, 0.2f);
    std::uniform_real_distribution<float> turn(0.0f, 2.0f * std::numbers::pi_v<float>);
    for (int trial = 0; trial < 500; ++trial) {
        const auto k = static_cast<std::size_t>(pick(random));
        const Vec2f centre =
            trial % 2 == 0 ? Vec2f(s.x[k], s.y[k]) : Vec2f(spread(random), spread(random));
        const int n = 3 + trial % 5;
        const float start = turn(random);
        std::vector<Vec2f> ring;
        for (int i = 0; i < n; ++i) {
            // Gaps of at most 1.4 · 2π/3 < π between neighbours, so every triangle turns the
            // same way, and the ring (inradius 200·cos(0.47π) > 18) holds the clip circle.
            const float a = start + (static_cast<float>(i) + jitter(random)) * 2.0f *
                                        std::numbers::pi_v<float> / static_cast<float>(n);
            ring.push_back(centre + 200.0f * Vec2f(std::cos(a), std::sin(a)));
        }
        CoverageMask seen = 0;
        for (std::size_t i = 0; i < ring.size(); ++i) {
            const CoverageMask m = triangle_mask(centre, ring[i], ring[(i + 1) % ring.size()]);
            EXPECT_EQ(seen & m, 0u) << trial;
            seen |= m;
        }
        EXPECT_EQ(seen, kFullCoverage) << trial;
    }
    // Quads with their corners on samples, split along a diagonal through two samples: the
    // samples on the diagonal, its ends included, go to one side only, and both splits of a quad
    // cover the same samples.
    int tied = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        std::array<std::size_t, 4> c;
        for (std::size_t& i : c) {
            i = static_cast<std::size_t>(pick(random));
        }
        std::array<Vec2f, 4> q;
        for (std::size_t i = 0; i < 4; ++i) {
            q[i] = Vec2f(s.x[c[i]], s.y[c[i]]);
        }
        // Convex and counter-clockwise in this order, or not a quad to split.
        bool convex = true;
        for (std::size_t i = 0; i < 4; ++i) {
            const Vec2f e = q[(i + 1) % 4] - q[i];
            const Vec2f f = q[(i + 2) % 4] - q[(i + 1) % 4];
            convex = convex &&
                     static_cast<double>(e.x()) * f.y() - static_cast<double>(e.y()) * f.x() > 1e-3;
        }
        if (!convex) {
            continue;
        }
        const CoverageMask first = triangle_mask(q[0], q[1], q[2]);
        const CoverageMask second = triangle_mask(q[0], q[2], q[3]);
        EXPECT_EQ(first & second, 0u) << trial;
        const CoverageMask other_first = triangle_mask(q[1], q[2], q[3]);
        const CoverageMask other_second = triangle_mask(q[1], q[3], q[0]);
        EXPECT_EQ(other_first & other_second, 0u) << trial;
        // The samples at the corners may belong to a neighbour outside; the rest agree.
        CoverageMask corners = 0;
        for (std::size_t i : c) {
            corners |= CoverageMask{1} << i;
        }
        EXPECT_EQ((first | second) & ~corners, (other_first | other_second) & ~corners) << trial;
        ++tied;
    }
    EXPECT_GT(tied, 100);
}

TEST(CoverageMask, CentredCircleHoldsTheSamplesWithinItsRadius) {
    for (const double mass : {0.1, 0.25, 0.5, 0.8, 0.97}) {
        const double radius = std::sqrt(-std::log1p(-mass * kKeptMass));
        const Mat2f form = Mat2f::Identity() / static_cast<float>(radius * radius);
        const int expected = static_cast<int>(std::floor(mass * kCoverageSamples + 0.5));
        EXPECT_EQ(std::popcount(ellipse_mask(Vec2f::Zero(), form)), expected) << mass;
    }
    // An ellipse's mask is the circle's of the samples mapped by its square root.
    const Mat2f stretch{{2.0f, 0.5f}, {0.5f, 1.0f}};
    const Mat2f form = stretch.transpose() * stretch;
    const Vec2f centre(0.3f, -0.2f);
    const CoverageSamples& s = coverage_samples();
    CoverageMask expected = 0;
    CoverageMask unsure = 0;  // within rounding of the ellipse's edge
    for (std::size_t i = 0; i < kCoverageSamples; ++i) {
        const Vec2f y = stretch * (Vec2f(s.x[i], s.y[i]) - centre);
        if (y.squaredNorm() < 0.999f) {
            expected |= CoverageMask{1} << i;
        } else if (y.squaredNorm() <= 1.001f) {
            unsure |= CoverageMask{1} << i;
        }
    }
    EXPECT_LE(std::popcount(unsure), 1);
    EXPECT_EQ(ellipse_mask(centre, form) & ~unsure, expected);
}

class CoverageMaskKernel : public hwy::TestWithParamTarget {};
HWY_TARGET_INSTANTIATE_TEST_SUITE_P(CoverageMaskKernel);

// The dispatched kernel of every instruction set this CPU has answers as the one-sample-at-a-time
// reference, bit for bit, for ellipses of every size and shape, on both patterns' samples.
TEST_P(CoverageMaskKernel, EllipseMaskAnswersAsTheScalarReferenceBitForBit) {
    std::mt19937 random(29);
    std::uniform_real_distribution<float> position(-2.5f, 2.5f);
    std::uniform_real_distribution<float> log_radius(-4.0f, 1.5f);
    std::uniform_real_distribution<float> angle(0.0f, std::numbers::pi_v<float>);
    int partial = 0;
    for (int i = 0; i < 20000; ++i) {
        const float a = std::exp(log_radius(random));
        const float b = std::exp(log_radius(random));
        const float turn = angle(random);
        const Vec2f axis(std::cos(turn), std::sin(turn));
        const Vec2f across(-axis.y(), axis.x());
        const Mat2f form =
            axis * axis.transpose() / (a * a) + across * across.transpose() / (b * b);
        const Vec2f centre(position(random), position(random));
        const SamplePattern pattern =
            i % 2 == 0 ? SamplePattern::Gaussian : SamplePattern::LightDisc;
        const CoverageMask mask = ellipse_mask(centre, form, pattern);
        ASSERT_EQ(mask, ellipse_mask_scalar(centre, form, pattern)) << "case " << i;
        partial += mask != 0 && mask != kFullCoverage ? 1 : 0;
    }
    // Not vacuous: most cases cover some samples and miss others.
    EXPECT_GT(partial, 5000);
}

TEST(CoverageMask, BoxMasksHoldEverySampleOfTheirBoxAndFewOthers) {
    // Superset: every sample inside the box, so that a fragment holding the box's samples can
    // skip a triangle's exact mask. Tight: no sample further than two bins from the box, so
    // that the skip happens.
    std::mt19937 random(31);
    std::uniform_real_distribution<float> position(-2.5f, 2.5f);
    std::uniform_real_distribution<float> log_size(-4.0f, 1.5f);
    int partial = 0;
    for (int i = 0; i < 20000; ++i) {
        const SamplePattern pattern =
            i % 2 == 0 ? SamplePattern::Gaussian : SamplePattern::LightDisc;
        const CoverageSamples& s = coverage_samples(pattern);
        const float extent = pattern == SamplePattern::Gaussian ? 1.98f : 1.42f;
        const float slack = 2.0f * 2.0f * extent / kBoxBins;
        const float x0 = position(random);
        const float y0 = position(random);
        const float x1 = x0 + std::exp(log_size(random));
        const float y1 = y0 + std::exp(log_size(random));
        const CoverageMask box = box_mask(x0, x1, y0, y1, pattern);
        for (int k = 0; k < kCoverageSamples; ++k) {
            const auto u = static_cast<std::size_t>(k);
            const bool inside = s.x[u] >= x0 && s.x[u] <= x1 && s.y[u] >= y0 && s.y[u] <= y1;
            const bool near = s.x[u] >= x0 - slack && s.x[u] <= x1 + slack &&
                              s.y[u] >= y0 - slack && s.y[u] <= y1 + slack;
            const bool held = ((box >> k) & 1u) != 0;
            ASSERT_TRUE(!inside || held) << "case " << i << ", sample " << k;
            ASSERT_TRUE(near || !held) << "case " << i << ", sample " << k;
        }
        partial += box != 0 && box != kFullCoverage ? 1 : 0;
    }
    EXPECT_GT(partial, 5000);
    // A box on a sample's exact coordinates holds it.
    const CoverageSamples& s = coverage_samples();
    for (std::size_t k = 0; k < kCoverageSamples; ++k) {
        EXPECT_NE(box_mask(s.x[k], s.x[k], s.y[k], s.y[k]) & (CoverageMask{1} << k), 0u) << k;
    }
}

TEST(CoverageMask, DamagedInputCoversNothing) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    EXPECT_EQ(triangle_mask(Vec2f(nan, 0.0f), Vec2f(1.0f, 0.0f), Vec2f(0.0f, 1.0f)), 0u);
    EXPECT_EQ(triangle_mask(Vec2f(-inf, 0.0f), Vec2f(1.0f, 0.0f), Vec2f(0.0f, 1.0f)), 0u);
    EXPECT_EQ(triangle_mask(Vec2f(0.0f, 0.0f), Vec2f(1.0f, 1.0f), Vec2f(2.0f, 2.0f)), 0u);
    EXPECT_EQ(edge_mask(Vec2f(0.5f, 0.5f), Vec2f(0.5f, 0.5f)), 0u);
    EXPECT_EQ(ellipse_mask(Vec2f(nan, 0.0f), Mat2f::Identity()), 0u);
}

TEST(SampleRange, SplitsPartitionTheSamplesInProportion) {
    EXPECT_EQ(SampleRange{}.mask(), kFullCoverage);
    std::mt19937 random(7);
    std::uniform_real_distribution<float> fraction(0.0f, 1.0f);
    for (int trial = 0; trial < 200; ++trial) {
        // A blend inside a blend (an instance below a finer level) splits its part again.
        const auto [outer_coarse, outer_finer] = SampleRange{}.split(fraction(random));
        const float c = fraction(random);
        const auto [coarse, finer] = outer_finer.split(c);
        EXPECT_EQ(outer_coarse.mask() & outer_finer.mask(), 0u);
        EXPECT_EQ(outer_coarse.mask() | outer_finer.mask(), kFullCoverage);
        EXPECT_EQ(coarse.mask() & finer.mask(), 0u);
        EXPECT_EQ(coarse.mask() | finer.mask(), outer_finer.mask());
        const int n = outer_finer.last - outer_finer.first;
        EXPECT_EQ(std::popcount(outer_finer.mask()), n);
        EXPECT_LE(
            std::abs(static_cast<float>(std::popcount(coarse.mask())) - c * static_cast<float>(n)),
            0.5f);
    }
    EXPECT_EQ(SampleRange{}.split(0.0f).first.mask(), 0u);
    EXPECT_EQ(SampleRange{}.split(1.0f).second.mask(), 0u);
    EXPECT_EQ(SampleRange{}.split(std::numeric_limits<float>::quiet_NaN()).first.mask(), 0u);
    EXPECT_EQ(SampleRange{}.split(-3.0f).second, SampleRange{});
}

TEST(SampleRange, TheCoarseLevelTakesTheInnerSamples) {
    // The samples run outwards by mass: a leading run lies inside the circle of its mass.
    const CoverageSamples& s = coverage_samples();
    for (const float c : {0.25f, 0.5f, 0.75f}) {
        const CoverageMask inner = SampleRange{}.split(c).first.mask();
        const float kept = 1.0f - kPointWeightClip;
        const float radius = std::sqrt(-std::log1p(-kept * c));
        for (std::size_t i = 0; i < kCoverageSamples; ++i) {
            const bool inside = std::hypot(s.x[i], s.y[i]) < radius;
            EXPECT_EQ(((inner >> i) & 1u) != 0u, inside) << "c " << c << ", sample " << i;
        }
    }
}

TEST(CoverageMask, ClosingFillsSurroundedHolesAndNotEdges) {
    // Single missing samples inside a covered region are holes.
    for (std::size_t i = 0; i < kCoverageSamples; i += 7) {
        EXPECT_EQ(close_holes(kFullCoverage & ~(CoverageMask{1} << i)), kFullCoverage) << i;
    }
    EXPECT_EQ(close_holes(0), 0u);
    EXPECT_EQ(close_holes(kFullCoverage), kFullCoverage);
    // A half-plane's edge is not a hole: closing adds less than a sample on average over
    // directions and offsets (measured 0.41), and never more than three.
    const CoverageSamples& s = coverage_samples();
    double added = 0.0;
    int lines = 0;
    for (int a = 0; a < 36; ++a) {
        const float angle = static_cast<float>(a) * std::numbers::pi_v<float> / 18.0f;
        const Vec2f direction(std::cos(angle), std::sin(angle));
        for (float offset = -1.5f; offset <= 1.5f; offset += 0.25f) {
            const Vec2f from = offset * Vec2f(-direction.y(), direction.x());
            const CoverageMask half = edge_mask(from, from + direction);
            const CoverageMask closed = close_holes(half);
            EXPECT_EQ(closed & half, half);
            const int extra = std::popcount(closed & ~half);
            EXPECT_LE(extra, 3) << "angle " << angle << ", offset " << offset;
            added += extra;
            ++lines;
            // What closing adds lies next to the edge: nearer to it than its own neighbours
            // are to it, five of which lie on the covered side.
            for (std::size_t i = 0; i < kCoverageSamples; ++i) {
                if (((closed & ~half) >> i) & 1u) {
                    const Vec2f y(s.x[i], s.y[i]);
                    const Vec2f to_line = y - from;
                    const float across = to_line.x() * direction.y() - to_line.y() * direction.x();
                    std::vector<float> distances;
                    for (std::size_t j = 0; j < kCoverageSamples; ++j) {
                        if (j != i) {
                            distances.push_back(std::hypot(s.x[j] - y.x(), s.y[j] - y.y()));
                        }
                    }
                    std::nth_element(distances.begin(), distances.begin() + kSampleNeighbours - 1,
                                     distances.end());
                    EXPECT_LE(std::abs(across), distances[kSampleNeighbours - 1]);
                }
            }
        }
    }
    EXPECT_LT(added / lines, 1.0);
    RecordProperty("mean_samples_added_at_an_edge", std::to_string(added / lines));
}

}  // namespace
}  // namespace mrt
