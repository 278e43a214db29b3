// Looking at a mesh without a scene file: load_scene on a mesh file gives the scene that frames
// it (common/scene_io/mesh_view.h). Asserted: the framing depends on the mesh alone, so the
// same mesh scaled and moved renders the same image; the printed scene (--print-scene) loads
// and renders the same image as the mesh file; every mesh of the shared data can be looked at.

#include "common/scene_io/mesh_view.h"
#include "common/image/image_metrics.h"
#include "common/scene_io/scene_loader.h"
#include "common/system/error.h"
#include "tests/support/test_support.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/raytrace/whitted.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace mrt {
namespace {

namespace fs = std::filesystem;

/// An irregular closed solid (a tetrahedron with a tip pulled out), every vertex scaled by
/// `scale` and moved by `offset`.
void write_solid(const fs::path& file, double scale, const Vec3f& offset) {
    const double v[5][3] = {
        {0, 0, 0}, {1.2, 0, 0.1}, {0.3, 0, 1.0}, {0.5, 1.4, 0.4}, {0.9, 0.6, 0.9}};
    std::ofstream out(file);
    for (const auto& p : v) {
        out << "v " << scale * p[0] + offset.x() << ' ' << scale * p[1] + offset.y() << ' '
            << scale * p[2] + offset.z() << '\n';
    }
    out << "f 1 3 2\nf 1 2 4\nf 2 5 4\nf 2 3 5\nf 3 4 5\nf 1 4 3\n";
}

Image whitted(const Scene& scene, int width, int height) {
    const SceneBvh bvh(scene);
    RenderOptions options = testing::camera_options(scene);
    options.width = width;
    options.height = height;
    return render_whitted(scene, bvh, options, {.spp = 1}).image;
}

/// Whether the image's centre pixel differs from the scene's background: the mesh (or its
/// ground) is in view there.
bool centre_sees_something(const Scene& scene, const Image& image) {
    const Rgb centre = image.at(image.width() / 2, image.height() / 2);
    return (centre - scene.background).abs().maxCoeff() > 1e-3f;
}

TEST(MeshView, RecognisesMeshFilesByTheirExtensionInAnyCase) {
    for (const char* name : {"a.obj", "b.PLY", "dir/c.off", "d.Stl"}) {
        EXPECT_TRUE(is_mesh_file(name)) << name;
    }
    for (const char* name : {"a.json", "b.mrh", "c", "d.obj.txt", "e.mtl"}) {
        EXPECT_FALSE(is_mesh_file(name)) << name;
    }
}

TEST(MeshView, FramesTheSameMeshAtAnyScaleAndPositionAlike) {
    const testing::ScratchDirectory scratch("mrt_mesh_view");
    write_solid(scratch.path() / "unit.obj", 1.0, Vec3f::Zero());
    write_solid(scratch.path() / "moved.obj", 37.0, Vec3f(100.0f, -5.0f, 20.0f));
    const Scene unit = load_scene(scratch.path() / "unit.obj");
    const Scene moved = load_scene(scratch.path() / "moved.obj");
    const Image a = whitted(unit, 48, 36);
    const Image b = whitted(moved, 48, 36);
    EXPECT_TRUE(centre_sees_something(unit, a));
    // Every length of the scene is a multiple of the bounding radius: the images differ only by
    // rounding (measured about 1e-6).
    EXPECT_LT(rmse(a, b), 1e-4);
    // And the mesh is in them: without it the image differs.
    Json without = mesh_view_scene(scratch.path() / "unit.obj");
    without["objects"].erase(without["objects"].begin());
    const Scene ground_only = parse_scene(without.dump(), scratch.path() / "ground.json");
    EXPECT_GT(rmse(a, whitted(ground_only, 48, 36)), 0.01);
}

TEST(MeshView, PrintedSceneLoadsAndRendersTheSameImage) {
    const testing::ScratchDirectory scratch("mrt_mesh_view");
    write_solid(scratch.path() / "solid.obj", 2.0, Vec3f(1.0f, 2.0f, 3.0f));
    const std::string printed = printable_scene(scratch.path() / "solid.obj");
    fs::create_directories(scratch.path() / "elsewhere");
    const fs::path saved = scratch.path() / "elsewhere" / "solid.json";
    std::ofstream(saved) << printed;
    const Scene from_mesh = load_scene(scratch.path() / "solid.obj");
    const Scene from_json = load_scene(saved);
    const Image a = whitted(from_mesh, 40, 30);
    const Image b = whitted(from_json, 40, 30);
    EXPECT_EQ(rmse(a, b), 0.0);
    EXPECT_EQ(from_json.camera.width, 640);
    EXPECT_EQ(from_json.camera.height, 480);
    // A scene file prints as its own JSON, which loads to the same scene again.
    const fs::path again = scratch.path() / "again.json";
    std::ofstream(again) << printable_scene(saved);
    EXPECT_EQ(rmse(whitted(load_scene(again), 40, 30), b), 0.0);
}

TEST(MeshView, EveryMeshOfTheSharedDataCanBeLookedAt) {
    const auto bunny = testing::find_data_file("meshes/stanford-bunny.obj");
    ASSERT_TRUE(bunny.has_value()) << "meshes/stanford-bunny.obj not on the data search path";
    const testing::ScratchDirectory scratch("mrt_mesh_view");
    std::vector<fs::path> meshes;
    for (const auto& entry : fs::recursive_directory_iterator(bunny->parent_path())) {
        if (entry.is_regular_file() && is_mesh_file(entry.path())) {
            meshes.push_back(entry.path());
        }
    }
    EXPECT_GE(meshes.size(), 5u);
    for (const fs::path& mesh : meshes) {
        SCOPED_TRACE(mesh.string());
        const Scene scene = load_scene(mesh);
        const Image image = whitted(scene, 32, 24);
        EXPECT_TRUE(centre_sees_something(scene, image));
        const fs::path saved = scratch.path() / (mesh.stem().string() + ".json");
        std::ofstream(saved) << printable_scene(mesh);
        EXPECT_EQ(rmse(whitted(load_scene(saved), 32, 24), image), 0.0);
    }
}

TEST(MeshView, AMissingMeshNamesEveryPlaceItWasLookedFor) {
    try {
        load_scene("meshes/no-such-mesh.obj");
        FAIL() << "expected an error";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("meshes/no-such-mesh.obj"), std::string::npos) << message;
        EXPECT_NE(message.find("mesh file not found (looked in: "), std::string::npos) << message;
    }
    try {
        printable_scene(fs::path(MRT_SOURCE_DIR) / "data" / "no-such-scene.json");
        FAIL() << "expected an error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("scene file not found"), std::string::npos);
    }
}

}  // namespace
}  // namespace mrt
