#include "common/mesh/procedural.h"
#include "common/mesh/mesh.h"
#include "common/system/error.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <utility>
#include <vector>

namespace mrt {
namespace {

double triangle_area(const Mesh& m, const std::array<std::uint32_t, 3>& t) {
    const Vec3d a = m.positions[t[0]].cast<double>();
    const Vec3d b = m.positions[t[1]].cast<double>();
    const Vec3d c = m.positions[t[2]].cast<double>();
    return 0.5 * (b - a).cross(c - a).norm();
}

double total_area(const Mesh& m) {
    double sum = 0.0;
    for (const auto& t : m.triangles) {
        sum += triangle_area(m, t);
    }
    return sum;
}

Vec3d face_normal(const Mesh& m, const std::array<std::uint32_t, 3>& t) {
    const Vec3d a = m.positions[t[0]].cast<double>();
    const Vec3d b = m.positions[t[1]].cast<double>();
    const Vec3d c = m.positions[t[2]].cast<double>();
    return (b - a).cross(c - a).normalized();
}

/// Twice the signed area of the triangle in texture space: positive when the uvs turn the same
/// way as the positions seen from the front, i.e. the texture is not mirrored.
double uv_signed_area(const Mesh& m, const std::array<std::uint32_t, 3>& t) {
    const Vec2d a = m.uvs[t[0]].cast<double>();
    const Vec2d b = m.uvs[t[1]].cast<double>();
    const Vec2d c = m.uvs[t[2]].cast<double>();
    return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

void expect_consistent_arrays(const Mesh& m) {
    EXPECT_FALSE(m.name.empty());
    ASSERT_EQ(m.normals.size(), m.positions.size());
    ASSERT_EQ(m.uvs.size(), m.positions.size());
    ASSERT_EQ(m.materials.size(), m.triangles.size());
    for (const auto& t : m.triangles) {
        for (const std::uint32_t v : t) {
            ASSERT_LT(v, m.positions.size());
        }
    }
    for (const Vec2f& uv : m.uvs) {
        EXPECT_GE(uv.minCoeff(), 0.0f);
        EXPECT_LE(uv.maxCoeff(), 1.0f);
    }
}

/// Number of degenerate triangles, judged by the same rules the loader uses.
std::size_t degenerate_count(const Mesh& m) {
    Mesh copy = m;
    return remove_degenerate_triangles(copy);
}

/// Vertex indices after merging vertices with bitwise-equal positions (undoes seams).
std::vector<std::uint32_t> weld_by_position(const Mesh& m) {
    std::map<std::array<std::uint32_t, 3>, std::uint32_t> first;
    std::vector<std::uint32_t> weld(m.positions.size());
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        const Vec3f p = m.positions[v] + Vec3f::Zero();
        const std::array<std::uint32_t, 3> key{std::bit_cast<std::uint32_t>(p.x()),
                                               std::bit_cast<std::uint32_t>(p.y()),
                                               std::bit_cast<std::uint32_t>(p.z())};
        weld[v] = first.try_emplace(key, static_cast<std::uint32_t>(v)).first->second;
    }
    return weld;
}

/// How often each directed edge occurs, on the welded indices.
std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed_edges(
    const Mesh& m, const std::vector<std::uint32_t>& weld) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
    for (const auto& t : m.triangles) {
        for (int i = 0; i < 3; ++i) {
            ++edges[{weld[t[i]], weld[t[(i + 1) % 3]]}];
        }
    }
    return edges;
}

std::string thrown_message(const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

// ------------------------------------------------------------------------------------------
// Sphere.

struct SphereCase {
    float radius;
    int segments;
    int rings;
};

class Sphere : public ::testing::TestWithParam<SphereCase> {};

TEST_P(Sphere, HasExpectedCountsAndConsistentArrays) {
    const auto [radius, segments, rings] = GetParam();
    const Mesh m = make_sphere(radius, segments, rings, 4);
    expect_consistent_arrays(m);
    // One vertex per segment at each pole, rows of segments + 1 (seam) in between.
    const auto s = static_cast<std::size_t>(segments);
    const auto r = static_cast<std::size_t>(rings);
    EXPECT_EQ(m.positions.size(), 2 * s + (r - 1) * (s + 1));
    EXPECT_EQ(m.triangle_count(), 2 * s * (r - 1));
    for (const std::uint32_t material : m.materials) {
        EXPECT_EQ(material, 4u);
    }
}

TEST_P(Sphere, VerticesLieAtRadiusWithNormalsPOverR) {
    const auto [radius, segments, rings] = GetParam();
    const Mesh m = make_sphere(radius, segments, rings, 0);
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        EXPECT_NEAR(m.positions[v].norm(), radius, 2e-6f * radius) << "vertex " << v;
        EXPECT_NEAR(m.normals[v].norm(), 1.0f, 1e-6f) << "vertex " << v;
        EXPECT_LT((m.normals[v] - m.positions[v] / radius).norm(), 1e-6f) << "vertex " << v;
    }
}

TEST_P(Sphere, TrianglesWindCounterClockwiseSeenFromOutside) {
    const auto [radius, segments, rings] = GetParam();
    const Mesh m = make_sphere(radius, segments, rings, 0);
    for (std::size_t t = 0; t < m.triangle_count(); ++t) {
        const Vec3d g = face_normal(m, m.triangles[t]);
        for (const std::uint32_t v : m.triangles[t]) {
            EXPECT_GT(g.dot(m.normals[v].cast<double>()), 0.0) << "triangle " << t;
        }
    }
}

TEST_P(Sphere, HasNoDegenerateTrianglesEvenAtThePoles) {
    const auto [radius, segments, rings] = GetParam();
    EXPECT_EQ(degenerate_count(make_sphere(radius, segments, rings, 0)), 0u);
}

TEST_P(Sphere, IsClosedOnceTheSeamIsWelded) {
    const auto [radius, segments, rings] = GetParam();
    const Mesh m = make_sphere(radius, segments, rings, 0);
    const std::vector<std::uint32_t> weld = weld_by_position(m);
    const auto edges = directed_edges(m, weld);
    // Closed and consistently oriented: every directed edge once, and its reverse once.
    for (const auto& [edge, count] : edges) {
        EXPECT_EQ(count, 1) << edge.first << "->" << edge.second;
        const auto reverse = edges.find({edge.second, edge.first});
        EXPECT_TRUE(reverse != edges.end() && reverse->second == 1)
            << edge.first << "->" << edge.second << " has no twin";
    }
    // Euler characteristic of a sphere: V − E + F = 2 on the welded positions, where the
    // poles are one vertex each.
    std::vector<bool> used(m.positions.size(), false);
    for (const std::uint32_t w : weld) {
        used[w] = true;
    }
    const auto vertices = static_cast<long long>(std::count(used.begin(), used.end(), true));
    const auto edge_count = static_cast<long long>(edges.size() / 2);
    const auto faces = static_cast<long long>(m.triangle_count());
    EXPECT_EQ(vertices - edge_count + faces, 2);
}

TEST_P(Sphere, UvsAreLongitudeAndLatitudeWithoutMirroring) {
    const auto [radius, segments, rings] = GetParam();
    const Mesh m = make_sphere(radius, segments, rings, 0);
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        // Latitude: v = 1 at the north pole (+y), 0 at the south pole.
        const Vec3d n = m.normals[v].cast<double>();
        const double latitude = std::atan2(n.y(), std::hypot(n.x(), n.z()));
        EXPECT_NEAR(m.uvs[v].y(), 0.5 + latitude / std::numbers::pi, 1e-6) << "vertex " << v;
    }
    for (std::size_t t = 0; t < m.triangle_count(); ++t) {
        EXPECT_GT(uv_signed_area(m, m.triangles[t]), 0.0) << "triangle " << t;
    }
}

