// The instanced hierarchy: group nodes' points cover every instance below them within the voxel
// diagonal (the mesh octrees' guarantee, now across instances and nested groups), prefilter a
// uniform material exactly, agree with a flattened build's points on the same surface, and the
// file is byte-identical for any thread count. The surface is checked against samples of the
// instanced triangles themselves, expanded independently of the builder.

#include "preprocess/scene_hierarchy.h"
#include "common/hierarchy/hierarchy_file.h"
#include "common/mesh/procedural.h"
#include "common/system/progress.h"
#include "preprocess/hierarchy_pack.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <random>
#include <unordered_map>

namespace mrt {
namespace {

/// A world of `tiles`² tiles, each a group of 3×3 plants (two plant meshes, rotated and scaled
/// differently) on a ground, the tiles rotated and scaled too: nested, non-uniform instancing.
Scene plant_field(int tiles, bool one_material) {
    Scene scene;
    Material stem;
    stem.name = "stem";
    stem.diffuse = Rgb(0.4f, 0.25f, 0.1f);
    Material leaf;
    leaf.name = "leaf";
    leaf.diffuse = one_material ? stem.diffuse : Rgb(0.1f, 0.7f, 0.2f);
    scene.materials = {stem, leaf};
    // A ground of large triangles, kept in its octree's root: group points must sample them.
    scene.meshes = {make_plant(3, 2, 4, 0, 1), make_plant(8, 1, 6, 0, 1),
                    make_checkerboard(4.0f, 4.0f, 2, 2, 0, 1)};
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    Group tile;
    tile.name = "tile";
    for (int i = 0; i < 9; ++i) {
        Instance plant;
        plant.kind = Instance::Kind::Mesh;
        plant.index = static_cast<std::uint32_t>(i % 2);
        plant.transform = Eigen::Translation3f(static_cast<float>(i % 3) * 1.3f, 0.0f,
                                               static_cast<float>(i / 3) * 1.3f) *
                          Eigen::AngleAxisf(6.28f * unit(rng), Vec3f::UnitY()) *
                          Eigen::Scaling(0.7f + 0.6f * unit(rng), 0.8f + 0.5f * unit(rng),
                                         0.7f + 0.6f * unit(rng));
        tile.children.push_back(plant);
    }
    Instance ground;
    ground.kind = Instance::Kind::Mesh;
    ground.index = 2;
    ground.transform = Eigen::Translation3f(1.3f, 0.0f, 1.3f);
    tile.children.push_back(ground);
    Group world;
    world.name = "world";
    for (int i = 0; i < tiles * tiles; ++i) {
        Instance t;
        t.kind = Instance::Kind::Group;
        t.index = 0;
        t.transform = Eigen::Translation3f(static_cast<float>(i % tiles) * 4.2f, 0.0f,
                                           static_cast<float>(i / tiles) * 4.2f) *
                      Eigen::AngleAxisf(1.57f * static_cast<float>(i % 4), Vec3f::UnitY()) *
                      Eigen::Scaling(1.0f + 0.1f * static_cast<float>(i % 3));
        world.children.push_back(t);
    }
    scene.groups = {tile, world};
    scene.root = 1;
    return scene;
}

/// Samples (in the space of `tree`'s object) of every triangle below node n, a few per
/// triangle, following instances into nested objects: the builder's surface, expanded anew.
void surface_below(const SceneHierarchy& h, std::uint32_t object, std::size_t n,
                   const Affine3f& to_space, std::mt19937_64& rng, std::vector<Vec3f>& out) {
    const SceneObject& o = h.objects[object];
    const OctreeNode& node = o.tree.nodes[n];
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    if (o.kind == SceneObject::Kind::Mesh) {
        // Every triangle of the mesh lies in the root's subtree; below other nodes, only the
        // root is ever asked for here (group nodes hold whole instances).
        for (const auto& tri : o.mesh->triangles) {
            for (int s = 0; s < 2; ++s) {
                float b1 = unit(rng), b2 = unit(rng);
                if (b1 + b2 > 1.0f) {
                    b1 = 1.0f - b1;
                    b2 = 1.0f - b2;
                }
                out.push_back(to_space *
                              ((1.0f - b1 - b2) * o.mesh->positions[tri[0]] +
                               b1 * o.mesh->positions[tri[1]] + b2 * o.mesh->positions[tri[2]]));
            }
        }
        return;
    }
    for (const std::int32_t c : node.children) {
        if (c >= 0) {
            surface_below(h, object, static_cast<std::size_t>(c), to_space, rng, out);
        }
    }
    for (const std::uint32_t i : node.instances) {
        const SceneInstance& instance = h.instances[i];
        surface_below(h, instance.object, 0, to_space * instance.transform, rng, out);
    }
}

/// The largest distance from a surface sample to the nearest representative of `node`, over
/// the voxel diagonal (≤ 1 is the coverage guarantee).
double worst_coverage(const OctreeNode& node, int grid, const std::vector<Vec3f>& surface) {
    const float voxel = node.side / static_cast<float>(grid);
    std::unordered_map<std::uint32_t, std::vector<Vec3f>> cells;  // voxel → representatives
    const auto key = [&](const Vec3i& v) {
        return static_cast<std::uint32_t>(((v.z() + 2) * 300 + (v.y() + 2)) * 300 + (v.x() + 2));
    };
    for (const OctreePoint& p : node.points) {
        const Vec3i v(p.voxel[0], p.voxel[1], p.voxel[2]);
        cells[key(v)].push_back(node.voxel_centre(p.voxel, grid));
    }
    double worst = 0.0;
    for (const Vec3f& x : surface) {
        const Vec3f g = (x - node.origin) / voxel;
        const Vec3i v(static_cast<int>(std::floor(g.x())), static_cast<int>(std::floor(g.y())),
                      static_cast<int>(std::floor(g.z())));
        float best = std::numeric_limits<float>::infinity();
        for (int dz = -2; dz <= 2; ++dz) {
            for (int dy = -2; dy <= 2; ++dy) {
                for (int dx = -2; dx <= 2; ++dx) {
                    const auto it = cells.find(key(v + Vec3i(dx, dy, dz)));
                    if (it == cells.end()) {
                        continue;
                    }
                    for (const Vec3f& c : it->second) {
                        best = std::min(best, (c - x).norm());
                    }
                }
            }
        }
        worst = std::max(worst, static_cast<double>(best) / (std::sqrt(3.0) * voxel));
    }
    return worst;
}

TEST(SceneHierarchy, GroupPointsCoverEveryInstanceBelowWithinTheVoxelDiagonal) {
    const Scene scene = plant_field(3, false);
    const SceneHierarchy h = build_scene_hierarchy(scene, nullptr, {});
    ASSERT_EQ(h.objects.size(), 5u);  // two plants, the ground, the tile, the world
    EXPECT_EQ(h.objects[h.world].kind, SceneObject::Kind::Group);
    std::mt19937_64 rng(5);
    std::size_t checked = 0;
    for (std::uint32_t o = 0; o < h.objects.size(); ++o) {
        if (h.objects[o].kind != SceneObject::Kind::Group) {
            continue;
        }
        for (std::size_t n = 0; n < h.objects[o].tree.nodes.size(); ++n) {
            const OctreeNode& node = h.objects[o].tree.nodes[n];
            if (node.points.empty()) {
                continue;
            }
            std::vector<Vec3f> surface;
            surface_below(h, o, n, Affine3f::Identity(), rng, surface);
            ASSERT_FALSE(surface.empty());
            EXPECT_LE(worst_coverage(node, h.options.grid, surface), 1.0)
                << "object " << o << " node " << n << " level " << node.level;
            ++checked;
        }
    }
    // The world root and the tile root at least, and the inner nodes of the world's tree.
    EXPECT_GE(checked, 3u);
}

TEST(SceneHierarchy, GroupPointsPrefilterAUniformMaterialExactly) {
    const Scene scene = plant_field(2, true);
    const SceneHierarchy h = build_scene_hierarchy(scene, nullptr, {});
    std::size_t points = 0;
    for (const SceneObject& o : h.objects) {
        if (o.kind != SceneObject::Kind::Group) {
            continue;
        }
        for (const OctreeNode& node : o.tree.nodes) {
            for (const OctreePoint& p : node.points) {
                EXPECT_NEAR(p.diffuse.x(), 0.4f, 1e-5f);
                EXPECT_NEAR(p.diffuse.y(), 0.25f, 1e-5f);
                EXPECT_NEAR(p.diffuse.z(), 0.1f, 1e-5f);
                EXPECT_NEAR(std::abs(p.normal.norm()), 1.0f, 1e-5f);
                ++points;
            }
        }
    }
    EXPECT_GT(points, 100u);
}

/// A piece of surface: where, how much area, what colour.
struct ColourSample {
    Vec3f position;
    float area;
    Rgb colour;
};

/// What a node shows at its resolution: its points (area coverage·voxel²) and, for a mesh
/// node, its kept triangles, sampled densely (the tracer intersects those directly).
std::vector<ColourSample> node_surface(const OctreeNode& node, int grid, const Mesh* mesh,
                                       const std::vector<Material>& materials) {
    std::vector<ColourSample> out;
    const float voxel = node.side / static_cast<float>(grid);
    for (const OctreePoint& p : node.points) {
        out.push_back({node.voxel_centre(p.voxel, grid), p.coverage * voxel * voxel, p.diffuse});
    }
    if (mesh != nullptr) {
        for (const std::uint32_t t : node.triangles) {
            const auto& tri = mesh->triangles[t];
            const Vec3f a = mesh->positions[tri[0]], b = mesh->positions[tri[1]],
                        c = mesh->positions[tri[2]];
            const float area = 0.5f * (b - a).cross(c - a).norm();
            constexpr int kSteps = 40;
            for (int i = 0; i < kSteps; ++i) {
                for (int j = 0; i + j < kSteps; ++j) {
                    const float u = (static_cast<float>(i) + 1.0f / 3.0f) / kSteps;
                    const float v = (static_cast<float>(j) + 1.0f / 3.0f) / kSteps;
                    out.push_back({(1.0f - u - v) * a + u * b + v * c,
                                   area / (kSteps * (kSteps + 1) / 2),
                                   materials[mesh->materials[t]].diffuse});
                }
            }
        }
    }
    return out;
}

/// The Gaussian-weighted (σ = `sigma`) average colour of `surface` around x.
Rgb colour_near(const std::vector<ColourSample>& surface, const Vec3f& x, float sigma) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double weight = 0.0;
    for (const ColourSample& s : surface) {
        const float d2 = (s.position - x).squaredNorm();
        const double w = std::exp(-0.5 * d2 / (sigma * sigma)) * s.area;
        sum += w * s.colour.matrix().cast<double>();
        weight += w;
    }
    return weight > 0.0 ? Rgb((sum / weight).cast<float>().array()) : Rgb::Zero();
}

TEST(SceneHierarchy, InstancedAndFlattenedRootsDescribeTheSameSurface) {
    const Scene scene = plant_field(3, false);
    const SceneHierarchy instanced = build_scene_hierarchy(scene, nullptr, {});
    const SceneHierarchy flat = build_scene_hierarchy(scene, nullptr, {}, Instancing::Flatten);
    ASSERT_EQ(flat.objects.size(), 1u);
    EXPECT_EQ(flat.objects[0].mesh->triangles.size(), scene.instanced_triangle_count());
    const OctreeNode& a = instanced.objects[instanced.world].tree.nodes[0];
    const OctreeNode& b = flat.objects[0].tree.nodes[0];
    ASSERT_FALSE(a.points.empty());
    ASSERT_FALSE(b.points.empty());
    const int k = instanced.options.grid;
    // The same world: cubes within a voxel of each other (the instanced bounds include the
    // finer points' half voxels).
    const float voxel = b.side / static_cast<float>(k);
    EXPECT_NEAR(a.side, b.side, 1.5f * voxel);
    // The instanced points lie on the flattened ones' surface and the other way round (within
    // both diagonals, points only: the flattened root also keeps triangles), and the colours
    // seen through a one-voxel Gaussian agree.
    const auto farthest = [&](const OctreeNode& from, const OctreeNode& to) {
        double worst = 0.0;
        for (const OctreePoint& p : from.points) {
            const Vec3f x = from.voxel_centre(p.voxel, k);
            float best = std::numeric_limits<float>::infinity();
            for (const OctreePoint& q : to.points) {
                best = std::min(best, (to.voxel_centre(q.voxel, k) - x).norm());
            }
            worst = std::max(worst, static_cast<double>(best));
        }
        return worst / (std::sqrt(3.0) * voxel);
    };
    EXPECT_LE(farthest(b, a), 1.5);
    // The flattened root keeps the ground's large triangles; the instanced root's points
    // stand for everything below it, the ground included.
    EXPECT_FALSE(b.triangles.empty());
    const std::vector<ColourSample> seen_a = node_surface(a, k, nullptr, scene.materials);
    const std::vector<ColourSample> seen_b =
        node_surface(b, k, flat.objects[0].mesh, scene.materials);
    double difference = 0.0;
    for (const OctreePoint& p : a.points) {
        const Vec3f x = a.voxel_centre(p.voxel, k);
        difference +=
            (colour_near(seen_a, x, voxel) - colour_near(seen_b, x, voxel)).abs().maxCoeff();
    }
    // Stems and leaves differ by 0.6 in green: a wrong mix would show as tenths.
    EXPECT_LT(difference / static_cast<double>(a.points.size()), 0.03);
}

TEST(SceneHierarchy, FileIsByteIdenticalForAnyThreadCount) {
    const Scene scene = plant_field(2, false);
    const auto packed = [&](int threads) {
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                        static_cast<std::size_t>(threads));
        const SceneHierarchy h = build_scene_hierarchy(scene, nullptr, {});
        return pack_hierarchy(h, scene.materials, "{}", "{}");
    };
    const HierarchyData one = packed(1);
    const HierarchyData many = packed(4);
    const auto same = [](const auto& x, const auto& y) {
        return x.size() == y.size() &&
               std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0;
    };
    EXPECT_TRUE(same(one.nodes, many.nodes));
    EXPECT_TRUE(same(one.core, many.core));
    EXPECT_TRUE(same(one.diffuse, many.diffuse));
    EXPECT_TRUE(same(one.instances, many.instances));
    EXPECT_TRUE(same(one.objects, many.objects));
    EXPECT_TRUE(same(one.triangles, many.triangles));
    EXPECT_EQ(one.world_object, many.world_object);
}

