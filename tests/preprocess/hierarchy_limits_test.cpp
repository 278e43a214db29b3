// The hierarchy build under huge but finite geometry and under its budgets: a sphere stretched
// to 1e30 builds finite, covering nodes (the arithmetic of extents, areas and distances is done
// where it cannot overflow); geometry whose cubes single precision cannot hold, and builds
// over Budgets::points or Budgets::octree_depth, are refused in one line naming the scene
// file, the mesh or group, what it asks for and the limit.

#include "common/hierarchy/hierarchy_file.h"
#include "common/mesh/procedural.h"
#include "preprocess/hierarchy_pack.h"
#include "preprocess/scene_hierarchy.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <string>

namespace mrt {
namespace {

/// A floor and `mesh` placed by `transform`, as loaded from "limits.json".
Scene floor_and(Mesh mesh, const Affine3f& transform) {
    Scene scene;
    scene.file = "limits.json";
    scene.materials = {Material{}};
    scene.meshes = {make_quad(8.0f, 8.0f, 0), std::move(mesh)};
    Group world;
    world.name = "world";
    world.children = {Instance{Instance::Kind::Mesh, 0, Affine3f::Identity()},
                      Instance{Instance::Kind::Mesh, 1, transform}};
    scene.groups = {world};
    return scene;
}

std::string refusal(const Scene& scene, const PointOctreeOptions& options = {}) {
    const tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    try {
        build_scene_hierarchy(scene, nullptr, options);
    } catch (const Error& e) {
        return e.what();
    }
    return "(built)";
}

bool finite(const Vec3f& v) {
    return v.allFinite();
}

TEST(HierarchyLimits, ASphereStretchedTo1e30BuildsFiniteNodesThatCoverIt) {
    const Affine3f stretch =
        Affine3f(Eigen::Translation3f(0.0f, 1.0f, 0.0f)) * Eigen::Scaling(1e30f, 1.0f, 1.0f);
    const Scene scene = floor_and(make_sphere(1.0f, 16, 8, 0), stretch);
    const SceneHierarchy h = build_scene_hierarchy(scene, nullptr, {});
    for (const SceneObject& o : h.objects) {
        for (const OctreeNode& node : o.tree.nodes) {
            EXPECT_TRUE(finite(node.origin) && std::isfinite(node.side) && node.side > 0.0f);
            EXPECT_TRUE(finite(node.sphere_centre) && std::isfinite(node.sphere_radius));
            for (const OctreePoint& p : node.points) {
                EXPECT_TRUE(std::isfinite(p.coverage) && p.coverage >= 0.0f);
                EXPECT_TRUE(finite(p.normal) && std::isfinite(p.offset));
            }
        }
    }
    // The world's root holds the stretched sphere as points: 1e30 long, one voxel thick.
    const OctreeNode& root = h.objects[h.world].tree.nodes[0];
    ASSERT_FALSE(root.points.empty());
    EXPECT_NEAR(root.side, 2e30f, 1e27f);
    const float voxel = root.side / static_cast<float>(h.options.grid);
    for (const OctreePoint& p : root.points) {
        const Vec3f c = root.voxel_centre(p.voxel, h.options.grid);
        EXPECT_LE(std::abs(c.x()), 1.01e30f);
        EXPECT_LE(std::abs(c.y()), voxel);  // the sphere and the floor are well inside a voxel
        EXPECT_LE(std::abs(c.z()), voxel);
    }
    // The sphere's surface spans the root's width: its points reach both ends.
    float lowest = kInfinity, highest = -kInfinity;
    for (const OctreePoint& p : root.points) {
        const float x = root.voxel_centre(p.voxel, h.options.grid).x();
        lowest = std::min(lowest, x);
        highest = std::max(highest, x);
    }
    EXPECT_LT(lowest, -0.8e30f);
    EXPECT_GT(highest, 0.8e30f);
    // And the file's reader accepts what is packed.
    const testing::ScratchDirectory scratch("mrt_hierarchy_limits_test");
    const std::filesystem::path file = scratch.path() / "stretched.mrh";
    write_hierarchy_file(file, pack_hierarchy(h, scene.materials, "{}", "{}"));
    EXPECT_EQ(HierarchyFile::open(file).nodes().size(), h.objects[0].tree.nodes.size() +
                                                            h.objects[1].tree.nodes.size() +
                                                            h.objects[2].tree.nodes.size());
}

// A radius of 4294967297 is 2^32 in single precision: every coordinate, extent and area of the
// unit sphere scaled by a power of two, exactly. Its octree is the unit sphere's, scaled.
TEST(HierarchyLimits, ASphereOfRadius2To32BuildsTheUnitSphereScaled) {
    const std::vector<Material> materials = {Material{}};
    const PointOctree unit =
        build_point_octree(make_sphere(1.0f, 64, 32, 0), materials, nullptr, {});
    const PointOctree big =
        build_point_octree(make_sphere(4294967297.0f, 64, 32, 0), materials, nullptr, {});
    ASSERT_EQ(unit.nodes.size(), big.nodes.size());
    constexpr float kScale = 4294967296.0f;
    std::size_t points = 0;
    for (std::size_t n = 0; n < unit.nodes.size(); ++n) {
        const OctreeNode& a = unit.nodes[n];
        const OctreeNode& b = big.nodes[n];
        EXPECT_EQ(a.level, b.level);
        EXPECT_EQ(a.triangles, b.triangles);
        EXPECT_EQ(a.origin * kScale, b.origin);
        EXPECT_EQ(a.side * kScale, b.side);
        ASSERT_EQ(a.points.size(), b.points.size());
        for (std::size_t i = 0; i < a.points.size(); ++i) {
            EXPECT_EQ(a.points[i].voxel, b.points[i].voxel);
            EXPECT_NEAR(a.points[i].coverage, b.points[i].coverage, 1e-6f);
            EXPECT_NEAR(a.points[i].offset, b.points[i].offset, 1e-6f);
            ++points;
        }
    }
    EXPECT_GT(points, 1000u);
}

// Depth adapts to where the geometry is: two small triangles 1e30 apart make a root and two
// leaves, not the 100 levels that separate their size from the extent.
TEST(HierarchyLimits, DepthFollowsTheGeometryNotItsExtent) {
    Mesh mesh;
    mesh.name = "two specks";
    mesh.positions = {{0, 0, 0},    {1, 0, 0}, {0, 1, 0}, {1e30f, 0, 0}, {1e30f + 1e24f, 0, 0},
                      {1e30f, 1, 0}};
    mesh.normals.assign(6, Vec3f::UnitZ());
    mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
    mesh.materials = {0, 0};
    PointOctreeOptions options;
    options.budgets.octree_depth = 1;
    const PointOctree octree = build_point_octree(mesh, {Material{}}, nullptr, options);
    ASSERT_EQ(octree.nodes.size(), 3u);
    EXPECT_EQ(octree.nodes[1].triangles.size() + octree.nodes[2].triangles.size(), 2u);
    EXPECT_NEAR(octree.nodes[0].side, 1e30f, 1e27f);
}

TEST(HierarchyLimits, RefusesASphereWiderThanSinglePrecisionCubesHold) {
    const Scene scene = floor_and(make_sphere(3.4e38f, 16, 8, 0), Affine3f::Identity());
    EXPECT_EQ(refusal(scene),
              "limits.json: mesh 'sphere(radius=3.4e+38, segments=16, rings=8)': it spans "
              "[-3.4e+38, 3.4e+38] along x, beyond what the point hierarchy's single-precision "
              "node cubes hold (coordinates within ±1e+38)");
}

TEST(HierarchyLimits, RefusesAQuadWiderThanSinglePrecisionCubesHold) {
    const Scene scene = floor_and(make_quad(3.4e38f, 3.4e38f, 0), Affine3f::Identity());
    EXPECT_EQ(refusal(scene),
              "limits.json: mesh 'quad(3.4e+38 x 3.4e+38)': it spans [-1.7e+38, 1.7e+38] along "
              "x, beyond what the point hierarchy's single-precision node cubes hold "
              "(coordinates within ±1e+38)");
}

TEST(HierarchyLimits, RefusesInstancesPlacedBeyondSinglePrecisionCubes) {
    // Each mesh fits; the group placing one 3e38 away does not.
    const Scene scene =
        floor_and(make_sphere(1.0f, 16, 8, 0), Affine3f(Eigen::Translation3f(3e38f, 0.0f, 0.0f)));
    EXPECT_EQ(refusal(scene),
              "limits.json: group 'world': it spans [-4, 3e+38] along x, beyond what the point "
              "hierarchy's single-precision node cubes hold (coordinates within ±1e+38)");
}

TEST(HierarchyLimits, RefusesMorePointsThanTheBudget) {
    const Scene scene = floor_and(make_sphere(1.0f, 48, 24, 0), Affine3f::Identity());
    PointOctreeOptions options;
    options.budgets.points = 10;
    // The floor's mesh comes first and is two triangles, kept whole: the sphere's root is the
    // first node to choose points, all of them before any is allocated.
    const std::string message = refusal(scene, options);
    EXPECT_EQ(message.rfind("limits.json: mesh 'sphere(radius=1, segments=48, rings=24)': the "
                            "scene asks for ",
                            0),
              0u)
        << message;
    EXPECT_NE(message.find(" representative points (counted so far), over the limit of 10 "
                           "(raise it with --budget points=N)"),
              std::string::npos)
        << message;
}

TEST(HierarchyLimits, RefusesATreeDeeperThanTheBudget) {
    const Scene scene = floor_and(make_sphere(1.0f, 48, 24, 0), Affine3f::Identity());
    PointOctreeOptions options;
    options.budgets.octree_depth = 1;
    EXPECT_EQ(refusal(scene, options),
              "limits.json: mesh 'sphere(radius=1, segments=48, rings=24)': the scene asks for 2 "
              "octree levels below a root, over the limit of 1 (raise it with --budget "
              "octree-depth=N)");
    options.budgets.octree_depth = 48;
    EXPECT_EQ(refusal(scene, options), "(built)");
}

TEST(HierarchyLimits, RefusesAnInstanceTreeDeeperThanTheBudget) {
    Scene scene = floor_and(make_sphere(1.0f, 8, 4, 0), Affine3f::Identity());
    // 64 spheres on a 4×4×4 lattice, 4 to a leaf: an instance tree 2 levels deep, over
    // meshes whose large triangles all stay in their roots.
    scene.groups[0].children.pop_back();
    for (int i = 0; i < 64; ++i) {
        scene.groups[0].children.push_back(
            {Instance::Kind::Mesh, 1,
             Affine3f(Eigen::Translation3f(3.0f * static_cast<float>(i % 4),
                                           3.0f * static_cast<float>(i / 4 % 4) + 2.0f,
                                           3.0f * static_cast<float>(i / 16)))});
    }
    PointOctreeOptions options;
    options.budgets.octree_depth = 1;
    EXPECT_EQ(refusal(scene, options),
              "limits.json: group 'world': the scene asks for 2 octree levels below a root, over "
              "the limit of 1 (raise it with --budget octree-depth=N)");
}

}  // namespace
}  // namespace mrt