TEST_P(Sphere, SeamDuplicatesPositionsWithUZeroAndOne) {
    const auto [radius, segments, rings] = GetParam();
    const Mesh m = make_sphere(radius, segments, rings, 0);
    const std::vector<std::uint32_t> weld = weld_by_position(m);
    std::size_t seam_pairs = 0;
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        if (weld[v] != v && m.uvs[v].x() == 1.0f && m.uvs[weld[v]].x() == 0.0f) {
            EXPECT_EQ(m.normals[v], m.normals[weld[v]]);
            ++seam_pairs;
        }
    }
    EXPECT_EQ(seam_pairs, static_cast<std::size_t>(rings - 1));
}

INSTANTIATE_TEST_SUITE_P(Resolutions, Sphere,
                         ::testing::Values(SphereCase{1.0f, 3, 2}, SphereCase{2.5f, 4, 3},
                                           SphereCase{0.5f, 16, 8}, SphereCase{10.0f, 64, 33}));

TEST(SphereArea, ConvergesToFourPiRSquared) {
    const double radius = 1.5;
    const double exact = 4.0 * std::numbers::pi * radius * radius;
    double previous_error = std::numeric_limits<double>::infinity();
    for (const int n : {8, 16, 32, 64, 128, 256}) {
        const double area = total_area(make_sphere(static_cast<float>(radius), 2 * n, n, 0));
        // Inscribed: always a little less than the sphere.
        EXPECT_LT(area, exact);
        const double error = (exact - area) / exact;
        EXPECT_LT(error, previous_error) << n;
        previous_error = error;
    }
    EXPECT_LT(previous_error, 1e-4);
}

