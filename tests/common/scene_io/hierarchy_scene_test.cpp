// A hierarchy file stands for its scene: load_scene on a .mrh gives back the scene's settings
// exactly and its geometry up to the quantized normals, instanced as the scene file instanced
// it (or flattened), and the tracers render it like the scene file; instanced and flattened
// builds render alike.

#include "common/hierarchy/hierarchy_file.h"
#include "common/image/image_metrics.h"
#include "common/math/quantization.h"
#include "common/mesh/procedural.h"
#include "common/scene_io/scene_loader.h"
#include "common/scene_io/scene_record.h"
#include "common/system/error.h"
#include "preprocess/hierarchy_pack.h"
#include "preprocess/scene_hierarchy.h"
#include "tests/support/test_support.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/raytrace/whitted.h"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

namespace mrt {
namespace {

namespace fs = std::filesystem;

fs::path default_scene() {
    return fs::path(MRT_SOURCE_DIR) / "data" / "scenes" / "two-spheres.json";
}

/// A scene of nested, rotated and non-uniformly scaled instances: plants in a tile, tiles in
/// the world, over a ground; seen from above at an angle.
Scene nested_scene() {
    const std::string json = R"({
      "camera": {"eye": [6, 5, 9], "look_at": [2.5, 0.3, 2.5], "fov": 40,
                 "resolution": [96, 72]},
      "lights": [{"type": "point", "position": [3, 8, 4], "intensity": [60, 60, 60]}],
      "materials": {"stem": {"diffuse": [0.4, 0.25, 0.1]},
                    "leaf": {"diffuse": [0.1, 0.7, 0.2], "specular": [0.2, 0.2, 0.2]},
                    "ground": {"diffuse": [0.7, 0.7, 0.7]}},
      "groups": {
        "tile": {"objects": [
          {"shape": "plant", "seed": 3, "depth": 2, "leaves_per_branch": 4,
           "stem_material": "stem", "leaf_material": "leaf"},
          {"shape": "plant", "seed": 5, "depth": 1, "leaves_per_branch": 6,
           "stem_material": "stem", "leaf_material": "leaf",
           "transform": {"translate": [1.2, 0, 0.4],
                         "rotate": {"axis": [0, 1, 0], "degrees": 70},
                         "scale": [1.3, 0.8, 1.0]}}]}},
      "objects": [
        {"shape": "quad", "size": [7, 7], "material": "ground",
         "transform": {"translate": [2.5, 0, 2.5]}},
        {"instance": "tile"},
        {"instance": "tile", "transform": {"translate": [3, 0, 0],
                                          "rotate": {"axis": [0, 1, 0], "degrees": 120}}},
        {"instance": "tile", "transform": {"translate": [0.5, 0, 3], "scale": [1.5, 1.5, 1.5]}}
      ]
    })";
    return parse_scene(json, fs::path(MRT_SOURCE_DIR) / "nested.json");
}

/// The scene written to `path` as mrt-preprocess writes it, and loaded back by load_scene.
Scene through_file(const Scene& scene, const fs::path& path, Instancing instancing) {
    const SceneHierarchy h = build_scene_hierarchy(scene, nullptr, {}, instancing);
    write_hierarchy_file(path, pack_hierarchy(h, scene.materials, scene_record_json(scene), "{}"));
    return load_scene(path);
}

bool same_bits(float a, float b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}

/// Every triangle of the expanded scenes, as world-space positions and unit normals in the
/// order flatten() lists them.
void expect_same_world(const Scene& read, const Scene& original, bool exact_order) {
    const Mesh a = flatten(read);
    const Mesh b = flatten(original);
    ASSERT_EQ(a.triangles.size(), b.triangles.size());
    if (!exact_order) {
        return;
    }
    for (std::size_t t = 0; t < a.triangles.size(); ++t) {
        ASSERT_EQ(a.materials[t], b.materials[t]) << "triangle " << t;
        for (int i = 0; i < 3; ++i) {
            const Vec3f pa = a.positions[a.triangles[t][static_cast<std::size_t>(i)]];
            const Vec3f pb = b.positions[b.triangles[t][static_cast<std::size_t>(i)]];
            ASSERT_LE((pa - pb).norm(), 1e-5f * (1.0f + pb.norm())) << "triangle " << t;
            const Vec3f na = a.normals[a.triangles[t][static_cast<std::size_t>(i)]];
            const Vec3f nb = b.normals[b.triangles[t][static_cast<std::size_t>(i)]];
            ASSERT_LE(testing::angle_between(na.cast<double>(), nb.cast<double>()),
                      kNormalMaxAngularError + 1e-5)
                << "triangle " << t;
        }
    }
}

