// Cone–triangle weights (§4.5): the Gaussian mass over a triangle against dense quadrature in
// double and against closed forms (½ on an edge, ¼ in a right-angled corner, area × height for
// tiny triangles); the paper's exp(−(d − ½)²); the map into the Gaussian's coordinates is the
// same under rotation and scale of the footprint and stays finite for nearly collinear ones.

#include "trace/cone/cone_triangle.h"

#include "common/footprint/point_weight.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace mrt {
namespace {

/// ∫_T exp(−|y|²)/π dy by the midpoint rule on the triangle split 4^levels times, in double.
double reference_mass(const Vec2f& a, const Vec2f& b, const Vec2f& c, int levels = 6) {
    const Eigen::Vector2d p0 = a.cast<double>(), p1 = b.cast<double>(), p2 = c.cast<double>();
    const int n = 1 << levels;
    const double area =
        0.5 * std::abs((p1 - p0).x() * (p2 - p0).y() - (p1 - p0).y() * (p2 - p0).x());
    double sum = 0.0;
    // Sub-triangles of the n×n split: centroids at barycentric ((i + 1/3)/n, (j + 1/3)/n) and
    // ((i + 2/3)/n, (j + 2/3)/n).
    for (int i = 0; i < n; ++i) {
        for (int j = 0; i + j < n; ++j) {
            for (const double offset : {1.0 / 3.0, 2.0 / 3.0}) {
                if (offset > 0.5 && i + j == n - 1) {
                    continue;  // the upside-down triangles stop one row earlier
                }
                const double u = (i + offset) / n, v = (j + offset) / n;
                const Eigen::Vector2d y = (1.0 - u - v) * p0 + u * p1 + v * p2;
                sum += std::exp(-y.squaredNorm());
            }
        }
    }
    return sum * area / (static_cast<double>(n) * n) / kPi;
}

TEST(GaussianTriangleMass, MatchesDenseQuadratureOnRandomTriangles) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    double worst = 0.0;
    for (int n = 0; n < 400; ++n) {
        const float size = std::pow(10.0f, unit(rng));  // 0.1 to 10 Gaussian units
        const Vec2f centre(2.0f * unit(rng), 2.0f * unit(rng));
        const Vec2f a = centre + size * Vec2f(unit(rng), unit(rng));
        const Vec2f b = centre + size * Vec2f(unit(rng), unit(rng));
        const Vec2f c = centre + size * Vec2f(unit(rng), unit(rng));
        const double levels = size > 3.0f ? 8 : 6;
        const double reference = reference_mass(a, b, c, static_cast<int>(levels));
        worst = std::max(worst, std::abs(gaussian_triangle_mass(a, b, c) - reference));
        // Orientation does not matter.
        EXPECT_NEAR(gaussian_triangle_mass(a, c, b), gaussian_triangle_mass(a, b, c), 1e-6);
    }
    EXPECT_LT(worst, 1e-4);  // the reference's own error is some 5e-5
}