TEST(SphereArguments, AreValidatedWithClearMessages) {
    EXPECT_NE(thrown_message([] { make_sphere(1.0f, 2, 8, 0); }).find("segments"),
              std::string::npos);
    EXPECT_NE(thrown_message([] { make_sphere(1.0f, 8, 1, 0); }).find("rings"), std::string::npos);
    for (const float radius : {0.0f, -1.0f, std::numeric_limits<float>::quiet_NaN(),
                               std::numeric_limits<float>::infinity()}) {
        EXPECT_NE(thrown_message([radius] { make_sphere(radius, 8, 4, 0); }).find("radius"),
                  std::string::npos)
            << radius;
    }
    EXPECT_NE(thrown_message([] { make_sphere(1.0f, 1 << 20, 1 << 20, 0); }).find("vertices"),
              std::string::npos);
}

// ------------------------------------------------------------------------------------------
// Quad.

TEST(Quad, FacesUpWithUnitUvsAndFullArea) {
    const Mesh m = make_quad(3.0f, 2.0f, 5);
    expect_consistent_arrays(m);
    EXPECT_EQ(m.positions.size(), 4u);
    EXPECT_EQ(m.triangle_count(), 2u);
    EXPECT_NEAR(total_area(m), 6.0, 1e-6);
    EXPECT_EQ(m.bounds().min(), Vec3f(-1.5f, 0.0f, -1.0f));
    EXPECT_EQ(m.bounds().max(), Vec3f(1.5f, 0.0f, 1.0f));
    for (const auto& t : m.triangles) {
        EXPECT_GT(face_normal(m, t).y(), 0.999999);
        EXPECT_GT(uv_signed_area(m, t), 0.0);
    }
    for (const Vec3f& n : m.normals) {
        EXPECT_EQ(n, Vec3f(0, 1, 0));
    }
    // The uvs span the unit square, one corner each.
    Eigen::AlignedBox2f uv_box;
    for (const Vec2f& uv : m.uvs) {
        uv_box.extend(uv);
    }
    EXPECT_EQ(uv_box.min(), Vec2f(0, 0));
    EXPECT_EQ(uv_box.max(), Vec2f(1, 1));
    EXPECT_EQ(m.materials, (std::vector<std::uint32_t>{5, 5}));
    EXPECT_EQ(degenerate_count(m), 0u);
}

