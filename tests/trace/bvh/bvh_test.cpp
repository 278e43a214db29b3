// TriangleBvh and SceneBvh against brute force: the BVH must return exactly what a loop over
// every triangle with the same watertight test returns, on a real scan (the Stanford bunny), on
// random soups and on degenerate inputs; a scene of nested instanced groups must match its
// flattened copy.

#include "common/mesh/mesh_io.h"
#include "common/mesh/procedural.h"
#include "common/scene/scene.h"
#include "common/scene_io/data_path.h"
#include "common/system/error.h"
#include "tests/support/test_support.h"
#include "trace/bvh/bvh_build.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/bvh/triangle_bvh.h"
#include "trace/bvh/triangle_intersect.h"

#include <gtest/gtest.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace mrt {
namespace {

// ---------------------------------------------------------------------------------------------
// Reference and inputs

/// Brute force: the watertight test on every triangle of the mesh, nearest hit wins, ties in t
/// to the lowest index (the loop order), which is the rule TriangleBvh documents.
///
/// To keep 100 000 rays × 70 000 triangles affordable, the test's first step (the float edge
/// functions and the rejection of strictly mixed signs, which intersect_triangle() does before
/// anything else) runs over all triangles in a branch-free loop the compiler vectorises, with
/// the very same IEEE operations; the triangles it does not reject go through the complete
/// scalar intersect_triangle(). Every triangle is still tested; the result is the one of calling
/// intersect_triangle() on each.
class BruteForce {
  public:
    explicit BruteForce(const Mesh& mesh) : m_mesh(mesh), m_n(mesh.triangles.size()) {
        for (int vertex = 0; vertex < 3; ++vertex) {
            for (int axis = 0; axis < 3; ++axis) {
                m_coords[vertex][axis].resize(m_n);
                for (std::size_t i = 0; i < m_n; ++i) {
                    m_coords[vertex][axis][i] = mesh.positions[mesh.triangles[i][vertex]][axis];
                }
            }
        }
    }

    /// Nearest hit with t in (0, ray.t_max); occlusion is then exactly "found".
    bool intersect(const Ray& ray, TriangleHit& hit) const {
        const WatertightRay w(ray);
        thread_local std::vector<std::uint8_t> keep;
        keep.resize(m_n);
        edge_prefilter(w, keep.data());
        float t_best = ray.t_max;
        bool found = false;
        for (std::uint32_t i = 0; i < m_n; ++i) {
            if (keep[i] == 0) {
                continue;
            }
            const auto& tri = m_mesh.triangles[i];
            TriangleIntersection is;
            if (intersect_triangle(w, m_mesh.positions[tri[0]], m_mesh.positions[tri[1]],
                                   m_mesh.positions[tri[2]], is) &&
                is.t < t_best) {
                t_best = is.t;
                hit.t = is.t;
                hit.triangle = i;
                hit.b1 = is.b1;
                hit.b2 = is.b2;
                found = true;
            }
        }
        return found;
    }

  private:
    void edge_prefilter(const WatertightRay& w, std::uint8_t* keep) const {
        const float* const ax_ = m_coords[0][w.kx].data();
        const float* const ay_ = m_coords[0][w.ky].data();
        const float* const az_ = m_coords[0][w.kz].data();
        const float* const bx_ = m_coords[1][w.kx].data();
        const float* const by_ = m_coords[1][w.ky].data();
        const float* const bz_ = m_coords[1][w.kz].data();
        const float* const cx_ = m_coords[2][w.kx].data();
        const float* const cy_ = m_coords[2][w.ky].data();
        const float* const cz_ = m_coords[2][w.kz].data();
        const float ox = w.origin[w.kx], oy = w.origin[w.ky], oz = w.origin[w.kz];
        const float sx = w.sx, sy = w.sy;
        // A local count: `keep` is a byte pointer, which may alias the member.
        const std::size_t n = m_n;
        for (std::size_t i = 0; i < n; ++i) {
            const float a_z = az_[i] - oz, b_z = bz_[i] - oz, c_z = cz_[i] - oz;
            const float ax = (ax_[i] - ox) - sx * a_z, ay = (ay_[i] - oy) - sy * a_z;
            const float bx = (bx_[i] - ox) - sx * b_z, by = (by_[i] - oy) - sy * b_z;
            const float cx = (cx_[i] - ox) - sx * c_z, cy = (cy_[i] - oy) - sy * c_z;
            const float u = cx * by - cy * bx;
            const float v = ax * cy - ay * cx;
            const float wf = bx * ay - by * ax;
            const bool negative = (u < 0.0f) | (v < 0.0f) | (wf < 0.0f);
            const bool positive = (u > 0.0f) | (v > 0.0f) | (wf > 0.0f);
            keep[i] = static_cast<std::uint8_t>(!(negative & positive));
        }
    }

