// Watertightness: rays aimed exactly at the shared vertices and edges of closed meshes must never
// slip between the triangles that share them (Woop, Benthin & Wald 2013). Rays come from outside,
// from many directions inside the cone where every face at the target is seen from the front,
// so the ray must enter the solid right at the target.

#include "common/mesh/procedural.h"
#include "common/scene/scene.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/bvh/triangle_bvh.h"
#include "trace/bvh/triangle_intersect.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <random>
#include <utility>
#include <vector>

namespace mrt {
namespace {

using Key = std::array<float, 3>;

Key key_of(const Vec3f& p) {
    return {p.x(), p.y(), p.z()};
}

/// A point on the surface to aim at, and the unit normals of the faces that share it.
struct Target {
    Vec3f point;
    std::vector<Vec3f> face_normals;
};

/// Shared vertices, and points along shared edges at several parameters, of a closed mesh.
/// Vertices and edges are identified by position, so duplicated seam and pole vertices of a UV
/// sphere count as the one point they are.
std::vector<Target> shared_targets(const Mesh& mesh) {
    std::map<Key, std::vector<Vec3f>> vertex_faces;
    std::map<std::pair<Key, Key>, std::vector<Vec3f>> edge_faces;
    for (const auto& tri : mesh.triangles) {
        const Vec3f p[3] = {mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]};
        const Vec3f n = (p[1] - p[0]).cross(p[2] - p[0]).normalized();
        for (int k = 0; k < 3; ++k) {
            vertex_faces[key_of(p[k])].push_back(n);
            Key a = key_of(p[k]), b = key_of(p[(k + 1) % 3]);
            if (b < a) {
                std::swap(a, b);
            }
            edge_faces[{a, b}].push_back(n);
        }
    }
    std::vector<Target> targets;
    for (const auto& [key, normals] : vertex_faces) {
        targets.push_back({Vec3f(key[0], key[1], key[2]), normals});
    }
    for (const auto& [edge, normals] : edge_faces) {
        EXPECT_EQ(normals.size(), 2u) << "closed mesh: every edge has two faces";
        const Vec3f a(edge.first[0], edge.first[1], edge.first[2]);
        const Vec3f b(edge.second[0], edge.second[1], edge.second[2]);
        for (const float s : {0.5f, 0.1f, 0.25f, 1.0f / 3.0f, 0.75f, 0.9f}) {
            targets.push_back({a + s * (b - a), normals});
        }
    }
    return targets;
}

/// Random unit directions from which every face at the target is seen well in front
/// (cos > 0.2), i.e. rays that enter the convex solid at the target.
std::vector<Vec3f> outside_directions(const Target& target, int count, std::mt19937& rng) {
    std::normal_distribution<float> normal;
    std::vector<Vec3f> directions;
    for (int attempts = 0; static_cast<int>(directions.size()) < count && attempts < 100000;
         ++attempts) {
        const Vec3f d = Vec3f(normal(rng), normal(rng), normal(rng)).normalized();
        bool in_front = true;
        for (const Vec3f& n : target.face_normals) {
            in_front = in_front && n.dot(d) > 0.2f;
        }
        if (in_front) {
            directions.push_back(d);
        }
    }
    EXPECT_EQ(static_cast<int>(directions.size()), count);
    return directions;
}

struct Tally {
    long rays = 0;
    long misses = 0;
    long far_hits = 0;  ///< Hit, but not at the target.
};

/// Shoots `per_target` rays at every target from distance `distance`; counts misses of
/// intersect() and of occluded().
template <typename Intersect, typename Occluded>
Tally shoot(const std::vector<Target>& targets, int per_target, float distance, std::uint32_t seed,
            const Intersect& intersect, const Occluded& occluded) {
    std::mt19937 rng(seed);
    Tally tally;
    for (const Target& target : targets) {
        for (const Vec3f& d : outside_directions(target, per_target, rng)) {
            const Vec3f origin = target.point + distance * d;
            const Ray ray{origin, target.point - origin, kInfinity};
            ++tally.rays;
            float t = 0.0f;
            if (!intersect(ray, t) || !occluded(ray)) {
                if (++tally.misses <= 5) {
                    ADD_FAILURE() << "missed: ray " << ray << " aimed at "
                                  << target.point.transpose();
                }
                continue;
            }
            // The ray enters at the target (t = 1 up to rounding).
            if (std::abs(t - 1.0f) > 1e-4f) {
                ++tally.far_hits;
            }
        }
    }
    return tally;
}

Tally shoot_bvh(const Mesh& mesh, int per_target, float distance, std::uint32_t seed) {
    const TriangleBvh bvh(mesh);
    return shoot(
        shared_targets(mesh), per_target, distance, seed,
        [&](const Ray& ray, float& t) {
            TriangleHit hit;
            const bool found = bvh.intersect(ray, hit);
            t = hit.t;
            return found;
        },
        [&](const Ray& ray) { return bvh.occluded(ray); });
}

Mesh cube() {
    Mesh mesh;
    for (int i = 0; i < 8; ++i) {
        mesh.positions.emplace_back((i & 1) != 0 ? 1.0f : -1.0f, (i & 2) != 0 ? 1.0f : -1.0f,
                                    (i & 4) != 0 ? 1.0f : -1.0f);
    }
    // Two counter-clockwise (seen from outside) triangles per face.
    const std::uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                       {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
        mesh.triangles.push_back({q[0], q[1], q[2]});
        mesh.triangles.push_back({q[0], q[2], q[3]});
    }
    mesh.normals.assign(mesh.positions.size(), Vec3f::UnitZ());
    return mesh;
}

Mesh icosahedron() {
    const float g = (1.0f + std::sqrt(5.0f)) / 2.0f;
    Mesh mesh;
    mesh.positions = {{-1, g, 0},  {1, g, 0},  {-1, -g, 0}, {1, -g, 0}, {0, -1, g},  {0, 1, g},
                      {0, -1, -g}, {0, 1, -g}, {g, 0, -1},  {g, 0, 1},  {-g, 0, -1}, {-g, 0, 1}};
    mesh.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                      {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                      {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                      {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    mesh.normals.assign(mesh.positions.size(), Vec3f::UnitZ());
    return mesh;
}

TEST(Watertight, SphereSharedEdgesAndVerticesNeverMissed) {
    const Mesh sphere = make_sphere(1.0f, 48, 24, 0);
    const Tally tally = shoot_bvh(sphere, 6, 3.0f, 1);
    EXPECT_EQ(tally.misses, 0) << "of " << tally.rays;
    EXPECT_EQ(tally.far_hits, 0);
    EXPECT_GE(tally.rays, 100000);
}

TEST(Watertight, CubeAndIcosahedronSharedEdgesAndVerticesNeverMissed) {
    for (const Mesh& mesh : {cube(), icosahedron()}) {
        const Tally tally = shoot_bvh(mesh, 400, 5.0f, 2);
        EXPECT_EQ(tally.misses, 0) << "of " << tally.rays;
        EXPECT_EQ(tally.far_hits, 0);
        EXPECT_GE(tally.rays, 10000);
    }
}

TEST(Watertight, SphereFarAwayAndSmallStillWatertight) {
    // Large coordinates relative to the triangle size: the sheared edge functions of shared
    // edges still cancel exactly.
    Mesh sphere = make_sphere(0.01f, 24, 12, 0);
    for (Vec3f& p : sphere.positions) {
        p += Vec3f(1000.0f, -250.0f, 40.0f);
    }
    const Tally tally = shoot_bvh(sphere, 20, 0.5f, 3);
    EXPECT_EQ(tally.misses, 0) << "of " << tally.rays;
}

TEST(Watertight, CheckerboardTileCornersAndEdgesNeverMissed) {
    const Mesh board = make_checkerboard(8.0f, 8.0f, 16, 16, 0, 1);
    const TriangleBvh bvh(board);
    // Corners lie on multiples of 0.5 and edge midpoints on multiples of 0.25; with these
    // direction components every ray passes exactly (no rounding) through its target at t = 1.
    long rays = 0, misses = 0;
    for (int ix = 0; ix <= 32; ++ix) {
        for (int iz = 0; iz <= 32; ++iz) {
            const Vec3f target(-4.0f + 0.25f * float(ix), 0.0f, -4.0f + 0.25f * float(iz));
            for (int dx = -2; dx <= 2; ++dx) {
                for (int dz = -2; dz <= 2; ++dz) {
                    const Vec3f d(0.5f * float(dx), -2.0f, 0.5f * float(dz));
                    const Ray ray{target - d, d, kInfinity};
                    TriangleHit hit;
                    ++rays;
                    if (!bvh.intersect(ray, hit) || hit.t != 1.0f || !bvh.occluded(ray)) {
                        if (++misses <= 5) {
                            ADD_FAILURE() << "ray " << ray << " t=" << hit.t;
                        }
                    }
                }
            }
        }
    }
    EXPECT_EQ(misses, 0) << "of " << rays;
}

TEST(Watertight, TransformedInstanceOfASphereNeverMissed) {
    // Through SceneBvh: the ray is transformed into the instance once, so all the triangles at a
    // shared edge still see the same ray.
    Scene scene;
    scene.meshes.push_back(make_sphere(1.0f, 32, 16, 0));
    scene.groups.resize(1);
    Affine3f xf = Affine3f::Identity();
    xf.translate(Vec3f(0.3f, -2.0f, 5.0f));
    xf.rotate(Eigen::AngleAxisf(0.7f, Vec3f(1.0f, 2.0f, 3.0f).normalized()));
    xf.scale(Vec3f(2.0f, 0.5f, 1.0f));
    scene.groups[0].children.push_back({Instance::Kind::Mesh, 0, xf});
    const SceneBvh bvh(scene);

    std::vector<Target> targets = shared_targets(scene.meshes[0]);
    const Mat3f normal_matrix = xf.linear().inverse().transpose();
    for (Target& target : targets) {
        target.point = xf * target.point;
        for (Vec3f& n : target.face_normals) {
            n = (normal_matrix * n).normalized();
        }
    }
    const Tally tally = shoot(
        targets, 4, 4.0f, 4,
        [&](const Ray& ray, float& t) {
            SceneHit hit;
            const bool found = bvh.intersect(ray, hit);
            t = hit.t;
            return found;
        },
        [&](const Ray& ray) { return bvh.occluded(ray); });
    EXPECT_EQ(tally.misses, 0) << "of " << tally.rays;
    EXPECT_GE(tally.rays, 20000);
}

TEST(Watertight, PointsOfASharedEdgeAreClaimedByAtLeastOneOfItsTriangles) {
    // The core property behind watertightness, on a single shared edge: for rays through points
    // of the edge, at least one of its two triangles reports a hit.
    const Vec3f a(0.0f, 0.0f, 0.0f), b(1.0f, 0.3f, 0.1f);
    const Vec3f c(0.2f, 1.0f, -0.2f), d(0.7f, -0.9f, 0.3f);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    int misses = 0;
    for (int i = 0; i < 20000; ++i) {
        const Vec3f target = a + u(rng) * (b - a);
        const Vec3f origin(u(rng) * 4.0f - 2.0f, u(rng) * 4.0f - 2.0f, 3.0f + u(rng));
        const WatertightRay w(Ray{origin, target - origin, kInfinity});
        TriangleIntersection hit;
        const bool first = intersect_triangle(w, a, b, c, hit);
        const bool second = intersect_triangle(w, b, a, d, hit);
        misses += (first || second) ? 0 : 1;
    }
    EXPECT_EQ(misses, 0);
}

}  // namespace
}  // namespace mrt