TEST(Quad, RejectsNonPositiveSizes) {
    EXPECT_NE(thrown_message([] { make_quad(0.0f, 1.0f, 0); }).find("size_x"), std::string::npos);
    EXPECT_NE(thrown_message([] { make_quad(1.0f, -2.0f, 0); }).find("size_z"), std::string::npos);
    EXPECT_NE(thrown_message([] {
                  make_quad(std::numeric_limits<float>::quiet_NaN(), 1.0f, 0);
              }).find("size_x"),
              std::string::npos);
}

// ------------------------------------------------------------------------------------------
// Checkerboard.

TEST(Checkerboard, SharesTileCornersAndCoversTheBoard) {
    const int nx = 5;
    const int nz = 3;
    const Mesh m = make_checkerboard(10.0f, 6.0f, nx, nz, 1, 2);
    expect_consistent_arrays(m);
    EXPECT_EQ(m.positions.size(), static_cast<std::size_t>((nx + 1) * (nz + 1)));
    EXPECT_EQ(m.triangle_count(), static_cast<std::size_t>(2 * nx * nz));
    EXPECT_NEAR(total_area(m), 60.0, 1e-4);
    EXPECT_EQ(m.bounds().min(), Vec3f(-5.0f, 0.0f, -3.0f));
    EXPECT_EQ(m.bounds().max(), Vec3f(5.0f, 0.0f, 3.0f));
    EXPECT_EQ(degenerate_count(m), 0u);
    for (const auto& t : m.triangles) {
        EXPECT_GT(face_normal(m, t).y(), 0.999999);
        EXPECT_GT(uv_signed_area(m, t), 0.0);
    }
    for (const Vec3f& n : m.normals) {
        EXPECT_EQ(n, Vec3f(0, 1, 0));
    }
    // Watertight: inner edges are shared by two triangles, the rim (2·(nx + nz) tile edges) by
    // one, and no position appears twice.
    std::vector<std::uint32_t> identity(m.positions.size());
    for (std::size_t v = 0; v < identity.size(); ++v) {
        identity[v] = static_cast<std::uint32_t>(v);
    }
    EXPECT_EQ(weld_by_position(m), identity);
    const auto edges = directed_edges(m, identity);
    std::size_t rim = 0;
    for (const auto& [edge, count] : edges) {
        EXPECT_EQ(count, 1);
        rim += edges.count({edge.second, edge.first}) == 0 ? 1 : 0;
    }
    EXPECT_EQ(rim, static_cast<std::size_t>(2 * (nx + nz)));
}

TEST(Checkerboard, AlternatesMaterialsStartingWithAAtMinimumCorner) {
    const int nx = 4;
    const int nz = 3;
    const float sx = 8.0f;
    const float sz = 3.0f;
    const Mesh m = make_checkerboard(sx, sz, nx, nz, 7, 9);
    std::map<std::pair<int, int>, std::vector<std::uint32_t>> tiles;
    for (std::size_t t = 0; t < m.triangle_count(); ++t) {
        Vec3f centroid = Vec3f::Zero();
        for (const std::uint32_t v : m.triangles[t]) {
            centroid += m.positions[v] / 3.0f;
        }
        const int ix = static_cast<int>(std::floor((centroid.x() + sx / 2) / (sx / nx)));
        const int iz = static_cast<int>(std::floor((centroid.z() + sz / 2) / (sz / nz)));
        tiles[{ix, iz}].push_back(m.materials[t]);
    }
    ASSERT_EQ(tiles.size(), static_cast<std::size_t>(nx * nz));
    for (const auto& [tile, materials] : tiles) {
        ASSERT_EQ(materials.size(), 2u);
        const std::uint32_t expected = (tile.first + tile.second) % 2 == 0 ? 7u : 9u;
        EXPECT_EQ(materials[0], expected) << tile.first << "," << tile.second;
        EXPECT_EQ(materials[1], expected) << tile.first << "," << tile.second;
    }
}