    const Mesh& m_mesh;
    std::size_t m_n;
    std::vector<float> m_coords[3][3];  ///< [vertex][axis][triangle]
};

const Mesh& bunny() {
    static const Mesh mesh = [] {
        const auto path = testing::find_data_file("meshes/stanford-bunny.obj");
        if (!path) {
            throw Error("meshes/stanford-bunny.obj not found on the data search path (MRT_DATA)");
        }
        return load_mesh(*path, 0).mesh;
    }();
    return mesh;
}

Eigen::AlignedBox3f bounds_of(const Mesh& mesh) {
    Eigen::AlignedBox3f box;
    box.setEmpty();
    for (const Vec3f& p : mesh.positions) {
        box.extend(p);
    }
    return box;
}

Vec3f random_unit(std::mt19937& rng) {
    std::normal_distribution<float> normal;
    for (;;) {
        const Vec3f v(normal(rng), normal(rng), normal(rng));
        if (v.squaredNorm() > 1e-6f) {
            return v.normalized();
        }
    }
}

Vec3f random_in_box(std::mt19937& rng, const Eigen::AlignedBox3f& box) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const Vec3f f(u(rng), u(rng), u(rng));
    return box.min() + f.cwiseProduct(box.max() - box.min());
}

/// Rays from a sphere around the box aimed at random points inside it (~80 %), and rays from
/// random points inside the box in random directions. Optionally random finite t_max.
std::vector<Ray> make_rays(const Eigen::AlignedBox3f& box, int count, std::uint32_t seed,
                           bool random_t_max) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const Vec3f center = box.center();
    const float radius = std::max(box.diagonal().norm(), 1e-3f);
    std::vector<Ray> rays(count);
    for (Ray& ray : rays) {
        if (u(rng) < 0.8f) {
            ray.origin = center + radius * random_unit(rng);
            ray.direction = random_in_box(rng, box) - ray.origin;
        } else {
            ray.origin = random_in_box(rng, box);
            ray.direction = random_unit(rng);
        }
        if (random_t_max) {
            ray.t_max = u(rng) * 1.5f * radius / ray.direction.norm();
        }
    }
    return rays;
}

Mesh random_soup(int count, std::uint32_t seed, float max_edge) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    Mesh mesh;
    for (int i = 0; i < count; ++i) {
        const Vec3f c(u(rng), u(rng), u(rng));
        for (int k = 0; k < 3; ++k) {
            mesh.positions.push_back(c + max_edge * Vec3f(u(rng), u(rng), u(rng)));
        }
        const auto b = static_cast<std::uint32_t>(3 * i);
        mesh.triangles.push_back({b, b + 1, b + 2});
    }
    mesh.normals.assign(mesh.positions.size(), Vec3f::UnitZ());
    mesh.materials.assign(mesh.triangles.size(), 0);
    return mesh;
}

/// Checks TriangleBvh::intersect and ::occluded against brute force on every ray; returns the
/// number of rays that hit.
int expect_matches_brute_force(const Mesh& mesh, const std::vector<Ray>& rays) {
    const TriangleBvh bvh(mesh);
    const BruteForce brute(mesh);
    std::vector<std::uint8_t> ok(rays.size(), 0);
    std::atomic<int> hits{0};
    tbb::parallel_for(std::size_t{0}, rays.size(), [&](std::size_t i) {
        TriangleHit expected, actual;
        const bool expect_hit = brute.intersect(rays[i], expected);
        const bool got_hit = bvh.intersect(rays[i], actual);
        bool same = expect_hit == got_hit && bvh.occluded(rays[i]) == expect_hit;
        if (same && expect_hit) {
            same = expected.t == actual.t && expected.triangle == actual.triangle &&
                   expected.b1 == actual.b1 && expected.b2 == actual.b2;
            hits += 1;
        }
        ok[i] = same ? 1 : 0;
    });
    int failures = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        if (ok[i] == 0 && ++failures <= 5) {
            TriangleHit expected, actual;
            const bool e = brute.intersect(rays[i], expected);
            const bool a = bvh.intersect(rays[i], actual);
            ADD_FAILURE() << "ray " << i << " " << rays[i] << ": brute force " << e
                          << " t=" << expected.t << " tri=" << expected.triangle << ", BVH " << a
                          << " t=" << actual.t << " tri=" << actual.triangle << ", occluded "
                          << bvh.occluded(rays[i]);
        }
    }
    EXPECT_EQ(failures, 0) << "of " << rays.size() << " rays";
    return hits.load();
}