TEST(GaussianTriangleMass, TrianglesOfASplitAddUpToTheWhole) {
    // The mass is a signed sum over edges, and the two triangles of a shared edge see it with
    // the same endpoints: a triangle split into 4^6 pieces, down to a thousandth of the
    // Gaussian, weighs what it weighs whole, to rounding — a surface's triangles add up to its
    // coverage however fine it is tessellated.
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<float> unit(-1.5f, 1.5f);
    for (int n = 0; n < 20; ++n) {
        const Vec2f a(unit(rng), unit(rng)), b(unit(rng), unit(rng)), c(unit(rng), unit(rng));
        const int pieces = 8;
        double sum = 0.0;
        const auto at = [&](int i, int j) {
            return Vec2f(a + (b - a) * (static_cast<float>(i) / pieces) +
                         (c - a) * (static_cast<float>(j) / pieces));
        };
        for (int i = 0; i < pieces; ++i) {
            for (int j = 0; i + j < pieces; ++j) {
                sum += gaussian_triangle_mass(at(i, j), at(i + 1, j), at(i, j + 1));
                if (i + j + 1 < pieces) {
                    sum += gaussian_triangle_mass(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                }
            }
        }
        EXPECT_NEAR(sum, gaussian_triangle_mass(a, b, c), 1e-6) << n;
    }
}

TEST(GaussianTriangleMass, ClosedFormsOnEdgesCornersAndTinyTriangles) {
    const float big = 1e3f;
    // The origin deep inside, on a straight edge, in a right-angled corner, far outside.
    EXPECT_NEAR(gaussian_triangle_mass({-big, -big}, {big, -big}, {0, big}), 1.0f, 1e-5f);
    EXPECT_NEAR(gaussian_triangle_mass({-big, 0}, {big, 0}, {0, big}), 0.5f, 1e-5f);
    EXPECT_NEAR(gaussian_triangle_mass({0, 0}, {big, 0}, {0, big}), 0.25f, 1e-5f);
    EXPECT_NEAR(gaussian_triangle_mass({5, 5}, {6, 5}, {5, 6}), 0.0f, 1e-9f);
    // A straight edge at distance d: ½·erfc(d) outside, 1 − ½·erfc(d) inside.
    for (const float d : {0.1f, 0.5f, 1.0f, 2.0f}) {
        EXPECT_NEAR(gaussian_triangle_mass({-big, d}, {big, d}, {0, big}), 0.5f * std::erfc(d),
                    1e-5f)
            << d;
        EXPECT_NEAR(gaussian_triangle_mass({-big, -d}, {big, -d}, {0, big}),
                    1.0f - 0.5f * std::erfc(d), 1e-5f)
            << d;
    }
    // A triangle a twentieth of the Gaussian across: its area times the density at its
    // centroid (the tabulated edge masses are within 1e-5 absolute, so far smaller triangles
    // have no relative accuracy, only their sum with their neighbours, below).
    const Vec2f c(0.7f, -0.4f);
    const float s = 0.05f;
    const float area = 0.5f * s * s;
    const Vec2f centroid = c + Vec2f(s, s) / 3.0f;
    EXPECT_NEAR(gaussian_triangle_mass(c, c + Vec2f(s, 0), c + Vec2f(0, s)) /
                    (area * std::exp(-centroid.squaredNorm()) / kPi),
                1.0f, 1e-2f);
    // Degenerate and damaged input.
    EXPECT_EQ(gaussian_triangle_mass({0, 0}, {1, 1}, {2, 2}), 0.0f);
    EXPECT_EQ(gaussian_triangle_mass({std::nanf(""), 0}, {1, 1}, {2, 0}), 0.0f);
}

std::array<VertexInRayFrame, 3> triangle_at(float t, const Vec2f& a, const Vec2f& b,
                                            const Vec2f& c) {
    return {VertexInRayFrame{t, a}, VertexInRayFrame{t, b}, VertexInRayFrame{t, c}};
}

/// Distance from the origin to the 2D triangle (a, b, c): 0 inside, else to the nearest edge.
float closest_distance(const Vec2f& a, const Vec2f& b, const Vec2f& c) {
    const auto side = [](const Vec2f& p, const Vec2f& q) { return p.x() * q.y() - p.y() * q.x(); };
    const float s0 = side(b - a, -a);
    const float s1 = side(c - b, -b);
    const float s2 = side(a - c, -c);
    if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) {
        return 0.0f;
    }
    const auto segment = [](const Vec2f& p, const Vec2f& q) {
        const Vec2f e = q - p;
        const float u = std::clamp(-p.dot(e) / std::max(e.squaredNorm(), 1e-30f), 0.0f, 1.0f);
        return (p + u * e).norm();
    };
    return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

TEST(ConeTriangle, CoverageIsHalfOnAnEdgeWhereThePapersWeightIsStillOne) {
    const GaussianFrame frame = GaussianFrame::of(0.1f * Mat2f::Identity());
    const std::array<GaussianFrame, 3> frames{frame, frame, frame};
    // An edge along v through the cone's axis: in Gaussian units the triangle spans ±100.
    const auto edge = triangle_at(5.0f, {0, -10}, {10, 0}, {0, 10});
    const auto coverage = intersect_cone_triangle(edge, frames, TriangleWeight::Coverage, 0.0f);
    const auto paper = intersect_cone_triangle(edge, frames, TriangleWeight::Paper, 0.0f);
    ASSERT_TRUE(coverage && paper);
    // Half the Gaussian's mass, over the 98 % inside the clip circle.
    EXPECT_NEAR(coverage->weight, 0.5f / (1.0f - kPointWeightClip), 1e-4f);
    EXPECT_EQ(paper->weight, 1.0f);
    EXPECT_FLOAT_EQ(coverage->t, 5.0f);
    // Two Gaussian units (0.2) outside the edge: beyond the clip circle (√ln 50 = 1.98 units),
    // where the Gaussian is below 2 %; the paper's exp(−1.5²) = 0.105 is not.
    const auto outside = triangle_at(5.0f, {0.2f, -10}, {10.2f, 0}, {0.2f, 10});
    EXPECT_FALSE(intersect_cone_triangle(outside, frames, TriangleWeight::Coverage, 0.0f));
    const auto paper_outside =
        intersect_cone_triangle(outside, frames, TriangleWeight::Paper, 0.0f);
    ASSERT_TRUE(paper_outside);
    EXPECT_NEAR(paper_outside->weight, std::exp(-1.5f * 1.5f), 1e-5f);
    // The closest point's barycentrics: on the edge from vertex 2 to vertex 0, half way.
    EXPECT_NEAR(coverage->b1, 0.0f, 1e-6f);
    EXPECT_NEAR(coverage->b2, 0.5f, 1e-6f);
    // Behind t_min: nothing.
    EXPECT_FALSE(intersect_cone_triangle(edge, frames, TriangleWeight::Coverage, 6.0f));
}

TEST(ConeTriangle, SameWeightUnderRotationAndScaleOfTheCone) {
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int n = 0; n < 200; ++n) {
        Mat2f f;
        f << unit(rng), unit(rng), unit(rng), unit(rng);
        f = FootprintCone::clamp_anisotropy(f, 8.0f);
        const std::array<Vec2f, 3> v{Vec2f(unit(rng), unit(rng)), Vec2f(unit(rng), unit(rng)),
                                     Vec2f(unit(rng), unit(rng))};
        const auto weigh = [&](const Mat2f& footprint, const Mat2f& r, float s) {
            const GaussianFrame frame = GaussianFrame::of(footprint);
            const auto hit = intersect_cone_triangle(
                triangle_at(1.0f, s * (r * v[0]), s * (r * v[1]), s * (r * v[2])),
                {frame, frame, frame}, TriangleWeight::Coverage, 0.0f);
            return hit ? hit->weight : 0.0f;
        };
        const float w = weigh(f, Mat2f::Identity(), 1.0f);
        const Mat2f r = Eigen::Rotation2Df(6.28f * unit(rng)).toRotationMatrix();
        const float s = std::pow(10.0f, 3.0f * unit(rng));
        EXPECT_NEAR(weigh(r * f, r, 1.0f), w, 2e-5f);
        EXPECT_NEAR(weigh(s * f, Mat2f::Identity(), s), w, 2e-5f);
        // The map agrees with the plain inverse where that is well conditioned.
        const Vec2f y0 = f.inverse() * v[0];
        const Vec2f y1 = f.inverse() * v[1];
        const Vec2f y2 = f.inverse() * v[2];
        const float direct = gaussian_triangle_mass(y0, y1, y2);
        EXPECT_NEAR(closest_distance(y0, y1, y2) > triangle_clip_radius(TriangleWeight::Coverage)
                        ? 0.0f
                        : direct / (1.0f - kPointWeightClip),
                    w, 2e-4f);
    }
}