TEST(SceneHierarchy, ProgressReachesItsTotalExactly) {
    const Scene scene = plant_field(2, false);
    for (const Instancing instancing : {Instancing::Keep, Instancing::Flatten}) {
        const std::uint64_t total = hierarchy_progress_total(scene, instancing);
        Progress progress("test", total, true);
        build_scene_hierarchy(scene, nullptr, {}, instancing, &progress);
        EXPECT_EQ(progress.done(), total)
            << (instancing == Instancing::Flatten ? "flattened" : "instanced");
    }
    // Instanced: the unique triangles and the tile's and the world's instances.
    EXPECT_EQ(hierarchy_progress_total(scene, Instancing::Keep),
              scene.unique_triangle_count() + 10 + 4);
}

TEST(SceneHierarchy, StoresUniqueGeometryOnce) {
    const Scene scene = plant_field(3, false);
    const HierarchyData instanced =
        pack_hierarchy(build_scene_hierarchy(scene, nullptr, {}), scene.materials, "{}", "{}");
    const HierarchyData flat =
        pack_hierarchy(build_scene_hierarchy(scene, nullptr, {}, Instancing::Flatten),
                       scene.materials, "{}", "{}");
    EXPECT_EQ(instanced.triangles.size(), scene.unique_triangle_count());
    EXPECT_EQ(flat.triangles.size(), scene.instanced_triangle_count());
    EXPECT_EQ(instanced.instances.size(), 10u + 9u);  // plants and ground, tiles of the world
    EXPECT_LT(instanced.core.size() * 4, flat.core.size());
}