/// Occlusion alone against brute force (segments with random t_max): any hit before t_max is
/// exactly a nearest hit before t_max.
int expect_occlusion_matches_brute_force(const Mesh& mesh, const std::vector<Ray>& rays) {
    const TriangleBvh bvh(mesh);
    const BruteForce brute(mesh);
    std::atomic<int> failures{0}, occluded{0};
    tbb::parallel_for(std::size_t{0}, rays.size(), [&](std::size_t i) {
        TriangleHit unused;
        const bool expected = brute.intersect(rays[i], unused);
        if (expected != bvh.occluded(rays[i])) {
            failures += 1;
        }
        occluded += expected ? 1 : 0;
    });
    EXPECT_EQ(failures.load(), 0) << "of " << rays.size() << " rays";
    return occluded.load();
}

// ---------------------------------------------------------------------------------------------
// Structure

/// Walks the 4-wide tree: depth-first (a node's first inner child follows it), child boxes inside
/// their parent's lane box, every node reached once, depth within the traversal stack, leaves of
/// at most 8 triangles whose packet runs tile the packet array, every triangle in one leaf.
void expect_well_formed(const TriangleBvh& bvh, std::size_t triangle_count) {
    const auto& nodes = bvh.nodes();
    if (triangle_count == 0) {
        EXPECT_TRUE(nodes.empty());
        EXPECT_TRUE(bvh.bounds().isEmpty());
        return;
    }
    ASSERT_FALSE(nodes.empty());
    std::vector<int> seen(nodes.size(), 0);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> packet_runs;
    std::size_t leaf_triangles = 0;
    struct Item {
        std::uint32_t node;
        int depth;
        Eigen::AlignedBox3f box;
    };
    std::vector<Item> stack{{0, 0, bvh.bounds()}};
    while (!stack.empty()) {
        const Item item = stack.back();
        stack.pop_back();
        ASSERT_LT(item.node, nodes.size());
        ASSERT_LT(item.depth, kBvhMaxDepth);
        seen[item.node] += 1;
        const BvhNode& n = nodes[item.node];
        bool first_inner = true;
        int used = 0;
        for (int lane = 0; lane < 4; ++lane) {
            const Vec3f lo(n.bounds[0][lane], n.bounds[2][lane], n.bounds[4][lane]);
            const Vec3f hi(n.bounds[1][lane], n.bounds[3][lane], n.bounds[5][lane]);
            if (lo.x() > hi.x()) {
                EXPECT_EQ(n.count[lane], 0u);
                continue;
            }
            ++used;
            EXPECT_TRUE(item.box.contains(Eigen::AlignedBox3f(lo, hi)));
            if (n.count[lane] != 0) {
                EXPECT_LE(n.count[lane], 8u);
                leaf_triangles += n.count[lane];
                packet_runs.emplace_back(n.child[lane], (n.count[lane] + 3u) / 4u);
                continue;
            }
            if (first_inner) {
                EXPECT_EQ(n.child[lane], item.node + 1) << "first inner child follows its parent";
                first_inner = false;
            }
            ASSERT_GT(n.child[lane], item.node);
            stack.push_back({n.child[lane], item.depth + 1, Eigen::AlignedBox3f(lo, hi)});
        }
        EXPECT_GE(used, triangle_count <= 8 ? 1 : 2);
    }
    EXPECT_EQ(leaf_triangles, triangle_count);
    EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }))
        << "every node reached exactly once";
    std::sort(packet_runs.begin(), packet_runs.end());
    std::uint32_t next = 0;
    for (const auto& [first, count] : packet_runs) {
        EXPECT_EQ(first, next) << "packet runs are disjoint and contiguous";
        next = first + count;
    }
}

TEST(TriangleBvh, TreeIsWellFormedDepthFirst) {
    static_assert(sizeof(BvhNode) == 128 && alignof(BvhNode) == 64);
    const Mesh soup = random_soup(5000, 7, 0.05f);
    const TriangleBvh bvh(soup);
    expect_well_formed(bvh, soup.triangles.size());
    const Eigen::AlignedBox3f box = bounds_of(soup);
    EXPECT_TRUE(bvh.bounds().isApprox(box));
    EXPECT_GT(bvh.bytes(), bvh.nodes().size() * sizeof(BvhNode));
}