TEST(ConeTriangle, NearlyCollinearFootprintsStayFiniteAndPerVertexFramesFollowDepth) {
    // Columns parallel to 1e-7: the clamp makes the ellipse 8:1 and the map stays finite.
    Mat2f f;
    f << 1.0f, 1.0f, 1e-7f, 2e-7f;
    const GaussianFrame clamped = GaussianFrame::of(FootprintCone::clamp_anisotropy(f, 8.0f));
    EXPECT_TRUE(clamped.inverse_semi_axes.allFinite());
    const auto hit =
        intersect_cone_triangle(triangle_at(1.0f, {-5, -5}, {5, -5}, {0, 5}),
                                {clamped, clamped, clamped}, TriangleWeight::Coverage, 0.0f);
    ASSERT_TRUE(hit);
    EXPECT_TRUE(std::isfinite(hit->weight));
    // A zero footprint (the apex) sees nothing.
    const GaussianFrame apex = GaussianFrame::of(Mat2f::Zero());
    EXPECT_FALSE(intersect_cone_triangle(triangle_at(0.0f, {-1, -1}, {1, -1}, {0, 1}),
                                         {apex, apex, apex}, TriangleWeight::Coverage, 0.0f));
    // Per vertex: a triangle whose far vertex sits where the cone is wider weighs more than the
    // same offsets seen with the near footprint throughout.
    FootprintCone cone;
    cone.incr_dev = 0.1f * Mat2f::Identity();
    const std::array<VertexInRayFrame, 3> tilted{VertexInRayFrame{1.0f, {0.15f, -1.0f}},
                                                 VertexInRayFrame{1.0f, {0.15f, 1.0f}},
                                                 VertexInRayFrame{20.0f, {2.0f, 0.0f}}};
    const GaussianFrame near = GaussianFrame::of(cone.at(1.0f));
    const std::array<GaussianFrame, 3> per_vertex{near, near, GaussianFrame::of(cone.at(20.0f))};
    const auto per_node =
        intersect_cone_triangle(tilted, {near, near, near}, TriangleWeight::Coverage, 0.0f);
    const auto exact = intersect_cone_triangle(tilted, per_vertex, TriangleWeight::Coverage, 0.0f);
    ASSERT_TRUE(exact);
    EXPECT_GT(exact->weight, per_node ? per_node->weight : 0.0f);
}