/// One 8-triangle sphere instanced `copies` times at each of `places` places 3 apart along x
/// (radius 1: the places do not overlap, the copies at one place coincide).
Scene piled_spheres(int places, int copies) {
    Scene scene;
    scene.materials = {Material{}};
    scene.meshes = {make_sphere(1.0f, 4, 2, 0)};
    Group world;
    world.name = "world";
    for (int p = 0; p < places; ++p) {
        for (int c = 0; c < copies; ++c) {
            Instance sphere;
            sphere.kind = Instance::Kind::Mesh;
            sphere.index = 0;
            sphere.transform = Eigen::Translation3f(3.0f * static_cast<float>(p), 0.0f, 0.0f);
            world.children.push_back(sphere);
        }
    }
    scene.groups = {world};
    return scene;
}

HierarchyWork work_of(const Scene& scene) {
    PointOctreeOptions options;
    options.oversampling = 16;  // the work's growth, not its amount, is checked
    return build_scene_hierarchy(scene, nullptr, options).work;
}

// Overlapping instances made every level of the instance tree (halves of the pile, all the
// same cube) re-sample every instance below it: N log N samples, and N instances' samples held
// at once in the root. Eight times the instances may cost at most about eight times the work.
TEST(SceneHierarchy, WorkGrowsLinearlyWithOverlappingInstances) {
    for (const int places : {1, 8}) {
        const HierarchyWork few = work_of(piled_spheres(places, 16));
        const HierarchyWork many = work_of(piled_spheres(places, 128));
        ASSERT_GT(few.samples, 0u);
        EXPECT_LE(static_cast<double>(many.samples), 8.0 * 1.1 * static_cast<double>(few.samples))
            << places << " places: " << few.samples << " → " << many.samples << " samples";
        EXPECT_LE(static_cast<double>(many.visits), 8.0 * 1.1 * static_cast<double>(few.visits))
            << places << " places: " << few.visits << " → " << many.visits << " nodes walked";
        // A pile's halves share its cube: only the pile's node makes points, however high.
        EXPECT_EQ(many.point_nodes, few.point_nodes) << places << " places";
    }
}