TEST(TriangleBvh, BuildIsIdenticalForAnyThreadCount) {
    const Mesh& mesh = bunny();
    std::vector<BvhNode> serial;
    {
        const tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        serial = TriangleBvh(mesh).nodes();
    }
    for (int threads : {2, 3, 8}) {
        const tbb::global_control many(tbb::global_control::max_allowed_parallelism, threads);
        const std::vector<BvhNode> parallel = TriangleBvh(mesh).nodes();
        ASSERT_EQ(parallel.size(), serial.size()) << threads << " threads";
        EXPECT_EQ(std::memcmp(parallel.data(), serial.data(), serial.size() * sizeof(BvhNode)), 0)
            << threads << " threads";
    }
}

TEST(TriangleBvh, BunnyTreeIsWellFormed) {
    const Mesh& mesh = bunny();
    const TriangleBvh bvh(mesh);
    expect_well_formed(bvh, mesh.triangles.size());
    EXPECT_TRUE(bvh.bounds().isApprox(bounds_of(mesh)));
}

// ---------------------------------------------------------------------------------------------
// Same answers as brute force

TEST(TriangleBvh, BunnyNearestHitAndOcclusionEqualBruteForceOn100000Rays) {
    const Mesh& mesh = bunny();
    const std::vector<Ray> rays = make_rays(bounds_of(mesh), 100000, 1, false);
    const int hits = expect_matches_brute_force(mesh, rays);
    // The test is only meaningful if a good share of rays hit something.
    EXPECT_GT(hits, 30000);
}

TEST(TriangleBvh, BunnyOcclusionWithRandomTMaxEqualsBruteForce) {
    const Mesh& mesh = bunny();
    const std::vector<Ray> rays = make_rays(bounds_of(mesh), 100000, 2, true);
    const int occluded = expect_occlusion_matches_brute_force(mesh, rays);
    EXPECT_GT(occluded, 10000);
    EXPECT_LT(occluded, 90000);
}

TEST(TriangleBvh, RandomSoupsEqualBruteForce) {
    for (std::uint32_t seed = 0; seed < 4; ++seed) {
        const Mesh soup = random_soup(3000, seed, seed % 2 == 0 ? 0.05f : 0.6f);
        expect_matches_brute_force(soup, make_rays(bounds_of(soup), 20000, 100 + seed, false));
        expect_matches_brute_force(soup, make_rays(bounds_of(soup), 5000, 200 + seed, true));
    }
}

TEST(TriangleBvh, CoplanarTrianglesEqualBruteForceIncludingAxisAlignedAndInPlaneRays) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    Mesh plane;
    for (std::uint32_t i = 0; i < 2000; ++i) {
        const Vec3f c(u(rng), 0.5f, u(rng));
        for (int k = 0; k < 3; ++k) {
            plane.positions.push_back(c + 0.1f * Vec3f(u(rng), 0.0f, u(rng)));
        }
        plane.triangles.push_back({3 * i, 3 * i + 1, 3 * i + 2});
    }
    std::vector<Ray> rays = make_rays(bounds_of(plane), 10000, 4, false);
    for (int i = 0; i < 5000; ++i) {
        // Straight down (two zero direction components), from above and from inside the
        // plane's zero-thickness box.
        rays.push_back(Ray{Vec3f(u(rng), i % 2 == 0 ? 2.0f : 0.5f, u(rng)), Vec3f(0, -1, 0)});
        // In the plane: the slab test sees an infinite reciprocal and an origin on the plane.
        rays.push_back(Ray{Vec3f(u(rng), 0.5f, u(rng)), Vec3f(u(rng), 0.0f, u(rng))});
        rays.push_back(Ray{Vec3f(u(rng), 0.5f, u(rng)), Vec3f(1.0f, -0.0f, 0.0f)});
    }
    const int hits = expect_matches_brute_force(plane, rays);
    EXPECT_GT(hits, 2000);
}

TEST(TriangleBvh, IdenticalTrianglesResolveTiesToTheLowestIndex) {
    Mesh mesh = random_soup(200, 5, 0.3f);
    // 1000 copies of one triangle (away from the soup) inserted among the soup's triangles:
    // centroids all equal, so the builder must fall back from SAH, and every hit on them is a
    // tie in t.
    const auto base = static_cast<std::uint32_t>(mesh.positions.size());
    mesh.positions.push_back(Vec3f(4.5f, -0.5f, 10.0f));
    mesh.positions.push_back(Vec3f(5.5f, -0.5f, 10.0f));
    mesh.positions.push_back(Vec3f(5.0f, 0.5f, 10.0f));
    for (int i = 0; i < 1000; ++i) {
        mesh.triangles.insert(mesh.triangles.begin() + 100 + i % 3,
                              {base, base + 1 + static_cast<std::uint32_t>(i % 2),
                               base + 2 - static_cast<std::uint32_t>(i % 2)});
    }
    const TriangleBvh bvh(mesh);
    expect_well_formed(bvh, mesh.triangles.size());
    expect_matches_brute_force(mesh, make_rays(bounds_of(mesh), 20000, 6, false));
    TriangleHit hit;
    ASSERT_TRUE(bvh.intersect(Ray{Vec3f(5.0f, 0.0f, 15.0f), Vec3f(0.0f, 0.0f, -1.0f)}, hit));
    EXPECT_FLOAT_EQ(hit.t, 5.0f);
    EXPECT_EQ(hit.triangle, 100u) << "the first copy";
}