/// The bits of a frame's four floats, so that frames compare bit for bit (NaN included).
std::array<std::uint32_t, 4> bits_of(const GaussianFrame& frame) {
    return {std::bit_cast<std::uint32_t>(frame.axis.x()),
            std::bit_cast<std::uint32_t>(frame.axis.y()),
            std::bit_cast<std::uint32_t>(frame.inverse_semi_axes.x()),
            std::bit_cast<std::uint32_t>(frame.inverse_semi_axes.y())};
}

TEST(GaussianFrame, OfClampedIsTheFrameOfTheClampedFootprintBitForBit) {
    // The reference is the two-step path the tracer took before: clamp, then decompose the
    // clamped footprint again. Random footprints over twelve decades of scale, half of them
    // nearly collinear (clamped), and damaged ones.
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<Mat2f> footprints{Mat2f::Zero(), Mat2f::Identity()};
    Mat2f damaged;
    damaged << std::nanf(""), 0.0f, 0.0f, 1.0f;
    footprints.push_back(damaged);
    damaged << 1.0f, inf, 0.0f, 1.0f;
    footprints.push_back(damaged);
    damaged << 1e30f, 0.0f, 0.0f, 1.0f;  // F·Fᵀ overflows
    footprints.push_back(damaged);
    for (int n = 0; n < 2000; ++n) {
        Mat2f f;
        f << unit(rng), unit(rng), unit(rng), unit(rng);
        if (n % 2 == 1) {
            f.col(1) = f.col(0) * (1.0f + 0.3f * unit(rng)) + 1e-3f * Vec2f(unit(rng), unit(rng));
        }
        footprints.push_back(std::pow(10.0f, 6.0f * unit(rng)) * f);
    }
    int clamped = 0;
    for (const Mat2f& f : footprints) {
        for (const float anisotropy : {1.0f, 8.0f, 1e3f}) {
            const Mat2f c = FootprintCone::clamp_anisotropy(f, anisotropy);
            clamped += c != f ? 1 : 0;
            EXPECT_EQ(bits_of(GaussianFrame::of_clamped(f, anisotropy)),
                      bits_of(GaussianFrame::of(c)))
                << f << "\nanisotropy " << anisotropy;
        }
    }
    // Both of of_clamped's ways were taken, many times.
    EXPECT_GT(clamped, 1000);
    EXPECT_LT(clamped, 5000);
}

