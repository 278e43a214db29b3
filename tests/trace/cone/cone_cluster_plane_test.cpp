// The cluster test a cone leaving a surface uses (trace/cone/cone_cluster_plane.h): whenever it
// says a cluster's members all have their tangent planes within the tolerance of the apex, each
// member does (recomputed in double), for flat, curved and noisy clusters and apexes on, near and
// off the surface; and it does say so for a flat cluster the apex lies in, where the traversal
// needs it to.

#include "trace/cone/cone_cluster_plane.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

namespace mrt {
namespace {

struct Member {
    Vec3f position;
    Vec3f normal;
};

/// 16 points on a patch of a sphere of radius `curvature_radius` (flat for infinity) around
/// `centre` facing `up`, `size` across, each moved along its normal by up to `noise`.
std::vector<Member> patch(std::mt19937_64& rng, const Vec3f& centre, const Vec3f& up, float size,
                          float curvature_radius, float noise) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    Vec3f a;
    Vec3f b;
    a = up.unitOrthogonal();
    b = up.cross(a);
    std::vector<Member> members;
    for (int k = 0; k < 16; ++k) {
        const float x = 0.5f * size * unit(rng);
        const float y = 0.5f * size * unit(rng);
        Member m;
        if (std::isinf(curvature_radius)) {
            m.normal = up;
            m.position = centre + x * a + y * b;
        } else {
            const Vec3f sphere_centre = centre - curvature_radius * up;
            const Vec3f direction = (curvature_radius * up + x * a + y * b).normalized();
            m.normal = direction;
            m.position = sphere_centre + curvature_radius * direction;
        }
        m.position += noise * unit(rng) * m.normal;
        members.push_back(m);
    }
    return members;
}

ConeClusterPlane plane_of(const std::vector<Member>& members, const Vec3f& centre) {
    return cluster_plane(centre, 0, static_cast<std::uint32_t>(members.size()),
                         [&](std::uint32_t j) {
                             return std::pair{members[j].position, members[j].normal};
                         });
}

float radius_of(const std::vector<Member>& members, const Vec3f& centre) {
    float r = 0.0f;
    for (const Member& m : members) {
        r = std::max(r, (m.position - centre).norm());
    }
    return r;
}

/// A patch `size` across, at a random scale from 0.01 to 100, within ten scales of the origin,
/// facing a random way, with its plane about its members' mean and its bounding radius.
/// `shape(size)` gives the patch's curvature radius and noise (patch()).
struct RandomCluster {
    float scale = 0.0f;
    float size = 0.0f;
    Vec3f up;
    std::vector<Member> members;
    Vec3f centre;
    ConeClusterPlane plane;
    float radius = 0.0f;
};

template <class Shape>
RandomCluster random_cluster(std::mt19937_64& rng, Shape&& shape) {
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    RandomCluster c;
    c.scale = std::pow(10.0f, 2.0f * unit(rng));
    const Vec3f centre = c.scale * 10.0f * Vec3f(unit(rng), unit(rng), unit(rng));
    c.up = Vec3f(unit(rng), unit(rng), unit(rng)).normalized();
    c.size = c.scale * (0.1f + positive(rng));
    const auto [curvature, noise] = shape(c.size);
    c.members = patch(rng, centre, c.up, c.size, curvature, noise);
    c.centre = Vec3f::Zero();
    for (const Member& m : c.members) {
        c.centre += m.position / 16.0f;
    }
    c.plane = plane_of(c.members, c.centre);
    c.radius = radius_of(c.members, c.centre);
    return c;
}

TEST(ConeClusterPlane, SaysLeavesOnlyWhereEveryMemberLeaves) {
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    int said = 0;
    int not_said = 0;
    for (int n = 0; n < 20000; ++n) {
        const int kind = n % 3;
        const auto [scale, size, up, members, box_centre, plane,
                    radius] = random_cluster(rng, [&](float across) {
            const float curvature = kind == 0 ? INFINITY : across * (2.0f + 100.0f * positive(rng));
            return std::pair{curvature, kind == 2 ? across * 1e-3f * positive(rng) : 0.0f};
        });
        // The apex on the surface near the patch, or a little off it, or far.
        const float tolerance = size * 0.01f * positive(rng);
        const Vec3f along = up.unitOrthogonal() * size * 3.0f * unit(rng);
        const float off = tolerance * 3.0f * unit(rng) * (n % 5 == 0 ? 100.0f : 1.0f);
        const Vec3f apex = members[0].position + along + off * members[0].normal;
        if (!cluster_leaves(plane, box_centre, radius, apex, tolerance)) {
            ++not_said;
            continue;
        }
        ++said;
        for (const Member& m : members) {
            const double distance =
                std::abs(m.normal.cast<double>().dot((m.position - apex).cast<double>()));
            EXPECT_LE(distance, static_cast<double>(tolerance) * (1.0 + 1e-5) + 1e-7 * scale)
                << "case " << n << " kind " << kind;
        }
    }
    EXPECT_GT(said, 1000);
    EXPECT_GT(not_said, 2000);
}

TEST(ConeClusterPlane, AFlatClusterIsLeftByAConeStartingInIt) {
    std::mt19937_64 rng(3);
    const Vec3f up = Vec3f(0.2f, 1.0f, -0.3f).normalized();
    const std::vector<Member> members =
        patch(rng, Vec3f(5.0f, 1.0f, -2.0f), up, 1.0f, INFINITY, 0.0f);
    Vec3f centre = Vec3f::Zero();
    for (const Member& m : members) {
        centre += m.position / 16.0f;
    }
    const ConeClusterPlane plane = plane_of(members, centre);
    EXPECT_LT(plane.spread, 1e-6f);
    EXPECT_LT(plane.thickness, 1e-5f);
    const float radius = radius_of(members, centre);
    EXPECT_TRUE(cluster_leaves(plane, centre, radius, members[3].position, 1e-3f));
    // Off the plane by more than the tolerance: not left.
    EXPECT_FALSE(cluster_leaves(plane, centre, radius, members[3].position + 2e-3f * up, 1e-3f));
}

/// The second clause (a curved surface's members around the apex): whenever it says so, every
/// member's tangent plane passes within `start` of the apex and the member lies within `near`
/// of it, recomputed in double; a tolerance of zero leaves the first clause out.
TEST(ConeClusterPlane, SaysAroundTheApexOnlyWhereEveryMemberIs) {
    std::mt19937_64 rng(29);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    int said = 0;
    int not_said = 0;
    for (int n = 0; n < 20000; ++n) {
        const auto [scale, size, up, members, box_centre, plane, radius] =
            random_cluster(rng, [&](float across) {
                return std::pair{across * (1.0f + 100.0f * positive(rng)), 0.0f};
            });
        const float start = size * 0.5f * positive(rng);
        const float near = size * 3.0f * positive(rng);
        const Vec3f along = up.unitOrthogonal() * size * unit(rng);
        const Vec3f apex = members[0].position + along + start * unit(rng) * members[0].normal;
        if (!cluster_leaves(plane, box_centre, radius, apex, 0.0f, start, near)) {
            ++not_said;
            continue;
        }
        ++said;
        for (const Member& m : members) {
            const Vec3d apart = (m.position - apex).cast<double>();
            EXPECT_LE(std::abs(m.normal.cast<double>().dot(apart)),
                      static_cast<double>(start) * (1.0 + 1e-5) + 1e-7 * scale)
                << "case " << n;
            EXPECT_LE(apart.norm(), static_cast<double>(near) * (1.0 + 1e-5) + 1e-7 * scale)
                << "case " << n;
        }
    }
    EXPECT_GT(said, 500);
    EXPECT_GT(not_said, 2000);
}

TEST(ConeClusterPlane, ACurvedClusterAroundTheApexIsLeft) {
    std::mt19937_64 rng(4);
    const Vec3f up = Vec3f(0.2f, 1.0f, -0.3f).normalized();
    // A cap of a sphere of radius 20 across 1: not flat to a tolerance of 1e-3 (its sag is
    // about 6e-3), but within a start of 0.1 of an apex on it.
    const std::vector<Member> members = patch(rng, Vec3f(5.0f, 1.0f, -2.0f), up, 1.0f, 20.0f, 0.0f);
    Vec3f centre = Vec3f::Zero();
    for (const Member& m : members) {
        centre += m.position / 16.0f;
    }
    const ConeClusterPlane plane = plane_of(members, centre);
    const float radius = radius_of(members, centre);
    const Vec3f apex = members[3].position;
    EXPECT_FALSE(cluster_leaves(plane, centre, radius, apex, 1e-3f));
    EXPECT_TRUE(cluster_leaves(plane, centre, radius, apex, 1e-3f, 0.1f, 2.0f));
    // Every member near enough, but not all of it within reach of the apex: not left.
    EXPECT_FALSE(cluster_leaves(plane, centre, radius, apex, 1e-3f, 0.1f, 0.5f * radius));
}

TEST(ConeClusterPlane, NormalsThatCancelHaveNoPlane) {
    const std::vector<Member> members = {{Vec3f::Zero(), Vec3f::UnitY()},
                                         {Vec3f::UnitX(), -Vec3f::UnitY()}};
    const ConeClusterPlane plane = plane_of(members, Vec3f(0.5f, 0.0f, 0.0f));
    EXPECT_TRUE(std::isinf(plane.spread));
    EXPECT_FALSE(cluster_leaves(plane, Vec3f(0.5f, 0.0f, 0.0f), 0.5f, Vec3f::Zero(), 1.0f));
}

/// The traversal's test of one triangle of the surface a cone leaves (cone_traversal.cpp,
/// triangle(): the first clause, which holds whether or not the cone enters a solid), in float
/// as it forms it.
bool triangle_leaves(const std::array<Vec3f, 3>& p, const Vec3f& apex, float coplanar) {
    const Vec3f edge1 = p[1] - p[0];
    const Vec3f edge2 = p[2] - p[0];
    const Vec3f normal = edge1.cross(edge2);
    const float length = normal.norm();
    const float size = std::sqrt(std::max(edge1.squaredNorm(), edge2.squaredNorm()));
    const float scale = std::sqrt(std::max(size * size, (p[0] - apex).squaredNorm()));
    return length > 0.0f && std::abs((normal / length).dot(apex - p[0])) <= coplanar * scale;
}

TEST(ConeClusterPlane, ATriangleClusterIsLeftOnlyWhereEveryTriangleIs) {
    // Triangles of a plane (a floor's tiles, of mixed sizes: the smallest member bounds the
    // tolerance) or of a gently curved patch, at scales from 1e-2 to 1e2, with apexes at
    // distances from the plane around the tolerance: whenever the cluster says left, each
    // triangle's own test says so, and for flat clusters with the apex well inside the
    // tolerance it does say so.
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_real_distribution<float> positive(0.0f, 1.0f);
    constexpr float kCoplanar = 1e-5f;
    int said_left = 0;
    int flat_and_near = 0;
    int flat_and_near_left = 0;
    for (int i = 0; i < 20000; ++i) {
        const float scale = std::pow(10.0f, 2.0f * unit(rng));
        const Vec3f up = Vec3f(unit(rng), unit(rng), unit(rng)).normalized();
        const Vec3f a = up.unitOrthogonal();
        const Vec3f b = up.cross(a);
        const Vec3f origin = Vec3f(unit(rng), unit(rng), unit(rng)) * 2.0f * scale;
        const bool flat = positive(rng) < 0.6f;
        const float sag = flat ? 0.0f : 1e-6f * scale * positive(rng);
        const auto on_surface = [&](float x, float y) {
            return Vec3f(origin + x * a + y * b + sag * (x * x + y * y) / (scale * scale) * up);
        };
        std::vector<std::array<Vec3f, 3>> triangles;
        float min_size = std::numeric_limits<float>::infinity();
        for (int k = 0; k < 8; ++k) {
            // Mixed sizes: a third of the cluster's width to all of it.
            const float size = scale * (positive(rng) < 0.3f ? 0.3f : 1.0f);
            const float x = scale * unit(rng);
            const float y = scale * unit(rng);
            triangles.push_back(
                {on_surface(x, y), on_surface(x + size, y), on_surface(x, y + size)});
            min_size = std::min(min_size, size);
        }
        Vec3f centre = Vec3f::Zero();
        for (const auto& t : triangles) {
            centre += (t[0] + t[1] + t[2]) / 24.0f;
        }
        float radius = 0.0f;
        for (const auto& t : triangles) {
            for (const Vec3f& v : t) {
                radius = std::max(radius, (v - centre).norm());
            }
        }
        const ConeTriangleClusterPlane cluster =
            triangle_cluster_plane(centre, 0, static_cast<std::uint32_t>(triangles.size()),
                                   [&](std::uint32_t j) { return triangles[j]; });
        // The apex on the surface near the cluster (or inside it), lifted off the plane by a
        // multiple of the smallest member's tolerance.
        const float lift = kCoplanar * min_size * 2.0f * positive(rng);
        const Vec3f apex =
            on_surface(2.0f * scale * unit(rng), 2.0f * scale * unit(rng)) + lift * up;
        const bool left = triangle_cluster_leaves(cluster, centre, radius, apex, kCoplanar);
        if (left) {
            ++said_left;
            for (const auto& t : triangles) {
                ASSERT_TRUE(triangle_leaves(t, apex, kCoplanar))
                    << "case " << i << ": the cluster is left, a triangle is not";
            }
        }
        if (flat && lift < 0.1f * kCoplanar * min_size) {
            ++flat_and_near;
            flat_and_near_left += left ? 1 : 0;
        }
    }
    EXPECT_GT(said_left, 1500);
    EXPECT_GT(flat_and_near_left, flat_and_near * 3 / 4) << flat_and_near;
}

TEST(ConeClusterPlane, ATriangleWithoutANormalKeepsItsCluster) {
    const std::array<std::array<Vec3f, 3>, 2> triangles{
        {{Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitZ()},
         {Vec3f::Zero(), Vec3f::UnitX(), Vec3f(2.0f, 0.0f, 0.0f)}}};
    const ConeTriangleClusterPlane cluster = triangle_cluster_plane(
        Vec3f(0.5f, 0.0f, 0.5f), 0, 2, [&](std::uint32_t j) { return triangles[j]; });
    EXPECT_TRUE(std::isinf(cluster.plane.spread));
    EXPECT_FALSE(triangle_cluster_leaves(cluster, Vec3f(0.5f, 0.0f, 0.5f), 2.0f,
                                         Vec3f(0.2f, 0.0f, 0.2f), 1e-5f));
}

}  // namespace
}  // namespace mrt