TEST(TriangleBvh, SingleTriangle) {
    Mesh mesh;
    mesh.positions = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)};
    mesh.triangles = {{0, 1, 2}};
    const TriangleBvh bvh(mesh);
    ASSERT_EQ(bvh.nodes().size(), 1u);
    expect_well_formed(bvh, 1);
    TriangleHit hit;
    ASSERT_TRUE(bvh.intersect(Ray{Vec3f(0.25f, 0.5f, 2.0f), Vec3f(0, 0, -1)}, hit));
    EXPECT_FLOAT_EQ(hit.t, 2.0f);
    EXPECT_EQ(hit.triangle, 0u);
    EXPECT_FLOAT_EQ(hit.b1, 0.25f);
    EXPECT_FLOAT_EQ(hit.b2, 0.5f);
    // The interval is open at both ends.
    EXPECT_FALSE(bvh.occluded(Ray{Vec3f(0.25f, 0.5f, 2.0f), Vec3f(0, 0, -1), 2.0f}));
    EXPECT_TRUE(bvh.occluded(Ray{Vec3f(0.25f, 0.5f, 2.0f), Vec3f(0, 0, -1), 2.0001f}));
    EXPECT_FALSE(bvh.occluded(Ray{Vec3f(0.25f, 0.5f, 0.0f), Vec3f(0, 0, -1)}));
    // An earlier hit closer than the triangle is kept.
    TriangleHit closer;
    closer.t = 1.0f;
    EXPECT_FALSE(bvh.intersect(Ray{Vec3f(0.25f, 0.5f, 2.0f), Vec3f(0, 0, -1)}, closer));
    EXPECT_EQ(closer.t, 1.0f);
    expect_matches_brute_force(mesh, make_rays(bounds_of(mesh), 5000, 8, false));
}

TEST(TriangleBvh, EmptyMeshNeverHits) {
    const TriangleBvh bvh{Mesh{}};
    EXPECT_TRUE(bvh.nodes().empty());
    EXPECT_TRUE(bvh.bounds().isEmpty());
    TriangleHit hit;
    EXPECT_FALSE(bvh.intersect(Ray{}, hit));
    EXPECT_FALSE(hit.t < kInfinity);
    EXPECT_FALSE(bvh.occluded(Ray{}));
    const TriangleBvh defaulted;
    EXPECT_FALSE(defaulted.intersect(Ray{}, hit));
}

TEST(TriangleBvh, InvalidRaysHitNothingAndTerminate) {
    const Mesh soup = random_soup(500, 9, 0.2f);
    const TriangleBvh bvh(soup);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const Ray rays[] = {
        {Vec3f(nan, 0, 0), Vec3f(0, 0, 1)},        {Vec3f(0, 0, -5), Vec3f(nan, nan, nan)},
        {Vec3f(kInfinity, 0, 0), Vec3f(-1, 0, 0)}, {Vec3f(0, 0, -5), Vec3f(0, kInfinity, 1)},
        {Vec3f(0, 0, -5), Vec3f(0, 0, 0)},         {Vec3f(0, 0, -5), Vec3f(0, 0, 1), nan},
        {Vec3f(0, 0, -5), Vec3f(0, 0, 1), 0.0f},   {Vec3f(0, 0, -5), Vec3f(0, 0, 1), -1.0f},
    };
    for (const Ray& ray : rays) {
        TriangleHit hit;
        EXPECT_FALSE(bvh.intersect(ray, hit)) << ray;
        EXPECT_FALSE(bvh.occluded(ray)) << ray;
    }
}

