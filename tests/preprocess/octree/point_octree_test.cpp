// The point hierarchy's build (Wand & Straßer §3): every triangle ends up exactly once as a
// triangle, the points of a node cover the surface they stand for to within a voxel diagonal
// (the coverage guarantee, checked with independent random surface points on a sphere and on
// the Stanford bunny), prefiltered colours are exact on a uniform mesh and the area-weighted
// average on a checkerboard, a flat surface's points report full coverage, and the result is
// the same for any number of threads.

#include "preprocess/octree/point_octree.h"
#include "common/mesh/mesh_io.h"
#include "common/mesh/procedural.h"
#include "common/texture/texture.h"
#include "tests/support/leaf_texture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <unordered_set>

namespace mrt {
namespace {

std::vector<Material> two_materials() {
    Material white;
    white.diffuse = Rgb(1.0f, 1.0f, 1.0f);
    Material dark;
    dark.diffuse = Rgb(0.2f, 0.1f, 0.0f);
    dark.reflectivity = 0.5f;
    return {white, dark};
}

/// Triangles of the subtree below `index` (kept in it or any descendant).
void subtree_triangles(const PointOctree& octree, std::int32_t index,
                       std::vector<std::uint32_t>& out) {
    const OctreeNode& node = octree.nodes[static_cast<std::size_t>(index)];
    out.insert(out.end(), node.triangles.begin(), node.triangles.end());
    for (const std::int32_t c : node.children) {
        if (c >= 0) {
            subtree_triangles(octree, c, out);
        }
    }
}

/// The triangles a node's points stand for: everything in its children's subtrees.
std::vector<std::uint32_t> represented_triangles(const PointOctree& octree, std::size_t index) {
    std::vector<std::uint32_t> out;
    for (const std::int32_t c : octree.nodes[index].children) {
        if (c >= 0) {
            subtree_triangles(octree, c, out);
        }
    }
    return out;
}

/// Random surface points of every represented triangle must lie within the voxel diagonal of
/// one of the node's points; returns how many were checked.
std::size_t expect_coverage(const Mesh& mesh, const PointOctree& octree) {
    const int k = octree.options.grid;
    std::mt19937 rng(12345);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    std::size_t checked = 0;
    for (std::size_t n = 0; n < octree.nodes.size(); ++n) {
        const OctreeNode& node = octree.nodes[n];
        if (node.points.empty()) {
            continue;
        }
        const float voxel = node.side / static_cast<float>(k);
        const float diagonal = std::sqrt(3.0f) * voxel;
        std::unordered_set<std::uint32_t> occupied;
        for (const OctreePoint& p : node.points) {
            occupied.insert((static_cast<std::uint32_t>(p.voxel[2]) * 256 + p.voxel[1]) * 256 +
                            p.voxel[0]);
        }
        int misses = 0;
        for (const std::uint32_t t : represented_triangles(octree, n)) {
            const auto& tri = mesh.triangles[t];
            for (int s = 0; s < 4; ++s) {
                float u = uniform(rng), v = uniform(rng);
                if (u + v > 1.0f) {
                    u = 1.0f - u;
                    v = 1.0f - v;
                }
                const Vec3f p = (1.0f - u - v) * mesh.positions[tri[0]] +
                                u * mesh.positions[tri[1]] + v * mesh.positions[tri[2]];
                const Vec3f g = (p - node.origin) / voxel;
                bool covered = false;
                for (int dz = -1; dz <= 1 && !covered; ++dz) {
                    for (int dy = -1; dy <= 1 && !covered; ++dy) {
                        for (int dx = -1; dx <= 1 && !covered; ++dx) {
                            const int x = static_cast<int>(std::floor(g.x())) + dx;
                            const int y = static_cast<int>(std::floor(g.y())) + dy;
                            const int z = static_cast<int>(std::floor(g.z())) + dz;
                            if (x < 0 || y < 0 || z < 0 || x >= k || y >= k || z >= k ||
                                !occupied.contains(
                                    static_cast<std::uint32_t>((z * 256 + y) * 256 + x))) {
                                continue;
                            }
                            const std::array<std::uint8_t, 3> voxel_index{
                                static_cast<std::uint8_t>(x), static_cast<std::uint8_t>(y),
                                static_cast<std::uint8_t>(z)};
                            covered = (node.voxel_centre(voxel_index, k) - p).norm() <= diagonal;
                        }
                    }
                }
                misses += covered ? 0 : 1;
                ++checked;
            }
        }
        EXPECT_EQ(misses, 0) << "node " << n << " at level " << node.level;
    }
    return checked;
}

void expect_every_triangle_once(const Mesh& mesh, const PointOctree& octree) {
    std::vector<int> seen(mesh.triangles.size(), 0);
    for (const OctreeNode& node : octree.nodes) {
        for (const std::uint32_t t : node.triangles) {
            ASSERT_LT(t, seen.size());
            ++seen[t];
        }
    }
    for (std::size_t t = 0; t < seen.size(); ++t) {
        ASSERT_EQ(seen[t], 1) << "triangle " << t;
    }
}

TEST(PointOctree, EveryTriangleEndsUpOnceAndPointsCoverTheSphere) {
    const Mesh sphere = make_sphere(1.0f, 96, 48, 0);
    PointOctreeOptions options;
    const PointOctree octree = build_point_octree(sphere, two_materials(), nullptr, options);
    expect_every_triangle_once(sphere, octree);
    EXPECT_GT(expect_coverage(sphere, octree), 10000u);
    // The root approximates the whole sphere: its points sit near the surface.
    const OctreeNode& root = octree.nodes[0];
    ASSERT_FALSE(root.points.empty());
    for (const OctreePoint& p : root.points) {
        const float voxel = root.side / static_cast<float>(options.grid);
        EXPECT_NEAR(root.voxel_centre(p.voxel, options.grid).norm(), 1.0f,
                    std::sqrt(3.0f) * 0.5f * voxel);
        // Outward normals, averaged over a patch: close to the radial direction.
        EXPECT_GT(p.normal.dot(root.voxel_centre(p.voxel, options.grid).normalized()), 0.95f);
    }
    // Normal gradients of a unit sphere: (1/r)·I at every level, less the fit's model error
    // (the deviation grows as 1/cos over the Gaussian's 2.5σ reach; σ/r ≤ 0.125 here) and the
    // facets of the 96×48 tessellation.
    int fitted = 0;
    for (const OctreeNode& node : octree.nodes) {
        for (const OctreePoint& p : node.points) {
            if (!p.gradient_fitted) {
                continue;
            }
            EXPECT_NEAR(p.gradient(0, 0), 1.0f, 0.08f);
            EXPECT_NEAR(p.gradient(1, 1), 1.0f, 0.08f);
            EXPECT_NEAR(p.gradient(0, 1), 0.0f, 0.05f);
            EXPECT_NEAR(p.gradient(1, 0), 0.0f, 0.05f);
            ++fitted;
        }
    }
    EXPECT_GT(fitted, 1000);
    // Bounding spheres hold their subtree's triangles.
    for (std::size_t n = 0; n < octree.nodes.size(); ++n) {
        std::vector<std::uint32_t> tris;
        subtree_triangles(octree, static_cast<std::int32_t>(n), tris);
        const OctreeNode& node = octree.nodes[n];
        for (const std::uint32_t t : tris) {
            for (const std::uint32_t v : sphere.triangles[t]) {
                EXPECT_LE((sphere.positions[v] - node.sphere_centre).norm(),
                          node.sphere_radius * (1.0f + 1e-5f));
            }
        }
    }
}

TEST(PointOctree, PointsCoverTheBunnyAtEveryLevel) {
    const auto path = testing::find_data_file("meshes/stanford-bunny.obj");
    ASSERT_TRUE(path.has_value()) << "stanford-bunny.obj not on the data search path";
    const Mesh bunny = load_mesh(*path, 0).mesh;
    const PointOctree octree = build_point_octree(bunny, two_materials(), nullptr, {});
    expect_every_triangle_once(bunny, octree);
    EXPECT_GT(expect_coverage(bunny, octree), 100000u);
    int deepest = 0;
    for (const OctreeNode& node : octree.nodes) {
        deepest = std::max(deepest, node.level);
    }
    EXPECT_GE(deepest, 3);
}

TEST(PointOctree, PointsCoverAProceduralPlantAtEveryLevel) {
    // Thin stems and small curved leaves in every orientation: slivers and tiny triangles.
    const Mesh plant = make_plant(3, 3, 8, 0, 1);
    const PointOctree octree = build_point_octree(plant, two_materials(), nullptr, {});
    expect_every_triangle_once(plant, octree);
    EXPECT_GT(expect_coverage(plant, octree), 20000u);
}

TEST(PointOctree, UniformMaterialIsExactAtEveryLevelAndFlatSurfacesAreCovered) {
    const Mesh quad = make_checkerboard(4.0f, 4.0f, 64, 64, 1, 1);
    const PointOctree octree = build_point_octree(quad, two_materials(), nullptr, {});
    const Material dark = two_materials()[1];
    std::size_t interior = 0;
    for (const OctreeNode& node : octree.nodes) {
        const float voxel = node.side / static_cast<float>(octree.options.grid);
        for (const OctreePoint& p : node.points) {
            EXPECT_NEAR(p.diffuse[0], dark.diffuse[0], 1e-6f);
            EXPECT_NEAR(p.diffuse[1], dark.diffuse[1], 1e-6f);
            EXPECT_NEAR(p.diffuse[2], dark.diffuse[2], 1e-6f);
            EXPECT_NEAR(p.reflectivity, 0.5f, 1e-6f);
            EXPECT_NEAR(p.normal.y(), 1.0f, 1e-6f);
            EXPECT_LT(p.gradient.norm(), 1e-4f);        // a plane does not bend
            EXPECT_NEAR(p.normal_length, 1.0f, 1e-6f);  // nor do its normals spread
            // Away from the board's edges and the node's faces (the samples are the node's own),
            // in a node that kept no triangle (a kept one is drawn as a triangle, its area is
            // not the points'), the plane's points form a square lattice of the voxel's side
            // and each stands for one voxel face of it, wherever the plane crosses the layer.
            // "Away": two gather radii (2 × 2.5 voxels), the reach of a sample's share.
            const Vec3f c = node.voxel_centre(p.voxel, octree.options.grid);
            const Vec3f inside = (c - node.origin) / voxel;
            const float margin = 5.0f;
            const auto k = static_cast<float>(octree.options.grid);
            if (node.triangles.empty() && std::abs(c.x()) < 2.0f - margin * voxel &&
                std::abs(c.z()) < 2.0f - margin * voxel && inside.x() > margin &&
                inside.x() < k - margin && inside.z() > margin && inside.z() < k - margin) {
                EXPECT_NEAR(p.coverage, 1.0f, 0.02f)
                    << "level " << node.level << " y/voxel " << c.y() / voxel << " inside "
                    << inside.transpose() << " side " << node.side << " origin "
                    << node.origin.transpose();
                ++interior;
            }
        }
    }
    EXPECT_GT(interior, 100u);
}

/// The area of triangle t of `mesh`, in double.
double area_of(const Mesh& mesh, std::uint32_t t) {
    const auto& tri = mesh.triangles[t];
    const Vec3d a = mesh.positions[tri[0]].cast<double>();
    return 0.5 * (mesh.positions[tri[1]].cast<double>() - a)
                     .cross(mesh.positions[tri[2]].cast<double>() - a)
                     .norm();
}

/// Σ `of(t)` over the triangles node n's points stand for.
template <class F>
double sum_over_represented(const PointOctree& octree, std::size_t n, const F& of) {
    double sum = 0.0;
    for (const std::uint32_t t : represented_triangles(octree, n)) {
        sum += of(t);
    }
    return sum;
}

/// Σ coverage·voxel² over a node's points against the area of the triangles they stand for
/// (computed in double from the mesh), node by node; returns the worst relative difference.
double worst_area_mismatch(const Mesh& mesh, const PointOctree& octree) {
    double worst = 0.0;
    for (std::size_t n = 0; n < octree.nodes.size(); ++n) {
        const OctreeNode& node = octree.nodes[n];
        if (node.points.empty()) {
            continue;
        }
        const double area =
            sum_over_represented(octree, n, [&](std::uint32_t t) { return area_of(mesh, t); });
        const double voxel = node.side / static_cast<double>(octree.options.grid);
        double covered = 0.0;
        for (const OctreePoint& p : node.points) {
            covered += p.coverage * voxel * voxel;
        }
        worst = std::max(worst, std::abs(covered - area) / area);
    }
    return worst;
}

TEST(PointOctree, CoveragesShareOutTheAreaOfWhatThePointsStandFor) {
    // A board tilted against every axis: its points occupy more voxels than its area in
    // voxel faces, and each stands for less than a face.
    Mesh tilted = make_checkerboard(4.0f, 4.0f, 32, 32, 0, 1);
    const Affine3f tilt(Eigen::AngleAxisf(0.6f, Vec3f::UnitX()) *
                        Eigen::AngleAxisf(0.35f, Vec3f::UnitZ()));
    for (Vec3f& p : tilted.positions) {
        p = tilt * p;
    }
    const Mesh sphere = make_sphere(1.0f, 64, 32, 0);
    const Mesh plant = make_plant(4, 2, 5, 0, 1);
    for (const Mesh* mesh : {static_cast<const Mesh*>(&tilted), &sphere, &plant}) {
        const PointOctree octree = build_point_octree(*mesh, two_materials(), nullptr, {});
        // Exact but for samples no point's Gaussian reaches, and float sums.
        EXPECT_LT(worst_area_mismatch(*mesh, octree), 2e-3) << mesh->name;
    }
    const PointOctree octree = build_point_octree(tilted, two_materials(), nullptr, {});
    double sum = 0.0;
    std::size_t count = 0;
    for (const OctreeNode& node : octree.nodes) {
        for (const OctreePoint& p : node.points) {
            sum += p.coverage;
            ++count;
        }
    }
    EXPECT_LT(sum / static_cast<double>(count), 0.85);
}

/// A unit card in the xy plane of n × n quads, uv (x + ½, y + ½), all of material 0.
Mesh grid_card(int n) {
    Mesh mesh;
    mesh.name = "card";
    for (int j = 0; j <= n; ++j) {
        for (int i = 0; i <= n; ++i) {
            const float u = static_cast<float>(i) / static_cast<float>(n);
            const float v = static_cast<float>(j) / static_cast<float>(n);
            mesh.positions.emplace_back(u - 0.5f, v - 0.5f, 0.0f);
            mesh.normals.push_back(Vec3f::UnitZ());
            mesh.uvs.emplace_back(u, v);
        }
    }
    const auto index = [n](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            mesh.triangles.push_back({index(i, j), index(i + 1, j), index(i + 1, j + 1)});
            mesh.triangles.push_back({index(i, j), index(i + 1, j + 1), index(i, j + 1)});
        }
    }
    mesh.materials.assign(mesh.triangles.size(), 0);
    return mesh;
}

TEST(PointOctree, ACutOutsPointsCoverWhatStandsOfItAtEveryLevel) {
    // A leaf card: the points of every node cover the represented triangles' whole area, and
    // their opacities weighed by coverage the area that stands (a quadrature of the bilinear
    // opacity over each triangle).
    const testing::ScratchDirectory scratch("mrt_point_octree_cutout");
    const double inside = testing::write_leaf_texture(scratch.path() / "leaf.png", 64);
    Scene scene;
    scene.textures.push_back(Texture{scratch.path() / "leaf.png", false, TextureChannel::Opacity});
    Material leaf;
    leaf.opacity_texture = 0;
    scene.materials = {leaf};
    const TextureSampler textures(scene);
    const Mesh card = grid_card(32);
    // Each triangle's standing area, by a 16 × 16 midpoint quadrature in its barycentrics.
    std::vector<double> standing(card.triangles.size(), 0.0);
    for (std::size_t t = 0; t < card.triangles.size(); ++t) {
        const auto& tri = card.triangles[t];
        constexpr int kSteps = 16;
        double sum = 0.0;
        int count = 0;
        for (int a = 0; a < kSteps; ++a) {
            for (int b = 0; a + b < kSteps; ++b) {
                const float b1 = (static_cast<float>(a) + 1.0f / 3.0f) / kSteps;
                const float b2 = (static_cast<float>(b) + 1.0f / 3.0f) / kSteps;
                const Vec2f uv = (1.0f - b1 - b2) * card.uvs[tri[0]] + b1 * card.uvs[tri[1]] +
                                 b2 * card.uvs[tri[2]];
                sum += textures.opacity(leaf, uv);
                ++count;
            }
        }
        standing[t] = area_of(card, static_cast<std::uint32_t>(t)) * sum / count;
    }
    double total = 0.0;
    for (const double a : standing) {
        total += a;
    }
    EXPECT_NEAR(total, inside, 0.01 * inside) << "the quadrature itself";
    const PointOctree octree = build_point_octree(card, scene.materials, &textures, {});
    double worst = 0.0;
    for (std::size_t n = 0; n < octree.nodes.size(); ++n) {
        const OctreeNode& node = octree.nodes[n];
        if (node.points.empty()) {
            continue;
        }
        const double area =
            sum_over_represented(octree, n, [&](std::uint32_t t) { return standing[t]; });
        const double whole =
            sum_over_represented(octree, n, [&](std::uint32_t t) { return area_of(card, t); });
        const double voxel = node.side / static_cast<double>(octree.options.grid);
        double covered = 0.0;
        double stands = 0.0;
        for (const OctreePoint& p : node.points) {
            EXPECT_GE(p.opacity, 0.0f);
            EXPECT_LE(p.opacity, 1.0f);
            covered += p.coverage * voxel * voxel;
            stands += p.coverage * p.opacity * voxel * voxel;
        }
        EXPECT_NEAR(covered, whole, 2e-3 * whole) << "node " << n;
        // Relative to the node's whole area: nodes over the holes stand for almost nothing.
        worst = std::max(worst, std::abs(stands - area) / whole);
    }
    std::printf("  worst standing-area error %.5f of a node's area\n", worst);
    EXPECT_LT(worst, 0.015);  // measured 0.0067: the opacity sampled at the dense samples
}

/// The length of the average unit normal of the sphere of radius `r` about the origin, weighed
/// by the prefilter's Gaussian of σ = `sigma` around `centre`, cut at 2.5σ: a quadrature in polar
/// coordinates about the direction of `centre`, independent of the build's samples.
double sphere_normal_length(const Vec3d& centre, double r, double sigma) {
    const Vec3d axis = centre.normalized();
    const Vec3d t = axis.unitOrthogonal();
    const Vec3d b = axis.cross(t);
    const double cut = 2.5 * sigma;
    const double reach =
        std::min(std::numbers::pi,
                 2.0 * std::asin(std::min(1.0, 0.5 * (centre.norm() - r + cut) / r)) + 0.1);
    constexpr int kRings = 400;
    constexpr int kSectors = 400;
    Vec3d sum = Vec3d::Zero();
    double weight = 0.0;
    for (int i = 0; i < kRings; ++i) {
        const double polar = (i + 0.5) * reach / kRings;
        for (int j = 0; j < kSectors; ++j) {
            const double azimuth = (j + 0.5) * 2.0 * std::numbers::pi / kSectors;
            const Vec3d n = std::cos(polar) * axis +
                            std::sin(polar) * (std::cos(azimuth) * t + std::sin(azimuth) * b);
            const double d2 = (r * n - centre).squaredNorm();
            if (d2 > cut * cut) {
                continue;
            }
            const double w = std::exp(-0.5 * d2 / (sigma * sigma)) * std::sin(polar);
            sum += w * n;
            weight += w;
        }
    }
    return sum.norm() / weight;
}

TEST(PointOctree, NormalLengthIsTheSpreadOfTheNormalsAPointStandsFor) {
    // On a sphere the normals under a point's Gaussian spread by about σ/r: the length of their
    // average is that of the sphere's own normals under the same Gaussian, a quadrature. The root
    // of a sphere half as large is half as large: the same spread (scale invariance). A plane's
    // is 1 (UniformMaterialIsExactAtEveryLevelAndFlatSurfacesAreCovered).
    std::vector<double> spreads;
    for (const float radius : {1.0f, 0.5f}) {
        const Mesh sphere = make_sphere(radius, 128, 64, 0);
        const PointOctree octree = build_point_octree(sphere, two_materials(), nullptr, {});
        const int k = octree.options.grid;
        const OctreeNode& root = octree.nodes.front();
        ASSERT_GT(root.points.size(), 100u);
        const double sigma = root.side / static_cast<double>(k);
        double worst = 0.0;
        double spread = 0.0;
        for (std::size_t i = 0; i < root.points.size(); i += 7) {
            const OctreePoint& p = root.points[i];
            const Vec3d centre = root.voxel_centre(p.voxel, k).cast<double>();
            const double expected = sphere_normal_length(centre, radius, sigma);
            worst = std::max(worst, std::abs(p.normal_length - expected) / (1.0 - expected));
            spread += 1.0 - expected;
        }
        spread /= static_cast<double>((root.points.size() + 6) / 7);
        std::printf("  radius %g: worst relative error %.4f, mean 1 - length %.5f\n", radius, worst,
                    spread);
        // 1 − ℓ ≈ σ²/r² (a Gaussian's mean squared tangential distance 2σ²): a per cent or more.
        EXPECT_GT(spread, 0.3 * sigma * sigma / (radius * radius));
        EXPECT_LT(worst, 0.03);  // measured 0.0076
        spreads.push_back(spread);
    }
    EXPECT_NEAR(spreads[1] / spreads[0], 1.0, 1e-3);
}

TEST(PointOctree, CoarseCheckerboardColourIsTheAreaWeightedAverage) {
    // 128² tiles over 4 units: at the root (voxel 0.25) every point's Gaussian spans many
    // tiles, so the colour is the average of the two materials, weighted by area (half each).
    const Mesh board = make_checkerboard(4.0f, 4.0f, 128, 128, 0, 1);
    PointOctreeOptions options;
    options.max_depth = 1;  // only the root's points are checked
    const PointOctree octree = build_point_octree(board, two_materials(), nullptr, options);
    const OctreeNode& root = octree.nodes[0];
    const float voxel = root.side / static_cast<float>(octree.options.grid);
    const auto materials = two_materials();
    const Rgb expected = 0.5f * (materials[0].diffuse + materials[1].diffuse);
    int checked = 0;
    for (const OctreePoint& p : root.points) {
        const Vec3f c = root.voxel_centre(p.voxel, octree.options.grid);
        if (std::abs(c.x()) < 2.0f - 3.0f * voxel && std::abs(c.z()) < 2.0f - 3.0f * voxel) {
            // Tile size / σ = 0.03125 / 0.25: the Gaussian averages ~50 tiles per axis; the
            // residual of its sampled average is below 1 %.
            EXPECT_NEAR(p.diffuse[0], expected[0], 0.01f);
            EXPECT_NEAR(p.diffuse[1], expected[1], 0.01f);
            EXPECT_NEAR(p.reflectivity, 0.25f, 0.01f);
            ++checked;
        }
    }
    EXPECT_GT(checked, 50);
}

TEST(PointOctree, SameResultForAnyNumberOfThreads) {
    const Mesh sphere = make_sphere(1.0f, 64, 32, 0);
    const auto build = [&](int threads) {
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                        static_cast<std::size_t>(threads));
        return build_point_octree(sphere, two_materials(), nullptr, {});
    };
    const PointOctree one = build(1);
    const PointOctree two = build(2);
    ASSERT_EQ(one.nodes.size(), two.nodes.size());
    for (std::size_t n = 0; n < one.nodes.size(); ++n) {
        const OctreeNode& a = one.nodes[n];
        const OctreeNode& b = two.nodes[n];
        ASSERT_EQ(a.triangles, b.triangles);
        ASSERT_EQ(a.children, b.children);
        ASSERT_EQ(a.points.size(), b.points.size());
        for (std::size_t i = 0; i < a.points.size(); ++i) {
            ASSERT_EQ(a.points[i].voxel, b.points[i].voxel);
            ASSERT_EQ(a.points[i].normal, b.points[i].normal);
            ASSERT_EQ(a.points[i].coverage, b.points[i].coverage);
        }
    }
}

TEST(PointOctree, RefusesAGridTheFileCannotIndex) {
    PointOctreeOptions options;
    options.grid = 257;
    EXPECT_NE(testing::error_message([&] {
                  build_point_octree(make_quad(1, 1, 0), two_materials(), nullptr, options);
              }).find("grid"),
              std::string::npos);
}

}  // namespace
}  // namespace mrt