TEST(SceneHierarchy, WorkGrowsLinearlyWithSeparateInstances) {
    const HierarchyWork few = work_of(piled_spheres(16, 1));
    const HierarchyWork many = work_of(piled_spheres(128, 1));
    ASSERT_GT(few.samples, 0u);
    EXPECT_LE(static_cast<double>(many.samples), 8.0 * 1.25 * static_cast<double>(few.samples))
        << few.samples << " → " << many.samples << " samples";
    EXPECT_EQ(few.thinned_nodes, 0u);  // separate instances are one layer of surface
}

// Piled instances keep covering their surface: the thinned samples still choose a point for
// every voxel the instances pass through, and prefilter a uniform material exactly.
TEST(SceneHierarchy, ThinnedPilesStillCoverTheirSurfaceAndAverageExactly) {
    Scene scene = piled_spheres(2, 64);
    // Each copy turned differently, so the copies do not coincide.
    for (std::size_t i = 0; i < scene.groups[0].children.size(); ++i) {
        Affine3f& m = scene.groups[0].children[i].transform;
        m = m *
            Eigen::AngleAxisf(0.1f * static_cast<float>(i), Vec3f(1.0f, 2.0f, 3.0f).normalized());
    }
    scene.materials[0].diffuse = Rgb(0.3f, 0.5f, 0.7f);
    PointOctreeOptions options;
    options.oversampling = 16;
    const SceneHierarchy h = build_scene_hierarchy(scene, nullptr, options);
    EXPECT_GT(h.work.thinned_nodes, 0u);
    const SceneObject& world = h.objects[h.world];
    std::mt19937_64 rng(9);
    std::size_t checked = 0;
    for (std::size_t n = 0; n < world.tree.nodes.size(); ++n) {
        const OctreeNode& node = world.tree.nodes[n];
        if (node.points.empty()) {
            continue;
        }
        std::vector<Vec3f> surface;
        surface_below(h, h.world, n, Affine3f::Identity(), rng, surface);
        EXPECT_LE(worst_coverage(node, h.options.grid, surface), 1.0) << "node " << n;
        for (const OctreePoint& p : node.points) {
            EXPECT_NEAR(p.diffuse.y(), 0.5f, 1e-5f);
        }
        ++checked;
    }
    EXPECT_GE(checked, 3u);  // the root and one node per place
}