TEST(HierarchyScene, GivesBackTheSettingsExactlyAndTheGeometryInstancedAsWritten) {
    const testing::ScratchDirectory scratch("mrt_hierarchy_scene");
    for (const Scene& original : {load_scene(default_scene()), nested_scene()}) {
        const Scene read = through_file(original, scratch.path() / "scene.mrh", Instancing::Keep);
        EXPECT_EQ(read.file, scratch.path() / "scene.mrh");
        EXPECT_TRUE(same_bits(read.camera.vertical_fov, original.camera.vertical_fov));
        EXPECT_EQ(read.camera.eye, original.camera.eye);
        EXPECT_EQ(read.camera.width, original.camera.width);
        ASSERT_EQ(read.materials.size(), original.materials.size());
        for (std::size_t m = 0; m < read.materials.size(); ++m) {
            EXPECT_EQ(read.materials[m].name, original.materials[m].name);
            EXPECT_EQ((read.materials[m].diffuse == original.materials[m].diffuse).all(), true);
            EXPECT_TRUE(same_bits(read.materials[m].ior, original.materials[m].ior));
        }
        EXPECT_EQ(read.point_lights.size(), original.point_lights.size());
        EXPECT_EQ(read.area_lights.size(), original.area_lights.size());
        // Unique geometry once, instanced as often as in the scene.
        EXPECT_EQ(read.unique_triangle_count(), original.unique_triangle_count());
        EXPECT_EQ(read.instanced_triangle_count(), original.instanced_triangle_count());
        expect_same_world(read, original, false);
    }
}

TEST(HierarchyScene, FlattenedFileHoldsTheWorldAsOneMesh) {
    const testing::ScratchDirectory scratch("mrt_hierarchy_scene");
    const Scene original = nested_scene();
    const Scene read = through_file(original, scratch.path() / "flat.mrh", Instancing::Flatten);
    ASSERT_EQ(read.meshes.size(), 1u);
    EXPECT_EQ(read.unique_triangle_count(), original.instanced_triangle_count());
    // The flattened mesh is flatten()'s, vertex for vertex: only the normals are quantized.
    expect_same_world(read, original, true);
}

TEST(HierarchyScene, RendersLikeItsSceneFileInstancedOrFlattened) {
    const testing::ScratchDirectory scratch("mrt_hierarchy_scene");
    for (const Scene& original : {load_scene(default_scene()), nested_scene()}) {
        const auto whitted = [](const Scene& scene) {
            const SceneBvh bvh(scene);
            RenderOptions options = testing::camera_options(scene);
            options.width = 96;
            options.height = 72;
            return render_whitted(scene, bvh, options, {.spp = 4}).image;
        };
        const Image reference = whitted(original);
        const Image instanced =
            whitted(through_file(original, scratch.path() / "i.mrh", Instancing::Keep));
        const Image flattened =
            whitted(through_file(original, scratch.path() / "f.mrh", Instancing::Flatten));
        // Quantized normals (≤ 4.4e-5 rad) move shading by about that much; highlights and
        // mirrored edges a little more (measured: RMSE ≤ 1.1e-4 on both scenes).
        EXPECT_LT(rmse(instanced, reference), 5e-4);
        EXPECT_LT(rmse(flattened, reference), 5e-4);
        EXPECT_LT(rmse(instanced, flattened), 5e-4);
        EXPECT_GT(rmse(reference, Image(reference.width(), reference.height())), 0.05);
    }
}

TEST(HierarchyScene, RefusesATriangleWithAMaterialTheRecordLacks) {
    const testing::ScratchDirectory scratch("mrt_hierarchy_scene");
    Scene scene = nested_scene();
    const SceneHierarchy h = build_scene_hierarchy(scene, nullptr, {});
    HierarchyData data = pack_hierarchy(h, scene.materials, "", "{}");
    scene.materials.pop_back();  // "ground", which the quad uses
    data.scene_json = scene_record_json(scene);
    const fs::path path = scratch.path() / "materials.mrh";
    write_hierarchy_file(path, data);
    const std::string message = testing::error_message([&] { load_scene(path); });
    EXPECT_EQ(message.rfind(path.string() + ": section 'TMAT' record ", 0), 0u) << message;
    EXPECT_NE(message.find("material 2 does not exist (the scene has 2)"), std::string::npos)
        << message;
}

TEST(HierarchyScene, ADamagedFileIsRefusedByTheLoaderWithTheReadersMessage) {
    const testing::ScratchDirectory scratch("mrt_hierarchy_scene");
    const fs::path path = scratch.path() / "short.mrh";
    through_file(nested_scene(), path, Instancing::Keep);
    fs::resize_file(path, fs::file_size(path) / 2);
    const std::string message = testing::error_message([&] { load_scene(path); });
    EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

}  // namespace
}  // namespace mrt