TEST(ConeTriangle, MappedVerticesWeighAsTheirFramesDo) {
    // Known answers through the mapped entry: an edge through the axis holds half the mass; a
    // non-finite mapped vertex or a triangle behind t_min is not hit.
    const auto edge = triangle_at(5.0f, {0, -1}, {1, 0}, {0, 1});
    const std::array<Vec2f, 3> y{Vec2f(0, -100), Vec2f(100, 0), Vec2f(0, 100)};
    const auto hit = intersect_cone_triangle_mapped(edge, y, TriangleWeight::Coverage, 0.0f);
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->weight, 0.5f / (1.0f - kPointWeightClip), 1e-4f);
    EXPECT_FLOAT_EQ(hit->t, 5.0f);
    EXPECT_FALSE(intersect_cone_triangle_mapped(edge, y, TriangleWeight::Coverage, 6.0f));
    std::array<Vec2f, 3> damaged = y;
    damaged[1].x() = std::nanf("");
    EXPECT_FALSE(intersect_cone_triangle_mapped(edge, damaged, TriangleWeight::Coverage, 0.0f));
    // And the same hit as from the frames themselves, on random triangles and footprints.
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    int hits = 0;
    for (int n = 0; n < 500; ++n) {
        std::array<VertexInRayFrame, 3> vertices;
        std::array<GaussianFrame, 3> frames;
        std::array<Vec2f, 3> mapped;
        for (std::size_t i = 0; i < 3; ++i) {
            vertices[i] = {1.0f + unit(rng), Vec2f(unit(rng), unit(rng))};
            Mat2f f;
            f << unit(rng), unit(rng), unit(rng), unit(rng);
            frames[i] = GaussianFrame::of_clamped(f, 8.0f);
            mapped[i] = frames[i].map(vertices[i].offset);
        }
        for (const TriangleWeight weight : {TriangleWeight::Coverage, TriangleWeight::Paper}) {
            const auto a = intersect_cone_triangle(vertices, frames, weight, 0.5f);
            const auto b = intersect_cone_triangle_mapped(vertices, mapped, weight, 0.5f);
            ASSERT_EQ(a.has_value(), b.has_value()) << n;
            if (a) {
                ++hits;
                EXPECT_EQ(a->t, b->t);
                EXPECT_EQ(a->weight, b->weight);
                EXPECT_EQ(a->b1, b->b1);
                EXPECT_EQ(a->b2, b->b2);
            }
        }
    }
    EXPECT_GT(hits, 100);
}

TEST(TriangleInRayFrame, LanesAreFrameOfAndMapBitForBit) {
    // The references: ConeRay::frame_of and GaussianFrame::map, one vertex at a time. Rays far
    // from the origin and vertices far from the ray, so that the order of the sums shows.
    std::mt19937_64 rng(29);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    const auto bits = [](float x) { return std::bit_cast<std::uint32_t>(x); };
    for (int n = 0; n < 2000; ++n) {
        const float scale = std::pow(10.0f, 4.0f * unit(rng));
        ConeRay ray;
        ray.origin = scale * Vec3f(unit(rng), unit(rng), unit(rng));
        ray.direction = Vec3f(unit(rng), unit(rng), unit(rng)).normalized();
        orthonormal_basis(ray.direction, ray.cone.u, ray.cone.v);
        std::array<Vec3f, 3> p;
        for (Vec3f& q : p) {
            q = ray.origin + scale * Vec3f(unit(rng), unit(rng), unit(rng));
        }
        Mat2f f;
        f << unit(rng), unit(rng), unit(rng), unit(rng);
        const GaussianFrame frame = GaussianFrame::of_clamped(scale * f, 8.0f);
        const TriangleInRayFrame lanes(ray, p);
        const TriangleInRayFrame::Mapped mapped = lanes.map(frame);
        const std::array<VertexInRayFrame, 3> vertices = lanes.vertices();
        const std::array<Vec2f, 3> points = mapped.points();
        for (std::size_t i = 0; i < 3; ++i) {
            const VertexInRayFrame expected = ray.frame_of(p[i]);
            ASSERT_EQ(bits(vertices[i].t), bits(expected.t)) << n << " " << i;
            ASSERT_EQ(bits(vertices[i].offset.x()), bits(expected.offset.x())) << n << " " << i;
            ASSERT_EQ(bits(vertices[i].offset.y()), bits(expected.offset.y())) << n << " " << i;
            const Vec2f y = frame.map(expected.offset);
            ASSERT_EQ(bits(points[i].x()), bits(y.x())) << n << " " << i;
            ASSERT_EQ(bits(points[i].y()), bits(y.y())) << n << " " << i;
        }
    }
}

}  // namespace
}  // namespace mrt