TEST(TriangleBvh, ZeroDirectionComponentsNeverMissTheBox) {
    // Axis-aligned rays whose origins lie exactly on the boxes' face planes (0·inf in the slab
    // test): a unit grid of triangles in z = 0, rays straight down through its vertex columns.
    Mesh grid = make_checkerboard(8.0f, 8.0f, 8, 8, 0, 1);
    for (Vec3f& p : grid.positions) {
        p = Vec3f(p.x(), p.z(), 0.0f);  // XZ board → XY plane
    }
    const TriangleBvh bvh(grid);
    int misses = 0;
    for (int ix = 0; ix <= 16; ++ix) {
        for (int iy = 0; iy <= 16; ++iy) {
            const Vec3f origin(-4.0f + 0.5f * float(ix), -4.0f + 0.5f * float(iy), 3.0f);
            TriangleHit hit;
            if (!bvh.intersect(Ray{origin, Vec3f(0.0f, 0.0f, -1.0f)}, hit) ||
                std::abs(hit.t - 3.0f) > 1e-5f) {
                ++misses;
            }
            // Negative zero components take the same path.
            if (!bvh.occluded(Ray{origin, Vec3f(-0.0f, -0.0f, -2.0f)})) {
                ++misses;
            }
        }
    }
    EXPECT_EQ(misses, 0);
}

// ---------------------------------------------------------------------------------------------
// SceneBvh

/// World hit point both ways: along the ray, and the object-space point from the barycentrics
/// mapped by object_to_world.
Vec3f object_point(const Scene& scene, const SceneHit& hit) {
    const Mesh& mesh = scene.meshes[hit.mesh];
    const auto& tri = mesh.triangles[hit.triangle];
    return (1.0f - hit.b1 - hit.b2) * mesh.positions[tri[0]] + hit.b1 * mesh.positions[tri[1]] +
           hit.b2 * mesh.positions[tri[2]];
}

float min_barycentric(const SceneHit& hit) {
    return std::min({1.0f - hit.b1 - hit.b2, hit.b1, hit.b2});
}

Affine3f make_transform(const Vec3f& translation, float angle, const Vec3f& axis,
                        const Vec3f& scale) {
    Affine3f xf = Affine3f::Identity();
    xf.translate(translation);
    xf.rotate(Eigen::AngleAxisf(angle, axis.normalized()));
    xf.scale(scale);
    return xf;
}

/// Root: ground checkerboard (identity) + group 1 three times; group 1: a sphere twice and a
/// small soup once; group 2 (one more level, inside group 1): the soup mirrored.
Scene make_nested_scene() {
    Scene scene;
    scene.materials.resize(2);
    scene.meshes.push_back(make_sphere(0.5f, 24, 12, 0));
    scene.meshes.push_back(random_soup(300, 11, 0.1f));
    scene.meshes.push_back(make_checkerboard(20.0f, 20.0f, 10, 10, 0, 1));
    scene.groups.resize(3);
    scene.groups[0].name = "world";
    scene.groups[1].name = "cluster";
    scene.groups[2].name = "mirrored soup";
    scene.groups[2].children.push_back(
        {Instance::Kind::Mesh, 1,
         make_transform(Vec3f(0, 0.2f, 0), 0.3f, Vec3f(1, 1, 0), Vec3f(-1.0f, 0.7f, 1.3f))});
    scene.groups[1].children.push_back({Instance::Kind::Mesh, 0, Affine3f::Identity()});
    scene.groups[1].children.push_back(
        {Instance::Kind::Mesh, 0,
         make_transform(Vec3f(1.5f, 0.3f, -0.4f), 0.7f, Vec3f(0, 1, 0), Vec3f(0.5f, 1.5f, 0.8f))});
    scene.groups[1].children.push_back(
        {Instance::Kind::Mesh, 1,
         make_transform(Vec3f(-1.2f, 0.0f, 0.8f), 0.0f, Vec3f(0, 0, 1), Vec3f(2.0f, 2.0f, 2.0f))});
    scene.groups[1].children.push_back(
        {Instance::Kind::Group, 2,
         make_transform(Vec3f(0.2f, 1.2f, 1.4f), 1.0f, Vec3f(0, 0, 1), Vec3f(1, 1, 1))});
    scene.groups[0].children.push_back(
        {Instance::Kind::Mesh, 2,
         make_transform(Vec3f(0, -1.0f, 0), 0.0f, Vec3f(0, 1, 0), Vec3f(1, 1, 1))});
    scene.groups[0].children.push_back(
        {Instance::Kind::Group, 1,
         make_transform(Vec3f(-3.0f, 0.5f, 0.0f), 0.4f, Vec3f(0, 1, 0), Vec3f(1, 1, 1))});
    scene.groups[0].children.push_back(
        {Instance::Kind::Group, 1,
         make_transform(Vec3f(2.5f, 0.0f, 1.0f), -1.1f, Vec3f(1, 0, 1), Vec3f(0.8f, 0.8f, 0.8f))});
    scene.groups[0].children.push_back(
        {Instance::Kind::Group, 1,
         make_transform(Vec3f(0.0f, 1.0f, -3.0f), 2.0f, Vec3f(0, 1, 1), Vec3f(1.3f, 0.6f, 1.3f))});
    scene.root = 0;
    return scene;
}