// Copies piled exactly on one another, thinned to a share of their samples each: every point
// still gathers samples, and the coverages add up to all the copies' area (each kept sample
// stands for its triangle's area over the samples kept).
TEST(SceneHierarchy, ThinnedIdenticalCopiesKeepTheirAreaAndEveryPointItsSamples) {
    constexpr int kCopies = 256;
    const Scene scene = piled_spheres(1, kCopies);
    const SceneHierarchy h = build_scene_hierarchy(scene, nullptr, {});
    EXPECT_GT(h.work.thinned_nodes, 0u);
    const OctreeNode& root = h.objects[h.world].tree.nodes[0];
    ASSERT_FALSE(root.points.empty());
    double coverage = 0.0;
    std::size_t empty = 0;
    for (const OctreePoint& p : root.points) {
        coverage += static_cast<double>(p.coverage);
        empty += p.coverage > 0.0f ? 0 : 1;
    }
    const Mesh& sphere = scene.meshes[0];
    double area = 0.0;
    for (const auto& t : sphere.triangles) {
        area +=
            0.5 * static_cast<double>((sphere.positions[t[1]] - sphere.positions[t[0]])
                                          .cross(sphere.positions[t[2]] - sphere.positions[t[0]])
                                          .norm());
    }
    const double voxel = static_cast<double>(root.side) / h.options.grid;
    EXPECT_NEAR(coverage, kCopies * area / (voxel * voxel), 1e-3 * coverage);
    EXPECT_EQ(empty, 0u) << "of " << root.points.size() << " points";
}

}  // namespace
}  // namespace mrt