TEST(Checkerboard, UvsSpanTheWholeBoard) {
    const Mesh m = make_checkerboard(2.0f, 4.0f, 2, 4, 0, 1);
    Eigen::AlignedBox2f uv_box;
    for (const Vec2f& uv : m.uvs) {
        uv_box.extend(uv);
    }
    EXPECT_EQ(uv_box.min(), Vec2f(0, 0));
    EXPECT_EQ(uv_box.max(), Vec2f(1, 1));
    // u follows x linearly across the board.
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        EXPECT_NEAR(m.uvs[v].x(), (m.positions[v].x() + 1.0f) / 2.0f, 1e-6f);
        EXPECT_NEAR(m.uvs[v].y(), (2.0f - m.positions[v].z()) / 4.0f, 1e-6f);
    }
}

TEST(Checkerboard, SingleTileIsAQuadOfMaterialA) {
    const Mesh m = make_checkerboard(1.0f, 1.0f, 1, 1, 3, 4);
    EXPECT_EQ(m.positions.size(), 4u);
    EXPECT_EQ(m.materials, (std::vector<std::uint32_t>{3, 3}));
}

TEST(Checkerboard, RejectsBadArguments) {
    EXPECT_NE(thrown_message([] { make_checkerboard(1.0f, 1.0f, 0, 2, 0, 1); }).find("tile"),
              std::string::npos);
    EXPECT_NE(thrown_message([] { make_checkerboard(1.0f, 1.0f, 2, -1, 0, 1); }).find("tile"),
              std::string::npos);
    EXPECT_NE(thrown_message([] { make_checkerboard(-1.0f, 1.0f, 2, 2, 0, 1); }).find("size_x"),
              std::string::npos);
    EXPECT_NE(thrown_message([] { make_checkerboard(1.0f, 0.0f, 2, 2, 0, 1); }).find("size_z"),
              std::string::npos);
    EXPECT_NE(thrown_message([] {
                  make_checkerboard(1.0f, 1.0f, 1 << 16, 1 << 16, 0, 1);
              }).find("vertices"),
              std::string::npos);
}

TEST(Plant, IsDeterministicFiniteAndBranched) {
    const Mesh a = make_plant(7, 2, 6, 0, 1);
    const Mesh b = make_plant(7, 2, 6, 0, 1);
    const Mesh c = make_plant(8, 2, 6, 0, 1);
    ASSERT_EQ(a.positions, b.positions);
    EXPECT_NE(a.positions, c.positions);
    // 1 + 3 + 9 branches of 4 segments × 6 sides × 2 triangles and two caps of 6, each with 6
    // leaves of 8 triangles.
    EXPECT_EQ(a.triangle_count(), 13u * (4 * 6 * 2 + 2 * 6 + 6 * 8));
    ASSERT_EQ(a.materials.size(), a.triangle_count());
    EXPECT_EQ(std::count(a.materials.begin(), a.materials.end(), 1u), 13 * 6 * 8);
    for (std::size_t v = 0; v < a.positions.size(); ++v) {
        EXPECT_TRUE(a.positions[v].allFinite());
        EXPECT_NEAR(a.normals[v].norm(), 1.0f, 1e-5f);
    }
    const auto box = a.bounds();
    EXPECT_GT(box.sizes().y(), 0.3f);
    EXPECT_LT(box.sizes().maxCoeff(), 3.0f);
    EXPECT_NE(thrown_message([] { make_plant(0, 9, 1, 0, 0); }).find("depth"), std::string::npos);
}

}  // namespace
}  // namespace mrt