Scene single_mesh_scene(Mesh mesh) {
    Scene scene;
    scene.meshes.push_back(std::move(mesh));
    scene.groups.resize(1);
    scene.groups[0].children.push_back({Instance::Kind::Mesh, 0, Affine3f::Identity()});
    return scene;
}

TEST(SceneBvh, InstancedSceneMatchesItsFlattenedCopyOn20000Rays) {
    const Scene scene = make_nested_scene();
    const Scene flat = single_mesh_scene(flatten(scene));
    const SceneBvh instanced(scene);
    const SceneBvh flattened(flat);

    // Boxes of transformed boxes are conservative: they contain the flattened geometry.
    const Eigen::AlignedBox3f box = instanced.bounds();
    const Eigen::AlignedBox3f exact = bounds_of(flat.meshes[0]);
    EXPECT_TRUE(box.contains(exact.min() + 1e-4f * Vec3f::Ones()) &&
                box.contains(exact.max() - 1e-4f * Vec3f::Ones()))
        << box.min().transpose() << " / " << box.max().transpose();
    EXPECT_TRUE(flattened.bounds().isApprox(exact));
    EXPECT_EQ(instanced.stats().unique_triangles, scene.unique_triangle_count());
    EXPECT_GT(instanced.stats().group_nodes, 0u);
    EXPECT_GT(instanced.stats().mesh_nodes, 0u);
    EXPECT_GT(instanced.stats().bytes, 0u);
    EXPECT_GE(instanced.stats().build_seconds, 0.0);

    // Focus the rays on the instances, not the large ground board.
    Eigen::AlignedBox3f focus(Vec3f(-5.0f, -1.5f, -5.0f), Vec3f(5.0f, 3.0f, 5.0f));
    const std::vector<Ray> rays = make_rays(focus, 20000, 21, false);
    const float scale = box.diagonal().norm();
    int hits = 0, edge_cases = 0, failures = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const Ray& ray = rays[i];
        SceneHit a, b;
        const bool hit_a = instanced.intersect(ray, a);
        const bool hit_b = flattened.intersect(ray, b);
        // Transforming the ray instead of the vertices rounds differently: a ray grazing an edge
        // may hit one copy and miss the other. Those are few and must lie on an edge.
        const bool near_edge =
            (hit_a && min_barycentric(a) < 1e-3f) || (hit_b && min_barycentric(b) < 1e-3f);
        bool ok = hit_a == hit_b;
        if (ok && hit_a) {
            ++hits;
            const Vec3f pa = ray.origin + a.t * ray.direction;
            const Vec3f pb = ray.origin + b.t * ray.direction;
            ok = std::abs(a.t - b.t) <= 1e-4f * std::max(a.t, b.t) &&
                 (pa - pb).norm() <= 1e-4f * scale;
            // The instance transform maps the object-space hit point to the world one.
            const Vec3f mapped = a.object_to_world * object_point(scene, a);
            EXPECT_LE((mapped - pa).norm(), 1e-4f * scale) << "ray " << i;
            EXPECT_EQ(a.valid(), true);
        }
        // occluded() agrees with intersect() for a segment ending just past the hit.
        Ray segment = ray;
        segment.t_max = hit_a ? a.t * 1.001f : kInfinity;
        EXPECT_EQ(instanced.occluded(segment), hit_a) << "ray " << i;
        if (hit_a) {
            segment.t_max = a.t * 0.999f;
            EXPECT_FALSE(instanced.occluded(segment)) << "ray " << i;
        }
        if (!ok) {
            if (near_edge) {
                ++edge_cases;
            } else if (++failures <= 5) {
                ADD_FAILURE() << "ray " << i << " " << ray << ": instanced " << hit_a
                              << " t=" << a.t << ", flattened " << hit_b << " t=" << b.t;
            }
        }
    }
    EXPECT_EQ(failures, 0);
    EXPECT_LE(edge_cases, 20) << "of " << rays.size();
    EXPECT_GT(hits, 4000);
}

TEST(SceneBvh, EmptyScenesNeverHit) {
    Scene none;
    const SceneBvh empty(none);
    SceneHit hit;
    EXPECT_FALSE(empty.intersect(Ray{}, hit));
    EXPECT_FALSE(empty.occluded(Ray{}));
    EXPECT_TRUE(empty.bounds().isEmpty());
    EXPECT_EQ(empty.stats().unique_triangles, 0u);

    // A root group with an empty mesh, an empty group, and a group of nothing.
    Scene hollow = single_mesh_scene(Mesh{});
    hollow.groups.resize(2);
    hollow.groups[0].children.push_back({Instance::Kind::Group, 1, Affine3f::Identity()});
    const SceneBvh bvh(hollow);
    EXPECT_FALSE(bvh.intersect(Ray{Vec3f(0, 0, -5), Vec3f(0, 0, 1)}, hit));
    EXPECT_FALSE(bvh.occluded(Ray{Vec3f(0, 0, -5), Vec3f(0, 0, 1)}));
    EXPECT_TRUE(bvh.bounds().isEmpty());
}

TEST(SceneBvh, BunnyThroughTheSceneEqualsTriangleBvh) {
    const Mesh& mesh = bunny();
    const Scene scene = single_mesh_scene(mesh);
    const SceneBvh scene_bvh(scene);
    const TriangleBvh bvh(mesh);
    const std::vector<Ray> rays = make_rays(bounds_of(mesh), 20000, 31, false);
    int mismatches = 0;
    for (const Ray& ray : rays) {
        SceneHit a;
        TriangleHit b;
        const bool hit_a = scene_bvh.intersect(ray, a);
        const bool hit_b = bvh.intersect(ray, b);
        if (hit_a != hit_b ||
            (hit_a && (a.t != b.t || a.triangle != b.triangle || a.b1 != b.b1 || a.b2 != b.b2 ||
                       a.mesh != 0 || !a.object_to_world.matrix().isIdentity(0.0f)))) {
            ++mismatches;
        }
    }
    EXPECT_EQ(mismatches, 0);
}

TEST(SceneBvh, RejectsCyclesAndBadIndices) {
    Scene cycle = single_mesh_scene(random_soup(4, 1, 0.1f));
    cycle.groups.resize(2);
    cycle.groups[0].children.push_back({Instance::Kind::Group, 1, Affine3f::Identity()});
    cycle.groups[1].children.push_back({Instance::Kind::Group, 0, Affine3f::Identity()});
    EXPECT_THROW(SceneBvh{cycle}, Error);

    Scene bad_mesh = single_mesh_scene(random_soup(4, 1, 0.1f));
    bad_mesh.groups[0].children.push_back({Instance::Kind::Mesh, 7, Affine3f::Identity()});
    EXPECT_THROW(SceneBvh{bad_mesh}, Error);

    // One level more than any tool accepts (the loader refuses it first; this guards hand-built
    // scenes).
    Scene deep = single_mesh_scene(random_soup(4, 1, 0.1f));
    constexpr auto kLevels = static_cast<std::uint32_t>(kMaxSupportedGroupNesting + 1);
    deep.groups.resize(kLevels);
    for (std::uint32_t g = 0; g + 1 < kLevels; ++g) {
        deep.groups[g].children.push_back({Instance::Kind::Group, g + 1, Affine3f::Identity()});
    }
    EXPECT_THROW(SceneBvh{deep}, Error);
}

TEST(SceneBvh, DeeplyNestedTransformsAccumulate) {
    // Ten levels of translate-by-one: the sphere ends up at x = 10.
    Scene scene;
    scene.meshes.push_back(make_sphere(0.25f, 16, 8, 0));
    scene.groups.resize(11);
    for (std::uint32_t g = 0; g < 10; ++g) {
        Affine3f xf = Affine3f::Identity();
        xf.translate(Vec3f(1.0f, 0.0f, 0.0f));
        scene.groups[g].children.push_back({Instance::Kind::Group, g + 1, xf});
    }
    scene.groups[10].children.push_back({Instance::Kind::Mesh, 0, Affine3f::Identity()});
    const SceneBvh bvh(scene);
    SceneHit hit;
    ASSERT_TRUE(bvh.intersect(Ray{Vec3f(10.0f, 0.0f, 5.0f), Vec3f(0.0f, 0.0f, -2.0f)}, hit));
    EXPECT_NEAR(hit.t, (5.0f - 0.25f) / 2.0f, 0.01f);  // a polygonal sphere
    EXPECT_TRUE(hit.object_to_world.translation().isApprox(Vec3f(10.0f, 0.0f, 0.0f)));
    EXPECT_FALSE(bvh.occluded(Ray{Vec3f(0.0f, 0.0f, 5.0f), Vec3f(0.0f, 0.0f, -1.0f)}));
}

}  // namespace
}  // namespace mrt
