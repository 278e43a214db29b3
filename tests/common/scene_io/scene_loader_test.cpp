#include "common/scene_io/scene_loader.h"
#include "common/math/invertibility.h"
#include "common/mesh/procedural.h"
#include "common/scene/scene.h"
#include "common/scene/scene_json.h"
#include "common/scene_io/data_path.h"
#include "common/system/error.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace mrt {
namespace {

namespace fs = std::filesystem;

constexpr float kTolerance = 1e-5f;
constexpr float kDegree = std::numbers::pi_v<float> / 180.0f;

fs::path test_data_dir() {
    return fs::path(MRT_SOURCE_DIR) / "tests" / "data" / "scene";
}

/// A fresh directory under the system temp directory, removed with everything in it.
class TempDir {
  public:
    TempDir() {
        std::random_device random;
        const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
        m_path = fs::temp_directory_path() /
                 ("mrt_scene_test_" + std::string(test ? test->name() : "x") + "_" +
                  std::to_string(random()));
        fs::create_directories(m_path);
    }
    ~TempDir() {
        std::error_code error;
        fs::remove_all(m_path, error);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    const fs::path& path() const { return m_path; }

    /// Writes `text` to the relative path `name`, creating directories; returns the full path.
    fs::path write(const fs::path& name, const std::string& text) const {
        const fs::path file = m_path / name;
        fs::create_directories(file.parent_path());
        std::ofstream(file, std::ios::binary) << text;
        return file;
    }

  private:
    fs::path m_path;
};

/// Sets MRT_DATA for the lifetime of the object, restoring the previous value afterwards.
class ScopedDataPath {
  public:
    explicit ScopedDataPath(const std::string& value) {
        if (const char* old = std::getenv("MRT_DATA")) {
            m_old = old;
        }
        setenv("MRT_DATA", value.c_str(), 1);
    }
    ~ScopedDataPath() {
        if (m_old) {
            setenv("MRT_DATA", m_old->c_str(), 1);
        } else {
            unsetenv("MRT_DATA");
        }
    }
    ScopedDataPath(const ScopedDataPath&) = delete;
    ScopedDataPath& operator=(const ScopedDataPath&) = delete;

  private:
    std::optional<std::string> m_old;
};

const std::string kTetrahedronObj =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
const std::string kTriangleObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// A valid scene assembled from parts; a part set empty is left out of the document.
class SceneParts {
  public:
    SceneParts& camera(std::string v) { return set(m_camera, std::move(v)); }
    SceneParts& materials(std::string v) { return set(m_materials, std::move(v)); }
    SceneParts& lights(std::string v) { return set(m_lights, std::move(v)); }
    SceneParts& groups(std::string v) { return set(m_groups, std::move(v)); }
    SceneParts& objects(std::string v) { return set(m_objects, std::move(v)); }
    /// Further top-level members, written as is.
    SceneParts& extra(std::string v) { return set(m_extra, std::move(v)); }

    std::string json() const {
        std::string out = "{";
        const auto add = [&out](const std::string& key, const std::string& value) {
            if (!value.empty()) {
                out += (out.size() > 1 ? ", \"" : "\"") + key + "\": " + value;
            }
        };
        add("camera", m_camera);
        add("materials", m_materials);
        add("lights", m_lights);
        add("groups", m_groups);
        add("objects", m_objects);
        if (!m_extra.empty()) {
            out += ", " + m_extra;
        }
        return out + "}";
    }

  private:
    SceneParts& set(std::string& part, std::string value) {
        part = std::move(value);
        return *this;
    }

    std::string m_camera = R"({"eye": [0, 0, 5], "look_at": [0, 0, 0]})";
    std::string m_materials =
        R"({"red": {"diffuse": [0.8, 0.1, 0.1]}, "glass": {"transparency": 0.9}})";
    std::string m_lights;
    std::string m_groups;
    std::string m_objects = R"([{"shape": "quad", "material": "red"}])";
    std::string m_extra;
};

Scene parse(const std::string& json, const SceneLoadOptions& options = {}) {
    return parse_scene(json, "scene.json", options);
}

/// The message of the Error parsing throws, or a note that nothing was thrown.
std::string error_of(const std::string& json, const fs::path& file = "scene.json") {
    try {
        parse_scene(json, file);
    } catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

Vec3f world_point(const Scene& scene, std::size_t child, const Vec3f& p) {
    return scene.groups[scene.root].children.at(child).transform * p;
}

void expect_near(const Vec3f& actual, const Vec3f& expected, float tolerance = kTolerance) {
    EXPECT_TRUE((actual - expected).norm() <= tolerance)
        << "actual (" << actual.transpose() << "), expected (" << expected.transpose() << ")";
}

void expect_near(const Rgb& actual, const Rgb& expected) {
    EXPECT_TRUE(((actual - expected).abs() <= kTolerance * (1.0f + expected.abs())).all())
        << "actual (" << actual.transpose() << "), expected (" << expected.transpose() << ")";
}

// ---- Values parse into the right places ------------------------------------------------------

TEST(SceneLoader, ParsesCameraWithFovInDegrees) {
    const Scene scene = parse(SceneParts()
                                  .camera(R"({"eye": [1, 2, 3], "look_at": [1, 2, 0],
        "up": [0, 0.5, 0], "fov": 40, "resolution": [640, 480], "aperture_radius": 0.1,
        "focal_distance": 2.5, "pixel_aspect": 1.5})")
                                  .json());
    const Camera& c = scene.camera;
    expect_near(c.eye, {1, 2, 3});
    expect_near(c.look_at, {1, 2, 0});
    expect_near(c.up, {0, 0.5f, 0});
    EXPECT_NEAR(c.vertical_fov, 40.0f * kDegree, 1e-6f);
    EXPECT_EQ(c.width, 640);
    EXPECT_EQ(c.height, 480);
    EXPECT_FLOAT_EQ(c.aperture_radius, 0.1f);
    EXPECT_FLOAT_EQ(c.focal_distance, 2.5f);
    EXPECT_FLOAT_EQ(c.pixel_aspect, 1.5f);
}

TEST(SceneLoader, CameraDefaultsFocusOnLookAtWithA45DegreeFov) {
    const Scene scene =
        parse(SceneParts().camera(R"({"eye": [0, 0, 0], "look_at": [3, 4, 0]})").json());
    const Camera& c = scene.camera;
    EXPECT_FLOAT_EQ(c.focal_distance, 5.0f);
    EXPECT_NEAR(c.vertical_fov, 45.0f * kDegree, 1e-6f);
    expect_near(c.up, {0, 1, 0});
    EXPECT_EQ(c.width, 512);
    EXPECT_EQ(c.height, 512);
    EXPECT_EQ(c.aperture_radius, 0.0f);
    EXPECT_EQ(c.pixel_aspect, 1.0f);
}

TEST(SceneLoader, ParsesBackgroundAmbientAndMaxDepthWithGreyShorthand) {
    const Scene scene = parse(SceneParts()
                                  .extra(R"("background": [0.1, 0.2, 0.3], "ambient": 0.25,
                                     "max_depth": 3)")
                                  .json());
    expect_near(scene.background, Rgb(0.1f, 0.2f, 0.3f));
    expect_near(scene.ambient, Rgb(0.25f, 0.25f, 0.25f));
    EXPECT_EQ(scene.max_depth, 3);
}

TEST(SceneLoader, SceneDefaultsAreBlackWithEightBounces) {
    const Scene scene = parse(SceneParts().json());
    expect_near(scene.background, Rgb::Zero());
    expect_near(scene.ambient, Rgb::Zero());
    EXPECT_EQ(scene.max_depth, 8);
    EXPECT_TRUE(scene.point_lights.empty());
    EXPECT_TRUE(scene.area_lights.empty());
    EXPECT_EQ(scene.file, fs::path("scene.json"));
}

TEST(SceneLoader, MaterialsKeepTheirNamesInDocumentOrder) {
    const Scene scene = parse(SceneParts()
                                  .materials(R"({
        "zeta": {"diffuse": [0.1, 0.2, 0.3], "specular": 0.5, "phong_exponent": 100,
                 "reflectivity": 0.25, "transparency": 0.75, "ior": 1.33, "roughness": 0.2},
        "alpha": {}})")
                                  .objects(R"([{"shape": "quad", "material": "alpha"}])")
                                  .json());
    ASSERT_EQ(scene.materials.size(), 2u);
    const Material& zeta = scene.materials[0];
    EXPECT_EQ(zeta.name, "zeta");
    expect_near(zeta.diffuse, Rgb(0.1f, 0.2f, 0.3f));
    expect_near(zeta.specular, Rgb(0.5f, 0.5f, 0.5f));
    EXPECT_FLOAT_EQ(zeta.phong_exponent, 100.0f);
    EXPECT_FLOAT_EQ(zeta.reflectivity, 0.25f);
    EXPECT_FLOAT_EQ(zeta.transparency, 0.75f);
    EXPECT_FLOAT_EQ(zeta.ior, 1.33f);
    EXPECT_FLOAT_EQ(zeta.roughness, 0.2f);
    EXPECT_EQ(zeta.texture, -1);

    const Material& alpha = scene.materials[1];
    const Material defaults;
    EXPECT_EQ(alpha.name, "alpha");
    expect_near(alpha.diffuse, defaults.diffuse);
    expect_near(alpha.specular, defaults.specular);
    EXPECT_EQ(alpha.phong_exponent, defaults.phong_exponent);
    EXPECT_EQ(alpha.ior, defaults.ior);
    // The quad refers to "alpha", the second material.
    const Mesh& quad = scene.meshes.at(scene.groups[scene.root].children.at(0).index);
    for (const std::uint32_t m : quad.materials) {
        EXPECT_EQ(m, 1u);
    }
}

TEST(SceneLoader, TexturesAreSharedByResolvedPathAndCarryTheirUvTransform) {
    TempDir dir;
    dir.write("textures/wood.png", "not decoded by the loader");
    const fs::path scene_file = dir.path() / "scene.json";
    const Scene scene = parse_scene(SceneParts()
                                        .materials(R"({
        "a": {"texture": {"file": "textures/wood.png", "uv_scale": 2, "uv_rotate": 90,
                          "uv_offset": [0.5, 0.25]}},
        "b": {"texture": {"file": "./textures/../textures/wood.png"}},
        "c": {"texture": {"file": "textures/wood.png", "srgb": false, "uv_scale": [1, 3]}},
        "d": {}})")
                                        .objects("[]")
                                        .json(),
                                    scene_file);
    ASSERT_EQ(scene.textures.size(), 2u);
    EXPECT_EQ(scene.materials[0].texture, 0);
    EXPECT_EQ(scene.materials[1].texture, 0);
    EXPECT_EQ(scene.materials[2].texture, 1);
    EXPECT_EQ(scene.materials[3].texture, -1);
    EXPECT_TRUE(scene.textures[0].srgb);
    EXPECT_FALSE(scene.textures[1].srgb);
    EXPECT_TRUE(scene.textures[0].path.is_absolute());
    EXPECT_TRUE(fs::equivalent(scene.textures[0].path, dir.path() / "textures/wood.png"));

    // uv' = translate(0.5, 0.25) · rotate(90°) · scale(2): (1, 0) → (2, 0) → (0, 2) → (0.5, 2.25).
    const Vec2f uv = scene.materials[0].uv_transform * Vec2f(1.0f, 0.0f);
    EXPECT_NEAR(uv.x(), 0.5f, kTolerance);
    EXPECT_NEAR(uv.y(), 2.25f, kTolerance);
    const Vec2f uv_c = scene.materials[2].uv_transform * Vec2f(1.0f, 1.0f);
    EXPECT_NEAR(uv_c.x(), 1.0f, kTolerance);
    EXPECT_NEAR(uv_c.y(), 3.0f, kTolerance);
    EXPECT_TRUE(scene.materials[1].uv_transform.matrix().isIdentity());
}

TEST(SceneLoader, PointLightPowerIsSpreadOverFourPiSteradians) {
    const Scene scene = parse(SceneParts()
                                  .lights(R"([
        {"type": "point", "position": [1, 2, 3], "intensity": [1, 2, 3]},
        {"type": "point", "position": [0, 0, 0], "power": [4, 8, 12]}])")
                                  .json());
    ASSERT_EQ(scene.point_lights.size(), 2u);
    expect_near(scene.point_lights[0].position, {1, 2, 3});
    expect_near(scene.point_lights[0].intensity, Rgb(1, 2, 3));
    const float pi = std::numbers::pi_v<float>;
    expect_near(scene.point_lights[1].intensity, Rgb(4, 8, 12) / (4.0f * pi));
}

TEST(SceneLoader, EllipseLightPowerBecomesRadianceOverAreaAndFaces) {
    const Scene scene = parse(SceneParts()
                                  .lights(R"([
        {"type": "ellipse", "center": [0, 3, 0], "semi_axis_u": [2, 0, 0],
         "semi_axis_v": [0, 0, 1], "radiance": 7},
        {"type": "ellipse", "center": [0, 3, 0], "semi_axis_u": [2, 0, 0],
         "semi_axis_v": [0, 0, 1], "power": 10},
        {"type": "ellipse", "center": [0, 3, 0], "semi_axis_u": [2, 0, 0],
         "semi_axis_v": [0, 0, 1], "power": 10, "two_sided": true}])")
                                  .json());
    ASSERT_EQ(scene.area_lights.size(), 3u);
    const EllipticalAreaLight& light = scene.area_lights[0];
    expect_near(light.center, {0, 3, 0});
    expect_near(light.semi_axis_u, {2, 0, 0});
    expect_near(light.semi_axis_v, {0, 0, 1});
    EXPECT_FALSE(light.two_sided);
    expect_near(light.radiance, Rgb::Constant(7.0f));
    // Area π·|u×v| = 2π; one face: L = Φ / (π · 2π).
    const float pi = std::numbers::pi_v<float>;
    expect_near(scene.area_lights[1].radiance, Rgb::Constant(10.0f / (pi * 2.0f * pi)));
    EXPECT_TRUE(scene.area_lights[2].two_sided);
    expect_near(scene.area_lights[2].radiance, Rgb::Constant(10.0f / (2.0f * pi * 2.0f * pi)));
}

TEST(SceneLoader, TransformComposesTranslateRotateScale) {
    const Scene scene = parse(SceneParts()
                                  .objects(R"([{"shape": "quad", "material": "red",
        "transform": {"translate": [1, 2, 3], "rotate": {"axis": [0, 0, 5], "degrees": 90},
                      "scale": 2}}])")
                                  .json());
    // (1,0,0) → scale (2,0,0) → rotate 90° about z (0,2,0) → translate (1,4,3).
    expect_near(world_point(scene, 0, {1, 0, 0}), {1, 4, 3});
    // Key order in the object does not matter: the composition is always T·R·S.
    const Scene reordered = parse(SceneParts()
                                      .objects(R"([{"shape": "quad", "material": "red",
        "transform": {"scale": 2, "rotate": {"axis": [0, 0, 1], "degrees": 90},
                      "translate": [1, 2, 3]}}])")
                                      .json());
    expect_near(world_point(reordered, 0, {1, 0, 0}), {1, 4, 3});
}

TEST(SceneLoader, NonUniformScaleScalesEachAxis) {
    const Scene scene = parse(SceneParts()
                                  .objects(R"([{"shape": "quad", "material": "red",
        "transform": {"scale": [2, 3, -4]}}])")
                                  .json());
    expect_near(world_point(scene, 0, {1, 1, 1}), {2, 3, -4});
}

TEST(SceneLoader, RotationArrayIsAppliedInOrder) {
    const Scene scene = parse(SceneParts()
                                  .objects(R"([{"shape": "quad", "material": "red",
        "transform": {"rotate": [{"axis": [1, 0, 0], "degrees": 90},
                                 {"axis": [0, 1, 0], "degrees": 90}]}}])")
                                  .json());
    // (0,1,0) → 90° about x → (0,0,1) → 90° about y → (1,0,0). The other order gives (0,0,1).
    expect_near(world_point(scene, 0, {0, 1, 0}), {1, 0, 0});
}

TEST(SceneLoader, TransformArrayAppliesItsFirstElementFirst) {
    const Scene scene = parse(SceneParts()
                                  .objects(R"([{"shape": "quad", "material": "red",
        "transform": [{"translate": [1, 0, 0]}, {"scale": 2},
                      {"rotate": {"axis": [0, 1, 0], "degrees": -90}}]}])")
                                  .json());
    // (0,0,0) → (1,0,0) → (2,0,0) → −90° about y → (0,0,2).
    expect_near(world_point(scene, 0, {0, 0, 0}), {0, 0, 2});
}

TEST(SceneLoader, MatrixTransformIsRowMajor) {
    const Scene scene = parse(SceneParts()
                                  .objects(R"([{"shape": "quad", "material": "red",
        "transform": {"matrix": [0, -1, 0, 5,
                                 1,  0, 0, 6,
                                 0,  0, 2, 7,
                                 0,  0, 0, 1]}}])")
                                  .json());
    expect_near(world_point(scene, 0, {1, 0, 0}), {5, 7, 7});
    expect_near(world_point(scene, 0, {0, 0, 1}), {5, 6, 9});
}

TEST(SceneLoader, ObjectsAndGroupsBecomeInstancesOfGroups) {
    const Scene scene = parse(SceneParts()
                                  .groups(R"({
        "pair": {"objects": [{"shape": "quad", "material": "red"},
                             {"shape": "quad", "material": "red",
                              "transform": {"translate": [0, 1, 0]}}]},
        "quartet": {"objects": [{"instance": "pair"},
                                {"instance": "pair", "transform": {"translate": [2, 0, 0]}}]},
        "unused": {"objects": []}})")
                                  .objects(R"([
        {"instance": "quartet", "transform": {"scale": 3}},
        {"shape": "sphere", "material": "glass", "segments": 8, "rings": 4}])")
                                  .json());
    ASSERT_EQ(scene.groups.size(), 4u);
    EXPECT_EQ(scene.root, 0u);
    EXPECT_EQ(scene.groups[1].name, "pair");
    EXPECT_EQ(scene.groups[2].name, "quartet");
    EXPECT_EQ(scene.groups[3].name, "unused");

    const Group& world = scene.groups[scene.root];
    ASSERT_EQ(world.children.size(), 2u);
    EXPECT_EQ(world.children[0].kind, Instance::Kind::Group);
    EXPECT_EQ(world.children[0].index, 2u);
    expect_near(world.children[0].transform * Vec3f(1, 1, 1), {3, 3, 3});
    EXPECT_EQ(world.children[1].kind, Instance::Kind::Mesh);

    const Group& quartet = scene.groups[2];
    ASSERT_EQ(quartet.children.size(), 2u);
    for (const Instance& child : quartet.children) {
        EXPECT_EQ(child.kind, Instance::Kind::Group);
        EXPECT_EQ(child.index, 1u);
    }
    // The two identical quads of "pair" share one mesh; the sphere is a second one.
    const Group& pair = scene.groups[1];
    ASSERT_EQ(pair.children.size(), 2u);
    EXPECT_EQ(pair.children[0].index, pair.children[1].index);
    EXPECT_EQ(scene.meshes.size(), 2u);

    const std::uint64_t quad = scene.meshes[pair.children[0].index].triangle_count();
    const std::uint64_t sphere = scene.meshes[world.children[1].index].triangle_count();
    EXPECT_GT(quad, 0u);
    EXPECT_EQ(scene.unique_triangle_count(), quad + sphere);
    EXPECT_EQ(scene.instanced_triangle_count(), 4 * quad + sphere);
}

TEST(SceneLoader, GroupsMayInstanceGroupsDefinedLater) {
    const Scene scene = parse(SceneParts()
                                  .groups(R"({
        "outer": {"objects": [{"instance": "inner"}]},
        "inner": {"objects": [{"shape": "quad", "material": "red"}]}})")
                                  .objects(R"([{"instance": "outer"}])")
                                  .json());
    EXPECT_EQ(scene.groups[1].children.at(0).index, 2u);
}

TEST(SceneLoader, SameProceduralShapeAndMaterialShareOneMesh) {
    const Scene scene = parse(SceneParts()
                                  .objects(R"([
        {"shape": "sphere", "radius": 2, "segments": 6, "rings": 3, "material": "red"},
        {"shape": "sphere", "radius": 2, "segments": 6, "rings": 3, "material": "red",
         "transform": {"translate": [5, 0, 0]}},
        {"shape": "sphere", "radius": 2, "segments": 6, "rings": 3, "material": "glass"},
        {"shape": "sphere", "radius": 1, "segments": 6, "rings": 3, "material": "red"},
        {"shape": "checkerboard", "size": [4, 2], "tiles": [4, 2], "materials": ["red", "glass"]},
        {"shape": "checkerboard", "size": [4, 2], "tiles": [4, 2], "materials": ["red", "glass"]},
        {"shape": "checkerboard", "size": [4, 2], "tiles": [4, 2], "materials": ["glass", "red"]}
        ])")
                                  .json());
    const auto& children = scene.groups[scene.root].children;
    ASSERT_EQ(children.size(), 7u);
    EXPECT_EQ(children[0].index, children[1].index);
    EXPECT_NE(children[0].index, children[2].index);
    EXPECT_NE(children[0].index, children[3].index);
    EXPECT_EQ(children[4].index, children[5].index);
    EXPECT_NE(children[4].index, children[6].index);
    EXPECT_EQ(scene.meshes.size(), 5u);
    for (const std::uint32_t m : scene.meshes[children[2].index].materials) {
        EXPECT_EQ(m, 1u);  // glass
    }
    // The checkerboard alternates its two materials.
    const Mesh& board = scene.meshes[children[4].index];
    EXPECT_EQ(board.triangle_count(), 2u * 4u * 2u);
    EXPECT_NE(std::find(board.materials.begin(), board.materials.end(), 0u), board.materials.end());
    EXPECT_NE(std::find(board.materials.begin(), board.materials.end(), 1u), board.materials.end());
}

TEST(SceneLoader, PlantIsMakePlantWithTheSameParameters) {
    const Scene scene = parse(SceneParts()
                                  .objects(R"([
        {"shape": "plant", "seed": 7, "depth": 2, "leaves_per_branch": 5,
         "stem_material": "glass", "leaf_material": "red"},
        {"shape": "plant", "seed": 7, "depth": 2, "leaves_per_branch": 5,
         "stem_material": "glass", "leaf_material": "red", "transform": {"translate": [2, 0, 0]}},
        {"shape": "plant", "seed": 8, "depth": 2, "leaves_per_branch": 5,
         "stem_material": "glass", "leaf_material": "red"}])")
                                  .json());
    const auto& children = scene.groups[scene.root].children;
    ASSERT_EQ(children.size(), 3u);
    EXPECT_EQ(children[0].index, children[1].index);
    EXPECT_NE(children[0].index, children[2].index);
    ASSERT_EQ(scene.meshes.size(), 2u);
    // Materials in file order: red is 0, glass is 1.
    const Mesh expected = make_plant(7, 2, 5, 1, 0);
    const Mesh& plant = scene.meshes[children[0].index];
    // (3^3 − 1)/2 = 13 branches of 4 segments × 6 sides × 2 triangles and two caps of 6, and
    // 5 leaves of 8 each.
    EXPECT_EQ(expected.triangle_count(), 13u * (60u + 5u * 8u));
    EXPECT_EQ(plant.triangle_count(), expected.triangle_count());
    EXPECT_EQ(plant.positions, expected.positions);
    EXPECT_EQ(plant.materials, expected.materials);
    EXPECT_NE(std::find(plant.materials.begin(), plant.materials.end(), 0u), plant.materials.end());
    EXPECT_NE(std::find(plant.materials.begin(), plant.materials.end(), 1u), plant.materials.end());
    EXPECT_EQ(scene.meshes[children[2].index].triangle_count(), expected.triangle_count());
    EXPECT_NE(scene.meshes[children[2].index].positions, expected.positions);
}

TEST(SceneLoader, PlantDefaultsToSeedZeroDepthThreeAndSixLeavesPerBranch) {
    const Scene scene = parse(SceneParts()
                                  .objects(R"([
        {"shape": "plant", "stem_material": "red", "leaf_material": "glass"}])")
                                  .json());
    ASSERT_EQ(scene.meshes.size(), 1u);
    const Mesh expected = make_plant(0, 3, 6, 0, 1);
    EXPECT_EQ(scene.meshes[0].triangle_count(), 40u * (60u + 6u * 8u));
    EXPECT_EQ(scene.meshes[0].triangle_count(), expected.triangle_count());
    EXPECT_EQ(scene.meshes[0].positions, expected.positions);
}

TEST(SceneLoader, SameMeshFileIsLoadedOnceAndInstanced) {
    TempDir dir;
    dir.write("meshes/tetra.obj", kTetrahedronObj);
    const Scene scene = parse_scene(SceneParts()
                                        .objects(R"([
        {"shape": "mesh", "file": "meshes/tetra.obj", "material": "red"},
        {"shape": "mesh", "file": "meshes/tetra.obj", "material": "red",
         "transform": {"translate": [3, 0, 0]}},
        {"shape": "mesh", "file": "meshes/../meshes/tetra.obj", "material": "red"},
        {"shape": "mesh", "file": "meshes/tetra.obj", "material": "glass"}])")
                                        .json(),
                                    dir.path() / "scene.json");
    const auto& children = scene.groups[scene.root].children;
    ASSERT_EQ(children.size(), 4u);
    // One mesh per (file, material): the red copies share, the glass one is its own mesh.
    ASSERT_EQ(scene.meshes.size(), 2u);
    EXPECT_EQ(children[0].index, children[1].index);
    EXPECT_EQ(children[0].index, children[2].index);
    EXPECT_NE(children[0].index, children[3].index);
    const Mesh& red = scene.meshes[children[0].index];
    const Mesh& glass = scene.meshes[children[3].index];
    EXPECT_EQ(red.triangle_count(), 4u);
    EXPECT_EQ(glass.triangle_count(), 4u);
    EXPECT_EQ(red.materials, std::vector<std::uint32_t>(4, 0u));
    EXPECT_EQ(glass.materials, std::vector<std::uint32_t>(4, 1u));
    EXPECT_EQ(scene.unique_triangle_count(), 8u);
    EXPECT_EQ(scene.instanced_triangle_count(), 16u);
}

TEST(SceneLoader, LoadsTheDocumentedExampleWithEveryFeature) {
    const ScopedDataPath data(MRT_TEST_DATA_DIRS);
    std::vector<std::string> warnings;
    const Scene scene =
        load_scene(test_data_dir() / "all_features.json",
                   {.warn = [&](const std::string& w) { warnings.push_back(w); }, .budgets = {}});
    EXPECT_TRUE(warnings.empty());
    EXPECT_EQ(scene.camera.width, 640);
    EXPECT_EQ(scene.max_depth, 6);
    EXPECT_EQ(scene.materials.size(), 6u);
    EXPECT_EQ(scene.textures.size(), 1u);
    EXPECT_EQ(scene.point_lights.size(), 2u);
    EXPECT_EQ(scene.area_lights.size(), 2u);
    ASSERT_EQ(scene.groups.size(), 3u);
    EXPECT_EQ(scene.groups[scene.root].children.size(), 8u);
    // checkerboard, tetrahedron (shared by two objects), sphere, textured quad, procedural plant,
    // the plant group's sphere, leaf quad.
    EXPECT_EQ(scene.meshes.size(), 7u);
    EXPECT_GT(scene.instanced_triangle_count(), scene.unique_triangle_count());
}

/// Meshes of a loaded scene that make_plant made (it names them "plant(seed=…").
std::size_t plant_mesh_count(const Scene& scene) {
    return static_cast<std::size_t>(
        std::count_if(scene.meshes.begin(), scene.meshes.end(),
                      [](const Mesh& mesh) { return mesh.name.rfind("plant(", 0) == 0; }));
}

// data/scenes/field.json, from scripts/make-field: the paper's Figure 7 scene (Wand & Straßer
// 2003 give 110 231 unique and 8.7 M instanced triangles).
TEST(SceneLoader, FieldSceneHasThePapersUniqueAndInstancedTriangleCounts) {
    const ScopedDataPath data(MRT_TEST_DATA_DIRS);
    const Scene scene = load_scene(fs::path(MRT_SOURCE_DIR) / "data" / "scenes" / "field.json");
    // In the test's XML report (--gtest_output=xml), for docs and benchmarks.
    RecordProperty("unique_triangles", std::to_string(scene.unique_triangle_count()));
    RecordProperty("instanced_triangles", std::to_string(scene.instanced_triangle_count()));
    EXPECT_GE(scene.instanced_triangle_count(), 8'700'000u);
    EXPECT_NEAR(static_cast<double>(scene.unique_triangle_count()), 110'231.0, 11'023.0);
    EXPECT_GE(plant_mesh_count(scene), 3u);
    EXPECT_EQ(scene.camera.width, 640);
    EXPECT_EQ(scene.camera.height, 480);
    EXPECT_EQ(scene.area_lights.size(), 1u);
}

TEST(SceneLoader, ScaledUpFieldSceneInstancesTheSameGeometryPast100MTriangles) {
    const ScopedDataPath data(MRT_TEST_DATA_DIRS);
    const fs::path scenes = fs::path(MRT_SOURCE_DIR) / "data" / "scenes";
    const Scene field = load_scene(scenes / "field.json");
    const Scene scaled = load_scene(scenes / "field-100m.json");
    RecordProperty("instanced_triangles", std::to_string(scaled.instanced_triangle_count()));
    EXPECT_GE(scaled.instanced_triangle_count(), 100'000'000u);
    EXPECT_EQ(scaled.unique_triangle_count(), field.unique_triangle_count());
    EXPECT_EQ(scaled.meshes.size(), field.meshes.size());
}

// data/scenes/effects-*.json, from scripts/make-effects: the paper's Figure 8 effects, 512²,
// each under one elliptical light.
TEST(SceneLoader, EffectsScenesHoldTheirEffects) {
    const fs::path scenes = fs::path(MRT_SOURCE_DIR) / "data" / "scenes";
    for (const char* name :
         {"effects-soft-shadows.json", "effects-depth-of-field.json", "effects-glossy.json"}) {
        const Scene scene = load_scene(scenes / name);
        EXPECT_EQ(scene.camera.width, 512) << name;
        EXPECT_EQ(scene.camera.height, 512) << name;
        EXPECT_EQ(scene.area_lights.size(), 1u) << name;
    }
    EXPECT_GE(plant_mesh_count(load_scene(scenes / "effects-soft-shadows.json")), 1u);
    const Scene dof = load_scene(scenes / "effects-depth-of-field.json");
    EXPECT_GT(dof.camera.aperture_radius, 0.0f);
    EXPECT_GT(dof.camera.focal_distance, 0.0f);
    std::vector<float> roughness;
    for (const Material& m : load_scene(scenes / "effects-glossy.json").materials) {
        if (m.reflectivity > 0.0f) {
            roughness.push_back(m.roughness);
        }
    }
    std::sort(roughness.begin(), roughness.end());
    EXPECT_EQ(roughness, (std::vector<float>{0.03f, 0.1f, 0.25f}));
}

// ---- Paths -----------------------------------------------------------------------------------

TEST(DataPath, SearchPathIsMrtDataEntriesThenSharedDataThenData) {
    const ScopedDataPath data("/first::relative/second:");
    const std::vector<fs::path> expected{"/first", "relative/second", "../shared/data", "data"};
    EXPECT_EQ(data_search_path(), expected);
}

TEST(DataPath, ResolvesRelativeToTheSceneDirectoryBeforeTheSearchPath) {
    TempDir dir;
    const fs::path local = dir.write("scene/meshes/m.obj", kTriangleObj);
    const fs::path shared = dir.write("shared/meshes/m.obj", kTriangleObj);
    const fs::path other = dir.write("shared/meshes/other.obj", kTriangleObj);
    const ScopedDataPath data((dir.path() / "nowhere").string() + ":" +
                              (dir.path() / "shared").string());

    const auto found_local = resolve_data_file("meshes/m.obj", dir.path() / "scene");
    ASSERT_TRUE(found_local);
    EXPECT_TRUE(fs::equivalent(*found_local, local));
    EXPECT_TRUE(found_local->is_absolute());

    const auto found_shared = resolve_data_file("meshes/other.obj", dir.path() / "scene");
    ASSERT_TRUE(found_shared);
    EXPECT_TRUE(fs::equivalent(*found_shared, other));

    EXPECT_FALSE(resolve_data_file("meshes/missing.obj", dir.path() / "scene"));
    EXPECT_FALSE(resolve_data_file("", dir.path() / "scene"));
    // A directory is not a data file.
    EXPECT_FALSE(resolve_data_file("meshes", dir.path() / "scene"));

    const auto absolute = resolve_data_file(shared.string(), "/nonexistent");
    ASSERT_TRUE(absolute);
    EXPECT_TRUE(fs::equivalent(*absolute, shared));
}

TEST(SceneLoader, MeshFilesResolveThroughMrtData) {
    TempDir dir;
    dir.write("data/meshes/only_here.obj", kTetrahedronObj);
    const ScopedDataPath data((dir.path() / "empty").string() + ":" +
                              (dir.path() / "data").string());
    const Scene scene = parse_scene(SceneParts()
                                        .objects(R"([
        {"shape": "mesh", "file": "meshes/only_here.obj", "material": "red"}])")
                                        .json(),
                                    dir.path() / "scenes" / "scene.json");
    ASSERT_EQ(scene.meshes.size(), 1u);
    EXPECT_EQ(scene.meshes[0].triangle_count(), 4u);
}

TEST(SceneLoader, LoadsTheCowFromSharedDataThroughTheSearchPath) {
    const ScopedDataPath data(MRT_TEST_DATA_DIRS);
    TempDir dir;
    const Scene scene = parse_scene(SceneParts()
                                        .objects(R"([
        {"shape": "mesh", "file": "meshes/cow.obj", "material": "glass"}])")
                                        .json(),
                                    dir.path() / "scene.json");
    ASSERT_EQ(scene.meshes.size(), 1u);
    const Mesh& cow = scene.meshes[0];
    // 5 804 triangles in the file; load_mesh may drop a few degenerate ones.
    EXPECT_GT(cow.triangle_count(), 5700u);
    EXPECT_LE(cow.triangle_count(), 5804u);
    EXPECT_EQ(cow.materials, std::vector<std::uint32_t>(cow.triangle_count(), 1u));
}

TEST(SceneLoader, MissingMeshFileSaysWhereItLooked) {
    TempDir dir;
    const ScopedDataPath data((dir.path() / "d1").string());
    const std::string message = error_of(SceneParts()
                                             .objects(R"([{"shape": "quad", "material": "red"},
            {"shape": "mesh", "file": "meshes/nope.obj", "material": "red"}])")
                                             .json(),
                                         dir.path() / "scene.json");
    const std::string prefix = (dir.path() / "scene.json").string() +
                               ": /objects/1/file: file \"meshes/nope.obj\" not found (looked in: ";
    EXPECT_EQ(message.substr(0, prefix.size()), prefix) << message;
    for (const fs::path& candidate :
         {dir.path() / "meshes/nope.obj", dir.path() / "d1/meshes/nope.obj",
          fs::path("../shared/data/meshes/nope.obj"), fs::path("data/meshes/nope.obj")}) {
        EXPECT_NE(message.find(candidate.string()), std::string::npos)
            << candidate << " missing from: " << message;
    }
}

TEST(SceneLoader, MissingTextureFileSaysWhereItLooked) {
    const std::string message = error_of(
        SceneParts().materials(R"({"red": {"texture": {"file": "textures/none.png"}}})").json());
    EXPECT_EQ(message.rfind("scene.json: /materials/red/texture/file: file \"textures/none.png\" "
                            "not found (looked in: textures/none.png, ",
                            0),
              0u)
        << message;
}

TEST(SceneLoader, MeshLoaderErrorsArePrefixedWithTheJsonLocation) {
    const ScopedDataPath data("");
    const fs::path scene_file = test_data_dir() / "scene.json";
    const std::string message = error_of(SceneParts()
                                             .objects(R"([{"shape": "quad", "material": "red"},
            {"shape": "mesh", "file": "meshes/no_faces.obj", "material": "red"}])")
                                             .json(),
                                         scene_file);
    const std::string prefix = scene_file.string() + ": /objects/1/file: ";
    EXPECT_EQ(message.substr(0, prefix.size()), prefix) << message;
    EXPECT_NE(message.find("no_faces.obj", prefix.size()), std::string::npos) << message;
}

TEST(SceneLoader, DroppedDegenerateTrianglesAreReportedInOneWarning) {
    const fs::path scene_file = test_data_dir() / "scene.json";
    std::vector<std::string> warnings;
    const Scene scene = parse_scene(
        SceneParts()
            .objects(R"([
        {"shape": "mesh", "file": "meshes/with_degenerate.obj", "material": "red"},
        {"shape": "mesh", "file": "meshes/with_degenerate.obj", "material": "glass"}])")
            .json(),
        scene_file, {.warn = [&](const std::string& w) { warnings.push_back(w); }, .budgets = {}});
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("with_degenerate.obj"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find("dropped 1 degenerate triangle"), std::string::npos) << warnings[0];
    EXPECT_EQ(scene.meshes.at(0).triangle_count(), 1u);
}

TEST(SceneLoader, LoadSceneReadsTheFileAndResolvesPathsBesideIt) {
    TempDir dir;
    dir.write("meshes/tetra.obj", kTetrahedronObj);
    const fs::path file = dir.write("scene.json", SceneParts()
                                                      .objects(R"([
        {"shape": "mesh", "file": "meshes/tetra.obj", "material": "red"}])")
                                                      .json());
    const Scene scene = load_scene(file);
    EXPECT_EQ(scene.file, file);
    EXPECT_EQ(scene.unique_triangle_count(), 4u);
}

TEST(SceneLoader, LoadSceneReportsAMissingSceneFile) {
    TempDir dir;
    const fs::path file = dir.path() / "absent.json";
    try {
        load_scene(file);
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()), file.string() + ": scene file not found");
    }
}

// ---- Mistakes give messages naming file, JSON pointer, what was found and what was expected --

TEST(SceneLoader, RejectsUnknownMaterialWithItsLocation) {
    const std::string json = SceneParts()
                                 .objects(R"([
        {"shape": "quad", "material": "red"}, {"shape": "quad", "material": "red"},
        {"shape": "quad", "material": "glass"}, {"shape": "quad", "material": "rde"}])")
                                 .json();
    EXPECT_EQ(
        error_of(json),
        R"(scene.json: /objects/3/material: unknown material "rde" (expected one of: glass, red))");
}

TEST(SceneLoader, RejectsUnknownKeyListingTheAllowedKeys) {
    const std::string json = SceneParts()
                                 .objects(R"([
        {"shape": "quad", "material": "red"}, {"shape": "quad", "material": "red"},
        {"shape": "sphere", "raduis": 2, "material": "red"}])")
                                 .json();
    EXPECT_EQ(error_of(json),
              "scene.json: /objects/2/raduis: unknown key (expected one of: material, radius, "
              "rings, segments, shape, transform)");
}

TEST(SceneLoader, RejectsFovOutsideTheOpenInterval) {
    EXPECT_EQ(error_of(SceneParts()
                           .camera(R"({"eye": [0, 0, 5], "look_at": [0, 0, 0],
                                               "fov": 200})")
                           .json()),
              "scene.json: /camera/fov: found 200, expected a number in (0, 180)");
}

TEST(SceneLoader, RejectsColourOfTheWrongType) {
    EXPECT_EQ(
        error_of(SceneParts().materials(R"({"red": {"diffuse": "red"}})").json()),
        R"(scene.json: /materials/red/diffuse: found "red", expected an array of 3 numbers or a number)");
}

TEST(SceneLoader, ReportsSyntaxErrorsAtLineAndColumn) {
    const std::string json = "{\n  \"camera\": {\n    x\n  }\n}\n";
    const std::string message = error_of(json);
    const std::string prefix = "scene.json: line 3, column 5: JSON syntax error: ";
    EXPECT_EQ(message.substr(0, prefix.size()), prefix) << message;
    EXPECT_GT(message.size(), prefix.size());
}

TEST(SceneLoader, ReportsTruncatedDocumentAtItsEnd) {
    const std::string message = error_of("{\"camera\": {\n");
    EXPECT_EQ(message.rfind("scene.json: line 2, column 1: JSON syntax error: ", 0), 0u) << message;
}

TEST(SceneLoader, ReportsLineAndColumnOfAnyByteOffset) {
    EXPECT_EQ(error_of("\n\n   ]").rfind("scene.json: line 3, column 4: JSON syntax error: ", 0),
              0u)
        << error_of("\n\n   ]");
    EXPECT_EQ(line_and_column("ab\ncd\n", 4), (std::pair<std::size_t, std::size_t>(2, 2)));
    EXPECT_EQ(line_and_column("ab\ncd\n", 0), (std::pair<std::size_t, std::size_t>(1, 1)));
    EXPECT_EQ(line_and_column("ab\ncd\n", 2), (std::pair<std::size_t, std::size_t>(1, 3)));
    EXPECT_EQ(line_and_column("ab\ncd\n", 3), (std::pair<std::size_t, std::size_t>(2, 1)));
}

TEST(SceneLoader, RejectsNumbersThatOverflowToInfinity) {
    EXPECT_EQ(
        error_of(SceneParts().camera(R"({"eye": [0, 0, 1e400], "look_at": [0, 0, 0]})").json()),
        "scene.json: /camera/eye/2: found 1e400, expected a finite number of magnitude <= "
        "3.4e38");
    // Finite as a double but not as a float.
    EXPECT_EQ(
        error_of(SceneParts().camera(R"({"eye": [0, 0, 1e39], "look_at": [0, 0, 0]})").json()),
        "scene.json: /camera/eye/2: found 1e+39, expected a finite number of magnitude <= "
        "3.4e38");
}

TEST(SceneLoader, RejectsDuplicateKeys) {
    EXPECT_EQ(error_of(SceneParts().materials(R"({"red": {"diffuse": 1, "diffuse": 0.5}})").json()),
              "scene.json: /materials/red/diffuse: duplicate key (each key may appear once per "
              "object)");
}

TEST(SceneLoader, RejectsGroupCycleNamingItsMembers) {
    EXPECT_EQ(error_of(SceneParts()
                           .groups(R"({
        "a": {"objects": [{"instance": "b"}]},
        "b": {"objects": [{"shape": "quad", "material": "red"}, {"instance": "a"}]}})")
                           .json()),
              "scene.json: /groups/a/objects/0/instance: group cycle a → b → a");
}

TEST(SceneLoader, RejectsGroupCycleReachedFromOutside) {
    EXPECT_EQ(error_of(SceneParts()
                           .groups(R"({
        "top": {"objects": [{"instance": "x"}]},
        "x": {"objects": [{"instance": "y"}]},
        "y": {"objects": [{"instance": "z"}]},
        "z": {"objects": [{"instance": "x"}]}})")
                           .objects(R"([{"instance": "top"}])")
                           .json()),
              "scene.json: /groups/x/objects/0/instance: group cycle x → y → z → x");
}

TEST(SceneLoader, RejectsGroupInstancingItself) {
    EXPECT_EQ(error_of(SceneParts().groups(R"({"a": {"objects": [{"instance": "a"}]}})").json()),
              "scene.json: /groups/a/objects/0/instance: group cycle a → a");
}

TEST(SceneLoader, ValidatesUnusedGroups) {
    EXPECT_EQ(
        error_of(SceneParts()
                     .groups(R"({"unused": {"objects": [
                                      {"shape": "quad", "material": "blue"}]}})")
                     .json()),
        R"(scene.json: /groups/unused/objects/0/material: unknown material "blue" (expected one of: glass, red))");
}

TEST(SceneLoader, EscapesKeysInJsonPointers) {
    EXPECT_EQ(error_of(SceneParts().materials(R"({"a/b~c": {"difuse": 1}})").json()),
              "scene.json: /materials/a~1b~0c/difuse: unknown key (expected one of: diffuse, "
              "emission, ior, opacity_texture, phong_exponent, reflectivity, roughness, "
              "specular, texture, "
              "transparency)");
}

TEST(SceneLoader, RejectsMaterialReferenceWhenNoneAreDefined) {
    EXPECT_EQ(
        error_of(SceneParts().materials("").json()),
        R"(scene.json: /objects/0/material: unknown material "red" (no materials are defined))");
}

TEST(SceneLoader, AcceptsNoMaterialsWhenNothingReferencesOne) {
    const Scene scene = parse(SceneParts().materials("").objects("[]").json());
    EXPECT_TRUE(scene.materials.empty());
    EXPECT_EQ(scene.instanced_triangle_count(), 0u);
    EXPECT_TRUE(flatten(scene).triangles.empty());
}

struct Mistake {
    std::string name;
    std::string json;
    std::string message;  ///< The whole expected message.
};

std::vector<Mistake> mistakes() {
    const auto camera = [](const std::string& members) {
        return SceneParts().camera("{" + members + "}").json();
    };
    const auto material = [](const std::string& members) {
        return SceneParts().materials(R"({"red": {)" + members + "}}").json();
    };
    const auto light = [](const std::string& members) {
        return SceneParts().lights("[{" + members + "}]").json();
    };
    const auto object = [](const std::string& members) {
        return SceneParts().objects("[{" + members + "}]").json();
    };
    const auto transform = [](const std::string& value) {
        return SceneParts()
            .objects(R"([{"shape": "quad", "material": "red", "transform": )" + value + "}]")
            .json();
    };
    const std::string eye = R"("eye": [0, 0, 5], "look_at": [0, 0, 0])";
    const std::string point = R"("type": "point", "position": [0, 1, 0])";
    const std::string ellipse = R"("type": "ellipse", "center": [0, 1, 0])";
    return {
        {"TopLevelNotAnObject", "[]", "scene.json: found [], expected an object"},
        {"MissingCamera", SceneParts().camera("").json(),
         R"(scene.json: missing required key "camera")"},
        {"MissingObjects", SceneParts().objects("").json(),
         R"(scene.json: missing required key "objects")"},
        {"UnknownTopLevelKey", SceneParts().extra(R"("lihgts": [])").json(),
         "scene.json: /lihgts: unknown key (expected one of: ambient, background, camera, groups, "
         "lights, materials, max_depth, objects, world_origin)"},
        {"CameraNotAnObject", SceneParts().camera("[0, 0, 5]").json(),
         "scene.json: /camera: found [0,0,5], expected an object"},
        {"CameraWithoutEye", camera(R"("look_at": [0, 0, 0])"),
         R"(scene.json: /camera: missing required key "eye")"},
        {"EyeNotAnArray", camera(R"("eye": "origin", "look_at": [0, 0, 0])"),
         R"(scene.json: /camera/eye: found "origin", expected an array of 3 numbers)"},
        {"EyeOfTwoNumbers", camera(R"("eye": [0, 5], "look_at": [0, 0, 0])"),
         "scene.json: /camera/eye: found [0,5], expected an array of 3 numbers"},
        {"EyeComponentNotANumber", camera(R"("eye": [0, "a", 5], "look_at": [0, 0, 0])"),
         R"(scene.json: /camera/eye/1: found "a", expected a number)"},
        {"EyeEqualsLookAt", camera(R"("eye": [1, 2, 3], "look_at": [1, 2, 3])"),
         R"(scene.json: /camera/look_at: found [1,2,3], expected a point different from "eye")"},
        {"UpParallelToView", camera(R"("eye": [0, 5, 0], "look_at": [0, 0, 0], "up": [0, 2, 0])"),
         "scene.json: /camera/up: found [0,2,0], expected a vector not parallel to the view "
         "direction (look_at - eye)"},
        {"DefaultUpParallelToView", camera(R"("eye": [0, 5, 0], "look_at": [0, 0, 0])"),
         R"(scene.json: /camera: the default "up" [0, 1, 0] is parallel to the view direction )"
         R"((look_at - eye); expected an explicit "up")"},
        {"UpZero", camera(eye + R"(, "up": [0, 0, 0])"),
         "scene.json: /camera/up: found [0,0,0], expected a non-zero vector"},
        {"FovZero", camera(eye + R"(, "fov": 0)"),
         "scene.json: /camera/fov: found 0, expected a number in (0, 180)"},
        {"FovAsString", camera(eye + R"(, "fov": "40")"),
         R"(scene.json: /camera/fov: found "40", expected a number in (0, 180))"},
        {"PixelAspectZero", camera(eye + R"(, "pixel_aspect": 0)"),
         "scene.json: /camera/pixel_aspect: found 0, expected a number in [0.01, 100]"},
        {"ResolutionZero", camera(eye + R"(, "resolution": [0, 512])"),
         "scene.json: /camera/resolution/0: found 0, expected an integer in [1, 65536]"},
        {"ResolutionFraction", camera(eye + R"(, "resolution": [512, 512.5])"),
         "scene.json: /camera/resolution/1: found 512.5, expected an integer in [1, 65536]"},
        {"ResolutionTooLarge", camera(eye + R"(, "resolution": [65537, 512])"),
         "scene.json: /camera/resolution/0: found 65537, expected an integer in [1, 65536]"},
        {"ResolutionHuge", camera(eye + R"(, "resolution": [18446744073709551615, 1])"),
         "scene.json: /camera/resolution/0: found 18446744073709551615, expected an integer in "
         "[1, 65536]"},
        {"ResolutionOneNumber", camera(eye + R"(, "resolution": 512)"),
         "scene.json: /camera/resolution: found 512, expected an array of 2 integers (width, "
         "height)"},
        {"NegativeAperture", camera(eye + R"(, "aperture_radius": -1)"),
         "scene.json: /camera/aperture_radius: found -1, expected a number >= 0"},
        {"ZeroFocalDistance", camera(eye + R"(, "focal_distance": 0)"),
         "scene.json: /camera/focal_distance: found 0, expected a number > 0"},
        {"UnknownCameraKey", camera(eye + R"(, "fovy": 40)"),
         "scene.json: /camera/fovy: unknown key (expected one of: aperture_radius, eye, "
         "focal_distance, fov, look_at, pixel_aspect, resolution, up)"},
        {"BackgroundAsName", SceneParts().extra(R"("background": "black")").json(),
         R"(scene.json: /background: found "black", expected an array of 3 numbers or a number)"},
        {"NegativeAmbient", SceneParts().extra(R"("ambient": -0.5)").json(),
         "scene.json: /ambient: found -0.5, expected a number >= 0"},
        {"NegativeMaxDepth", SceneParts().extra(R"("max_depth": -1)").json(),
         "scene.json: /max_depth: found -1, expected an integer in [0, 1000]"},
        {"MaterialsAsArray", SceneParts().materials(R"([{"diffuse": 1}])").json(),
         R"(scene.json: /materials: found [{"diffuse":1}], expected an object of named materials)"},
        {"NegativeColourComponent", material(R"("diffuse": [0.5, -1, 0])"),
         "scene.json: /materials/red/diffuse/1: found -1, expected a number >= 0"},
        {"ColourOfFourNumbers", material(R"("specular": [1, 1, 1, 1])"),
         "scene.json: /materials/red/specular: found [1,1,1,1], expected an array of 3 numbers "
         "or a number"},
        {"ReflectivityAboveOne", material(R"("reflectivity": 1.5)"),
         "scene.json: /materials/red/reflectivity: found 1.5, expected a number in [0, 1]"},
        {"ReflectivityPlusTransparencyAboveOne",
         material(R"("reflectivity": 0.6, "transparency": 0.7)"),
         "scene.json: /materials/red: reflectivity + transparency = 1.3, expected at most 1"},
        {"IorZero", material(R"("ior": 0)"),
         "scene.json: /materials/red/ior: found 0, expected a number > 0"},
        {"NegativePhongExponent", material(R"("phong_exponent": -2)"),
         "scene.json: /materials/red/phong_exponent: found -2, expected a number >= 0"},
        {"NegativeRoughness", material(R"("roughness": -0.1)"),
         "scene.json: /materials/red/roughness: found -0.1, expected a number >= 0"},
        {"TextureWithoutFile", material(R"("texture": {"srgb": true})"),
         R"(scene.json: /materials/red/texture: missing required key "file")"},
        {"TextureFileEmpty", material(R"("texture": {"file": ""})"),
         R"(scene.json: /materials/red/texture/file: found "", expected a file name)"},
        {"LightsAsObject", SceneParts().lights(R"({"type": "point"})").json(),
         R"(scene.json: /lights: found {"type":"point"}, expected an array of lights)"},
        {"LightWithoutType", light(R"("position": [0, 1, 0], "intensity": 1)"),
         R"(scene.json: /lights/0: missing required key "type")"},
        {"UnknownLightType", light(R"("type": "spot")"),
         R"(scene.json: /lights/0/type: found "spot", expected one of: ellipse, point)"},
        {"PointLightWithIntensityAndPower", light(point + R"(, "intensity": 1, "power": 4)"),
         R"(scene.json: /lights/0/power: found both "intensity" and "power", expected exactly one of them)"},
        {"PointLightWithoutIntensityOrPower", light(point),
         R"(scene.json: /lights/0: missing required key "intensity" or "power" (exactly one))"},
        {"PointLightWithRadiance", light(point + R"(, "radiance": 1)"),
         "scene.json: /lights/0/radiance: unknown key (expected one of: intensity, position, "
         "power, type)"},
        {"EllipseWithParallelAxes",
         light(ellipse + R"(, "semi_axis_u": [1, 0, 0], "semi_axis_v": [-2, 0, 0], "power": 1)"),
         "scene.json: /lights/0/semi_axis_v: found [-2,0,0], expected a vector not parallel to "
         "semi_axis_u (non-zero area)"},
        {"EllipseWithZeroAxis",
         light(ellipse + R"(, "semi_axis_u": [0, 0, 0], "semi_axis_v": [0, 0, 1], "power": 1)"),
         "scene.json: /lights/0/semi_axis_u: found [0,0,0], expected a non-zero vector"},
        {"EllipseTwoSidedAsNumber",
         light(ellipse + R"(, "semi_axis_u": [1, 0, 0], "semi_axis_v": [0, 0, 1], "radiance": 1,
                            "two_sided": 1)"),
         "scene.json: /lights/0/two_sided: found 1, expected true or false"},
        {"ObjectsAsObject", SceneParts().objects("{}").json(),
         "scene.json: /objects: found {}, expected an array of objects"},
        {"ObjectWithoutShape", object(R"("material": "red")"),
         R"(scene.json: /objects/0: missing required key "shape" (or "instance"))"},
        {"UnknownShape", object(R"("shape": "cube", "material": "red")"),
         R"(scene.json: /objects/0/shape: found "cube", expected one of: checkerboard, mesh, plant, quad, sphere)"},
        {"ShapeWithoutMaterial", object(R"("shape": "sphere")"),
         R"(scene.json: /objects/0: missing required key "material")"},
        {"MaterialNotAString", object(R"("shape": "sphere", "material": 0)"),
         "scene.json: /objects/0/material: found 0, expected a string"},
        {"MeshWithoutFile", object(R"("shape": "mesh", "material": "red")"),
         R"(scene.json: /objects/0: missing required key "file")"},
        {"SphereRadiusZero", object(R"("shape": "sphere", "radius": 0, "material": "red")"),
         "scene.json: /objects/0/radius: found 0, expected a number > 0"},
        {"SphereTooFewSegments", object(R"("shape": "sphere", "segments": 2, "material": "red")"),
         "scene.json: /objects/0/segments: found 2, expected an integer in [3, 65536]"},
        {"SphereTooFewRings", object(R"("shape": "sphere", "rings": 1, "material": "red")"),
         "scene.json: /objects/0/rings: found 1, expected an integer in [2, 65536]"},
        {"QuadWithZeroSize", object(R"("shape": "quad", "size": [1, 0], "material": "red")"),
         "scene.json: /objects/0/size/1: found 0, expected a number > 0"},
        {"QuadWithMaterials", object(R"("shape": "quad", "materials": ["red", "red"])"),
         "scene.json: /objects/0/materials: unknown key (expected one of: material, shape, size, "
         "transform)"},
        {"CheckerboardWithOneMaterial", object(R"("shape": "checkerboard", "materials": ["red"])"),
         R"(scene.json: /objects/0/materials: found ["red"], expected an array of 2 material names)"},
        {"CheckerboardWithUnknownMaterial",
         object(R"("shape": "checkerboard", "materials": ["red", "blue"])"),
         R"(scene.json: /objects/0/materials/1: unknown material "blue" (expected one of: glass, red))"},
        {"CheckerboardWithZeroTiles",
         object(R"("shape": "checkerboard", "tiles": [0, 2], "materials": ["red", "glass"])"),
         "scene.json: /objects/0/tiles/0: found 0, expected an integer in [1, 65536]"},
        {"PlantWithoutLeafMaterial", object(R"("shape": "plant", "stem_material": "red")"),
         R"(scene.json: /objects/0: missing required key "leaf_material")"},
        {"PlantWithUnknownStemMaterial",
         object(R"("shape": "plant", "stem_material": "bark", "leaf_material": "red")"),
         R"(scene.json: /objects/0/stem_material: unknown material "bark" (expected one of: )"
         R"(glass, red))"},
        {"PlantWithMaterial", object(R"("shape": "plant", "material": "red")"),
         "scene.json: /objects/0/material: unknown key (expected one of: depth, leaf_material, "
         "leaves_per_branch, seed, shape, stem_material, transform)"},
        {"PlantTooDeep",
         object(R"("shape": "plant", "depth": 9, "stem_material": "red", "leaf_material": "red")"),
         "scene.json: /objects/0/depth: found 9, expected an integer in [0, 8]"},
        {"PlantNegativeDepth",
         object(R"("shape": "plant", "depth": -1, "stem_material": "red", "leaf_material": "red")"),
         "scene.json: /objects/0/depth: found -1, expected an integer in [0, 8]"},
        {"PlantTooManyLeaves", object(R"("shape": "plant", "leaves_per_branch": 1001,
                                          "stem_material": "red", "leaf_material": "red")"),
         "scene.json: /objects/0/leaves_per_branch: found 1001, expected an integer in [0, 1000]"},
        {"PlantNegativeSeed",
         object(R"("shape": "plant", "seed": -3, "stem_material": "red", "leaf_material": "red")"),
         "scene.json: /objects/0/seed: found -3, expected an integer in [0, 2147483647]"},
        {"PlantSeedFraction",
         object(R"("shape": "plant", "seed": 1.5, "stem_material": "red", "leaf_material": "red")"),
         "scene.json: /objects/0/seed: found 1.5, expected an integer in [0, 2147483647]"},
        {"UnknownInstance",
         SceneParts()
             .groups(R"({"plant": {"objects": []}})")
             .objects(R"([{"instance": "plnt"}])")
             .json(),
         R"(scene.json: /objects/0/instance: unknown group "plnt" (expected one of: plant))"},
        {"InstanceWithoutGroups", object(R"("instance": "plant")"),
         R"(scene.json: /objects/0/instance: unknown group "plant" (no groups are defined))"},
        {"InstanceWithShape",
         SceneParts()
             .groups(R"({"plant": {"objects": []}})")
             .objects(R"([{"instance": "plant", "shape": "quad"}])")
             .json(),
         "scene.json: /objects/0/shape: unknown key (expected one of: instance, transform)"},
        {"GroupWithoutObjects", SceneParts().groups(R"({"plant": {}})").json(),
         R"(scene.json: /groups/plant: missing required key "objects")"},
        {"TransformAsNumber", transform("5"),
         "scene.json: /objects/0/transform: found 5, expected a transform object or an array of "
         "them"},
        {"UnknownTransformKey", transform(R"({"rotation": {"axis": [0, 1, 0], "degrees": 9}})"),
         "scene.json: /objects/0/transform/rotation: unknown key (expected one of: matrix, "
         "rotate, scale, translate)"},
        {"ZeroScale", transform(R"({"scale": 0})"),
         "scene.json: /objects/0/transform/scale: found 0, expected a non-zero number"},
        {"ZeroScaleComponent", transform(R"({"scale": [1, 0, 1]})"),
         "scene.json: /objects/0/transform/scale/1: found 0, expected a non-zero number"},
        {"ScaleOfTwoNumbers", transform(R"({"scale": [1, 2]})"),
         "scene.json: /objects/0/transform/scale: found [1,2], expected a non-zero number or an "
         "array of 3 non-zero numbers"},
        {"ZeroRotationAxis", transform(R"({"rotate": {"axis": [0, 0, 0], "degrees": 30}})"),
         "scene.json: /objects/0/transform/rotate/axis: found [0,0,0], expected a non-zero "
         "vector"},
        {"RotationWithoutDegrees", transform(R"({"rotate": [{"axis": [0, 1, 0]}]})"),
         R"(scene.json: /objects/0/transform/rotate/0: missing required key "degrees")"},
        {"RotationAsNumber", transform(R"({"rotate": 90})"),
         R"(scene.json: /objects/0/transform/rotate: found 90, expected an object {"axis": [x, y, z], "degrees": a} or an array of them)"},
        {"TranslateNotFinite", transform(R"({"translate": [0, -1e999, 0]})"),
         "scene.json: /objects/0/transform/translate/1: found -1e999, expected a finite number "
         "of magnitude <= 3.4e38"},
        {"MatrixOfFifteenNumbers", transform(R"({"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0]})"),
         "scene.json: /objects/0/transform/matrix: found [1,0,0,0,0,1,0,0,0,0,1,0,0,0,0], "
         "expected an array of 16 numbers (4x4, row-major)"},
        {"MatrixWithProjectiveRow",
         transform(R"({"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,1]})"),
         "scene.json: /objects/0/transform/matrix: found [1,0,0,0,0,1,0,0,0,0,1,0,0,0,1,1], "
         "expected a last row of 0, 0, 0, 1 (an affine matrix)"},
        {"SingularMatrix", transform(R"({"matrix": [1,0,0,0, 0,0,0,0, 0,0,1,0, 0,0,0,1]})"),
         "scene.json: /objects/0/transform/matrix: found [1,0,0,0,0,0,0,0,0,0,1,0,0,0,0,1], "
         "expected an invertible matrix"},
        {"MatrixWithTranslate",
         transform(R"({"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "translate": [1, 0, 0]})"),
         R"(scene.json: /objects/0/transform/translate: cannot be combined with "matrix" )"
         R"((expected either "matrix" or any of "scale", "rotate", "translate"))"},
        {"NestedTransformArray", transform(R"([[{"scale": 2}]])"),
         R"(scene.json: /objects/0/transform/0: found [{"scale":2}], expected an object)"},
        {"ComposedTransformUnderflows", transform(R"([{"scale": 1e-30}, {"scale": 1e-30}])"),
         "scene.json: /objects/0/transform: the composed transform is not invertible in single "
         "precision (expected an invertible transform)"},
    };
}

void PrintTo(const Mistake& mistake, std::ostream* os) {
    *os << mistake.name;
}

class SceneLoaderMistake : public ::testing::TestWithParam<Mistake> {};

TEST_P(SceneLoaderMistake, IsReportedWithFilePointerFoundAndExpected) {
    EXPECT_EQ(error_of(GetParam().json), GetParam().message) << GetParam().json;
}

INSTANTIATE_TEST_SUITE_P(Each, SceneLoaderMistake, ::testing::ValuesIn(mistakes()),
                         [](const ::testing::TestParamInfo<Mistake>& param_info) {
                             return param_info.param.name;
                         });

TEST(SceneLoader, ProceduralShapeBeyondTheVertexBudgetIsReportedAtTheObject) {
    // With the triangle budget out of the way, the generator's own vertex limit refuses it.
    SceneLoadOptions options;
    options.budgets.procedural_triangles = std::numeric_limits<std::uint64_t>::max();
    options.budgets.instanced_triangles = std::numeric_limits<std::uint64_t>::max();
    std::string message = "(no error)";
    try {
        parse(SceneParts()
                  .objects(R"([{"shape": "sphere", "material": "red",
                                "segments": 65536, "rings": 65536}])")
                  .json(),
              options);
    } catch (const Error& e) {
        message = e.what();
    }
    EXPECT_EQ(message.rfind("scene.json: /objects/0: sphere", 0), 0u) << message;
}

TEST(SceneLoader, ShortensLongFoundValues) {
    std::string long_array = "[";
    for (int i = 0; i < 200; ++i) {
        long_array += (i ? ", " : "") + std::to_string(i);
    }
    long_array += "]";
    const std::string message = error_of(
        SceneParts().camera(R"({"eye": )" + long_array + R"(, "look_at": [0, 0, 0]})").json());
    EXPECT_LT(message.size(), 200u) << message;
    EXPECT_NE(message.find("...], expected an array of 3 numbers"), std::string::npos) << message;
}

// ---- Scene helpers ---------------------------------------------------------------------------

/// One triangle in the z = 0 plane facing +z, with uvs and material `material`.
Mesh unit_triangle(std::uint32_t material) {
    Mesh mesh;
    mesh.name = "triangle";
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    mesh.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    mesh.uvs = {{0, 0}, {1, 0}, {0, 1}};
    mesh.triangles = {{0, 1, 2}};
    mesh.materials = {material};
    return mesh;
}

Affine3f translation(float x, float y, float z) {
    return Affine3f(Eigen::Translation3f(x, y, z));
}

Affine3f scaling(float x, float y, float z) {
    Affine3f t = Affine3f::Identity();
    t.scale(Vec3f(x, y, z));
    return t;
}

/// world ─ outer (translate 0,0,10) ─ inner, and inner scaled by 2 ─ triangle (translate 1,0,0);
/// plus the triangle directly in the world.
Scene nested_scene() {
    Scene scene;
    scene.materials.resize(2);
    scene.meshes.push_back(unit_triangle(1));
    scene.groups.resize(3);
    scene.groups[1].name = "inner";
    scene.groups[1].children.push_back({Instance::Kind::Mesh, 0, translation(1, 0, 0)});
    scene.groups[2].name = "outer";
    scene.groups[2].children.push_back({Instance::Kind::Group, 1, Affine3f::Identity()});
    scene.groups[2].children.push_back({Instance::Kind::Group, 1, scaling(2, 2, 2)});
    scene.groups[0].children.push_back({Instance::Kind::Group, 2, translation(0, 0, 10)});
    scene.groups[0].children.push_back({Instance::Kind::Mesh, 0, Affine3f::Identity()});
    return scene;
}

TEST(Scene, CountsTrianglesThroughNestedInstances) {
    const Scene scene = nested_scene();
    EXPECT_EQ(scene.unique_triangle_count(), 1u);
    EXPECT_EQ(scene.instanced_triangle_count(), 3u);
}

TEST(Scene, FlattenExpandsNestedInstancesIntoWorldSpace) {
    const Mesh flat = flatten(nested_scene());
    ASSERT_EQ(flat.triangle_count(), 3u);
    ASSERT_EQ(flat.positions.size(), 9u);
    ASSERT_EQ(flat.normals.size(), 9u);
    ASSERT_EQ(flat.uvs.size(), 9u);
    EXPECT_EQ(flat.materials, std::vector<std::uint32_t>(3, 1u));
    // Second instance of inner: translate(0,0,10) · scale(2) · translate(1,0,0):
    // (1,0,0) → (2,0,0) → (4,0,0) → (4,0,10).
    const auto& second = flat.triangles[1];
    expect_near(flat.positions[second[0]], {2, 0, 10});
    expect_near(flat.positions[second[1]], {4, 0, 10});
    expect_near(flat.positions[second[2]], {2, 2, 10});
    expect_near(flat.normals[second[1]], {0, 0, 1});
    EXPECT_EQ(flat.uvs[second[1]], Vec2f(1, 0));
    // First instance: (0,1,0) → (1,1,0) → (1,1,10).
    expect_near(flat.positions[flat.triangles[0][2]], {1, 1, 10});
    // The triangle placed directly in the world is unchanged.
    expect_near(flat.positions[flat.triangles[2][1]], {1, 0, 0});
}

TEST(Scene, FlattenTransformsNormalsByTheInverseTranspose) {
    Scene scene;
    Mesh mesh = unit_triangle(0);
    // A plane x + y = 1 through (1,0,0), (0,1,0), (0,1,1), normal (1,1,0)/√2.
    mesh.positions = {{1, 0, 0}, {0, 1, 0}, {0, 1, 1}};
    const Vec3f n = Vec3f(1, 1, 0).normalized();
    mesh.normals = {n, n, n};
    scene.meshes.push_back(mesh);
    scene.groups.resize(1);
    scene.groups[0].children.push_back({Instance::Kind::Mesh, 0, scaling(2, 1, 1)});
    const Mesh flat = flatten(scene);
    // The scaled plane x/2 + y = 1 has normal ∝ (1/2, 1, 0), not the scaled (2, 1, 0).
    const Vec3f expected = Vec3f(0.5f, 1.0f, 0.0f).normalized();
    for (const Vec3f& normal : flat.normals) {
        expect_near(normal, expected);
    }
}

TEST(Scene, FlattenKeepsWindingConsistentUnderMirroring) {
    Scene scene;
    scene.meshes.push_back(unit_triangle(0));
    scene.groups.resize(1);
    scene.groups[0].children.push_back({Instance::Kind::Mesh, 0, scaling(1, 1, -1)});
    const Mesh flat = flatten(scene);
    ASSERT_EQ(flat.triangle_count(), 1u);
    const auto& t = flat.triangles[0];
    const Vec3f geometric = (flat.positions[t[1]] - flat.positions[t[0]])
                                .cross(flat.positions[t[2]] - flat.positions[t[0]]);
    expect_near(flat.normals[t[0]], {0, 0, -1});
    EXPECT_GT(geometric.dot(flat.normals[t[0]]), 0.0f);
}

TEST(Scene, FlattenFillsUvsOfMeshesWithoutThem) {
    Scene scene;
    scene.meshes.push_back(unit_triangle(0));
    Mesh bare = unit_triangle(0);
    bare.uvs.clear();
    scene.meshes.push_back(bare);
    scene.groups.resize(1);
    scene.groups[0].children.push_back({Instance::Kind::Mesh, 1, Affine3f::Identity()});
    scene.groups[0].children.push_back({Instance::Kind::Mesh, 0, Affine3f::Identity()});
    const Mesh flat = flatten(scene);
    ASSERT_EQ(flat.uvs.size(), flat.positions.size());
    EXPECT_EQ(flat.uvs[0], Vec2f(0, 0));
    EXPECT_EQ(flat.uvs[4], Vec2f(1, 0));
}

TEST(Scene, FlattenOfLoadedSceneMatchesInstancedCount) {
    const Scene scene = parse(SceneParts()
                                  .groups(R"({
        "row": {"objects": [{"shape": "quad", "material": "red"},
                            {"shape": "quad", "material": "red",
                             "transform": {"translate": [2, 0, 0]}}]},
        "grid": {"objects": [{"instance": "row"},
                             {"instance": "row", "transform": {"translate": [0, 0, 2]}}]}})")
                                  .objects(R"([{"instance": "grid",
                                       "transform": {"translate": [0, 5, 0]}}])")
                                  .json());
    const Mesh flat = flatten(scene);
    EXPECT_EQ(flat.triangle_count(), scene.instanced_triangle_count());
    EXPECT_EQ(scene.instanced_triangle_count(), 4 * scene.unique_triangle_count());
    for (const Vec3f& p : flat.positions) {
        EXPECT_NEAR(p.y(), 5.0f, kTolerance);
    }
    const Eigen::AlignedBox3f bounds = flat.bounds();
    expect_near(bounds.min(), {-0.5f, 5, -0.5f});
    expect_near(bounds.max(), {2.5f, 5, 2.5f});
}

TEST(Scene, PrintsCameraWithFovInDegrees) {
    Camera camera;
    camera.vertical_fov = 30.0f * kDegree;
    camera.width = 320;
    camera.height = 200;
    std::ostringstream out;
    out << camera;
    EXPECT_NE(out.str().find("fov=30°"), std::string::npos) << out.str();
    EXPECT_NE(out.str().find("320x200"), std::string::npos) << out.str();
    EXPECT_NE(out.str().find("eye=(0, 0, 5)"), std::string::npos) << out.str();
}

TEST(Scene, PrintsMaterialWithItsName) {
    Material material;
    material.name = "copper";
    material.ior = 1.25f;
    std::ostringstream out;
    out << material;
    EXPECT_EQ(out.str().rfind("Material{name=\"copper\", diffuse=(0.8, 0.8, 0.8)", 0), 0u)
        << out.str();
    EXPECT_NE(out.str().find("ior=1.25"), std::string::npos) << out.str();
}

// ---- Invertibility whatever the scale (common/math/invertibility.h)
// ------------------------------

/// The linear part of the world's first object's transform, as `transform` composes it.
Mat3f linear_of(const std::string& transform) {
    return parse(SceneParts()
                     .objects(R"([{"shape": "quad", "material": "red", "transform": )" + transform +
                              "}]")
                     .json())
        .groups[0]
        .children.at(0)
        .transform.linear();
}

std::string transform_error(const std::string& transform) {
    return error_of(
        SceneParts()
            .objects(R"([{"shape": "quad", "material": "red", "transform": )" + transform + "}]")
            .json());
}

const std::string kNotInvertible =
    "scene.json: /objects/0/transform: the composed transform is not invertible in single "
    "precision (expected an invertible transform)";

TEST(SceneLoader, AcceptsExactScalesWhoseDeterminantLeavesTheFloatRange) {
    // det = 1e39 overflows a float and 1e-90 underflows it; the inverses 1e-13 and 1e30 are
    // ordinary floats.
    EXPECT_EQ(linear_of(R"({"scale": 1e13})"), Mat3f(Vec3f::Constant(1e13f).asDiagonal()));
    EXPECT_EQ(linear_of(R"({"scale": 1e-30})"), Mat3f(Vec3f::Constant(1e-30f).asDiagonal()));
    EXPECT_EQ(linear_of(R"({"matrix": [1e13, 0, 0, 0, 0, 1e13, 0, 0, 0, 0, 1e13, 0, 0, 0, 0, 1]})"),
              Mat3f(Vec3f::Constant(1e13f).asDiagonal()));
    // Composed in double: 1e30 · 1e-30 is 1 (up to the double rounding of the decimals).
    expect_near(Vec3f(linear_of(R"([{"scale": 1e30}, {"scale": 1e-30}])").diagonal()), {1, 1, 1});
    EXPECT_EQ(linear_of(R"([{"scale": [1e30, 1, 1]}, {"scale": [1, 1e-30, 1]}])"),
              Mat3f(Vec3f(1e30f, 1e-30f, 1.0f).asDiagonal()));
    EXPECT_EQ(linear_of(R"({"scale": [1e30, 1, 1]})"), Mat3f(Vec3f(1e30f, 1, 1).asDiagonal()));
}

TEST(SceneLoader, AcceptsRotatedNonUniformScalesOfAnyRatio) {
    // Scale then rotate (R·S) and rotate then scale (S·R): both have columns, or rows, of wildly
    // different lengths, which a determinant relative to the largest coefficient calls singular.
    const std::string rotate = R"({"rotate": {"axis": [1, 2, 3], "degrees": 37}})";
    const std::string scale = R"({"scale": [1e30, 1, 1e-20]})";
    for (const std::string& transform :
         {"[" + scale + ", " + rotate + "]", "[" + rotate + ", " + scale + "]"}) {
        SCOPED_TRACE(transform);
        const Mat3f linear = linear_of(transform);
        // The inverse, in double, undoes it: L⁻¹·L = I to rounding, entry by entry relative to
        // the magnitudes summed (|L⁻¹|·|L|), as entries of 1e30 times 1e-30 must be.
        const Eigen::Matrix3d l = linear.cast<double>();
        const Eigen::Matrix3d inverse = l.inverse();
        const Eigen::Matrix3d residual = (inverse * l - Eigen::Matrix3d::Identity()).cwiseAbs();
        EXPECT_TRUE((residual.array() <= 1e-12 * (inverse.cwiseAbs() * l.cwiseAbs()).array()).all())
            << l;
    }
}

TEST(SceneLoader, RefusesSingularOrUnrepresentableTransforms) {
    // Rank-deficient: the third row is the sum of the first two.
    EXPECT_EQ(transform_error(R"({"matrix": [1, 2, 3, 0, 4, 5, 6, 0, 5, 7, 9, 0, 0, 0, 0, 1]})"),
              "scene.json: /objects/0/transform/matrix: found [1,2,3,0,4,5,6,0,5,7,9,0,0,0,0,1], "
              "expected an invertible matrix");
    // Nearly singular: invertible in double, but 1 + 1e-7 rounds to a float neighbour of 1 and
    // the rounding alone could make it singular.
    EXPECT_EQ(
        transform_error(R"({"matrix": [1, 1, 0, 0, 1, 1.0000001, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]})"),
        "scene.json: /objects/0/transform/matrix: found "
        "[1,1,0,0,1,1.0000001,0,0,0,0,1,0,0,0,0,1], expected an invertible matrix");
    // Moderately ill-conditioned is fine.
    EXPECT_EQ(
        linear_of(R"({"matrix": [1, 1, 0, 0, 1, 1.001, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]})")(1, 1),
        1.001f);
    // Products beyond the float range: 1e-60 is zero, 1e60 infinite; 1e-40 is a float (a
    // subnormal), but its inverse 1e40 is not.
    EXPECT_EQ(transform_error(R"([{"scale": 1e-30}, {"scale": [1, 1e-30, 1]}])"), kNotInvertible);
    EXPECT_EQ(transform_error(R"([{"scale": 1e30}, {"scale": 1e30}])"), kNotInvertible);
    EXPECT_EQ(transform_error(R"([{"scale": 1e-20}, {"scale": 1e-20}])"), kNotInvertible);
}

TEST(Invertibility, ConditionIsThatOfTheBestScalingOfRowsAndColumns) {
    // Scaled permutations: 1, whatever the scales.
    Eigen::Matrix3d permutation;
    permutation << 0, 1e30, 0, 0, 0, -1e-30, 3, 0, 0;
    EXPECT_NEAR(scaling_invariant_condition(permutation), 1.0, 1e-4);
    // A rotation by 45° about z: |R⁻¹|·|R| has the block [[1, 1], [1, 1]], spectral radius 2.
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(std::numbers::pi / 4.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    EXPECT_NEAR(scaling_invariant_condition(rotation), 2.0, 1e-12);
    // Unchanged by scaling rows and columns.
    const Eigen::Matrix3d scaled = Eigen::Vector3d(1e20, 1, 1e-15).asDiagonal() * rotation *
                                   Eigen::Vector3d(3e-25, 7, 1e10).asDiagonal();
    EXPECT_NEAR(scaling_invariant_condition(scaled), 2.0, 1e-9);
    EXPECT_TRUE(invertible_in_single_precision(scaled));
    // [[1, 1], [1, 1 + e]]: |A⁻¹|·|A| = (1/e)·[[2 + e, 2 + 2e], [2, 2 + e]] for the block,
    // spectral radius (2 + e + 2·sqrt(1 + e))/e ≈ 4/e.
    const double e = 1e-3;
    Eigen::Matrix3d near_singular;
    near_singular << 1, 1, 0, 1, 1 + e, 0, 0, 0, 1;
    EXPECT_NEAR(scaling_invariant_condition(near_singular), (2 + e + 2 * std::sqrt(1 + e)) / e,
                1e-6);
    near_singular(1, 1) = 1 + 1e-9;
    EXPECT_FALSE(invertible_in_single_precision(near_singular));
    Eigen::Matrix3d singular;
    singular << 1, 2, 3, 2, 4, 6, 0, 0, 1;
    EXPECT_EQ(scaling_invariant_condition(singular), std::numeric_limits<double>::infinity());
}

// ---- Hostile files: nesting, group chains and budgets ----------------------------------------

/// The message of the Error parsing with `options` throws, or a note that nothing was thrown.
std::string error_with(const std::string& json, const SceneLoadOptions& options) {
    try {
        parse_scene(json, "scene.json", options);
    } catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

/// "groups": g1 … gN, each g_k instancing g_{k+1} `copies` times and gN holding `leaf`; the
/// world instances g1 once. World included, that is N + 1 levels of groups.
std::string group_chain(std::size_t n, int copies = 1,
                        const std::string& leaf = R"({"shape": "quad", "material": "red"})") {
    std::string groups = "{";
    for (std::size_t k = 1; k <= n; ++k) {
        groups += (k > 1 ? ", " : "") + ("\"g" + std::to_string(k) + "\": {\"objects\": [");
        for (int c = 0; c < copies; ++c) {
            groups += (c > 0 ? ", " : "") +
                      (k < n ? "{\"instance\": \"g" + std::to_string(k + 1) + "\"}" : leaf);
        }
        groups += "]}";
    }
    return groups + "}";
}

std::string chain_scene(std::size_t n, int copies = 1) {
    return SceneParts().groups(group_chain(n, copies)).objects(R"([{"instance": "g1"}])").json();
}

TEST(SceneLoader, RefusesJsonNestedDeeperThanTheLimitAtTheOpeningBracket) {
    // 100 000 arrays in "ambient", followed by further keys in the same object.
    const std::string prefix = R"({"ambient": )";
    const std::string json = prefix + std::string(100'000, '[') + std::string(100'000, ']') +
                             R"(, "camera": {"eye": [0, 0, 5], "look_at": [0, 0, 0]}, )"
                             R"("objects": []})";
    // The top-level object is level 1: the 64th bracket opens level 65.
    const std::size_t byte = prefix.size() + 63;
    EXPECT_EQ(error_of(json),
              "scene.json: line 1, column " + std::to_string(byte + 1) + " (byte " +
                  std::to_string(byte) +
                  "): arrays and objects nest deeper than 64 levels (a scene needs about 10)");
}

TEST(SceneLoader, RefusesAMillionNestedObjectsUnderAnUnknownKeyBeforeBuildingThem) {
    std::string json = "{\n\"camera\": {\"eye\": [0, 0, 5], \"look_at\": [0, 0, 0]},\n\"x\": ";
    const std::size_t start = json.size();
    for (int i = 0; i < 1'000'000; ++i) {
        json += "{\"a\":";
    }
    json += "1" + std::string(1'000'000, '}') + ", \"objects\": []}";
    const std::size_t byte = start + 63 * 5;  // Five bytes per level; the file's "{" is level 1.
    const std::size_t column = byte - json.rfind('\n', start);
    EXPECT_EQ(error_of(json), "scene.json: line 3, column " + std::to_string(column) + " (byte " +
                                  std::to_string(byte) +
                                  "): arrays and objects nest deeper than 64 levels (a scene "
                                  "needs about 10)");
}

TEST(SceneLoader, NestingUpToTheLimitIsLeftToTheValueChecks) {
    // 63 arrays in "ambient" reach level 64 exactly: no nesting error, but a wrong colour.
    const std::string json =
        SceneParts().extra(R"("ambient": )" + std::string(63, '[') + std::string(63, ']')).json();
    EXPECT_EQ(error_of(json),
              "scene.json: /ambient: found [[[[...]]]], expected an array of 3 "
              "numbers or a number");
}

TEST(SceneLoader, BracketsInsideStringsAreNotNesting) {
    const std::string brackets = std::string(200, '[') + "\\\"" + std::string(200, '{');
    const Scene scene =
        parse(SceneParts().materials(R"({")" + brackets + R"(": {}, "red": {}})").json());
    EXPECT_EQ(scene.materials.front().name, std::string(200, '[') + "\"" + std::string(200, '{'));
}

TEST(SceneLoader, RefusesGroupChainsDeeperThanTheLimit) {
    // 20 000 groups each instancing the next: 20 001 levels with the world; g64 is level 65.
    EXPECT_EQ(error_of(chain_scene(20'000)),
              "scene.json: /groups/g64: the scene asks for 20001 levels of group nesting, over "
              "the limit of 64 (raise it with --budget group-nesting=N)");
}

TEST(SceneLoader, AcceptsGroupsNestedExactlyToTheLimit) {
    const Scene scene = parse(chain_scene(63));
    std::vector<std::uint64_t> triangles;
    for (const Mesh& mesh : scene.meshes) {
        triangles.push_back(mesh.triangle_count());
    }
    EXPECT_EQ(expand_groups(scene, triangles)[scene.root].levels, 64u);
    EXPECT_EQ(scene.instanced_triangle_count(), 2u);
    EXPECT_EQ(error_of(chain_scene(64)),
              "scene.json: /groups/g64: the scene asks for 65 levels of group nesting, over the "
              "limit of 64 (raise it with --budget group-nesting=N)");
}

TEST(SceneLoader, GroupNestingBudgetRaisesTheLimitUpToWhatEveryToolSupports) {
    SceneLoadOptions options;
    options.budgets.group_nesting = 100;
    EXPECT_NO_THROW(parse(chain_scene(99), options));
    options.budgets.group_nesting = 1'000'000;
    EXPECT_NO_THROW(parse(chain_scene(255), options));
    EXPECT_EQ(error_with(chain_scene(300), options),
              "scene.json: /groups/g256: the scene asks for 301 levels of group nesting, over the "
              "256 levels every tool supports (whatever --budget group-nesting says)");
    EXPECT_EQ(kMaxSupportedGroupNesting, 256u);
}

TEST(SceneLoader, RefusesSphereOverTheProceduralTriangleBudgetBeforeGeneratingIt) {
    // 2 × 65536 × 65535 triangles; generating them took minutes before the budget.
    EXPECT_EQ(error_of(SceneParts()
                           .objects(R"([{"shape": "quad", "material": "red"},
                                        {"shape": "sphere", "material": "red",
                                         "segments": 65536, "rings": 65536}])")
                           .json()),
              "scene.json: /objects/1: the scene asks for 8.59e+09 triangles in one procedural "
              "shape, over the limit of 2e+07 (raise it with --budget procedural-triangles=N)");
}

TEST(SceneLoader, RefusesCheckerboardAndPlantOverTheProceduralTriangleBudget) {
    EXPECT_EQ(error_of(SceneParts()
                           .objects(R"([{"shape": "checkerboard", "materials": ["red", "glass"],
                                         "tiles": [65536, 65536]}])")
                           .json()),
              "scene.json: /objects/0: the scene asks for 8.59e+09 triangles in one procedural "
              "shape, over the limit of 2e+07 (raise it with --budget procedural-triangles=N)");
    // (3^9 − 1) / 2 = 9841 branches of 60 + 8 × 1000 triangles.
    EXPECT_EQ(error_of(SceneParts()
                           .objects(R"([{"shape": "plant", "stem_material": "red",
                                         "leaf_material": "red", "depth": 8,
                                         "leaves_per_branch": 1000}])")
                           .json()),
              "scene.json: /objects/0: the scene asks for 7.93e+07 triangles in one procedural "
              "shape, over the limit of 2e+07 (raise it with --budget procedural-triangles=N)");
}

TEST(SceneLoader, ProceduralTriangleCountsMatchTheGeneratedMeshes) {
    for (const auto& [segments, rings] : {std::pair{3, 2}, {5, 4}, {64, 32}, {7, 9}}) {
        EXPECT_EQ(sphere_triangle_count(segments, rings),
                  make_sphere(1.0f, segments, rings, 0).triangle_count())
            << segments << " x " << rings;
    }
    for (const auto& [x, z] : {std::pair{1, 1}, {3, 7}, {8, 8}}) {
        EXPECT_EQ(checkerboard_triangle_count(x, z),
                  make_checkerboard(1.0f, 1.0f, x, z, 0, 1).triangle_count());
    }
    for (const auto& [depth, leaves] : {std::pair{0, 0}, {2, 3}, {3, 6}}) {
        EXPECT_EQ(plant_triangle_count(depth, leaves),
                  make_plant(7, depth, leaves, 0, 1).triangle_count())
            << depth << ", " << leaves;
    }
}

TEST(SceneLoader, RefusesMoreInstancesThanTheBudgetCountingGroupsExpanded) {
    // 27 groups each instancing the next twice: 2^27 = 134 217 728 quads.
    EXPECT_EQ(error_of(chain_scene(27, 2)),
              "scene.json: /objects: the scene asks for 1.34e+08 mesh instances (groups "
              "expanded), over the limit of 1e+08 (raise it with --budget instances=N)");
}

TEST(SceneLoader, RefusesInstancedTrianglesOverTheBudget) {
    SceneLoadOptions options;
    options.budgets.instanced_triangles = 11;
    // g1 instances g2 three times, g2 holds three quads of 2 triangles.
    EXPECT_EQ(error_with(chain_scene(2, 3), options),
              "scene.json: /objects: the scene asks for 18 triangles (instances expanded), over "
              "the limit of 11 (raise it with --budget instanced-triangles=N)");
    options.budgets.instanced_triangles = 18;
    EXPECT_EQ(parse(chain_scene(2, 3), options).instanced_triangle_count(), 18u);
}

TEST(SceneLoader, CountsThatOverflowSixtyFourBitsSaturate) {
    // 63 groups doubling each level: 2^63 quads, 2^64 triangles, which would wrap to 0.
    SceneLoadOptions options;
    options.budgets.instances = std::numeric_limits<std::uint64_t>::max();
    EXPECT_EQ(error_with(chain_scene(63, 2), options),
              "scene.json: /objects: the scene asks for more than 1.8e19 triangles (instances "
              "expanded), over the limit of 4e+09 (raise it with --budget instanced-triangles=N)");
}

TEST(SceneLoader, RefusesACameraResolutionOverThePixelBudget) {
    EXPECT_EQ(error_of(SceneParts()
                           .camera(R"({"eye": [0, 0, 5], "look_at": [0, 0, 0],
                                       "resolution": [65536, 65536]})")
                           .json()),
              "scene.json: /camera/resolution: the scene asks for 4.29e+09 pixels (camera "
              "resolution), over the limit of 2.68e+08 (raise it with --budget pixels=N)");
    SceneLoadOptions options;
    options.budgets.pixels = 65536ull * 65536ull;
    EXPECT_EQ(parse(SceneParts()
                        .camera(R"({"eye": [0, 0, 5], "look_at": [0, 0, 0],
                                    "resolution": [65536, 65536]})")
                        .json(),
                    options)
                  .camera.width,
              65536);
}

/// world → g1 → … → g_n → triangle, built by hand (no loader to bound it).
Scene hand_built_chain(std::uint32_t n) {
    Scene scene;
    scene.materials.resize(1);
    scene.meshes.push_back(unit_triangle(0));
    scene.groups.resize(n + 1);
    for (std::uint32_t g = 0; g < n; ++g) {
        scene.groups[g].children.push_back({Instance::Kind::Group, g + 1, translation(1, 0, 0)});
    }
    scene.groups[n].children.push_back({Instance::Kind::Mesh, 0, Affine3f::Identity()});
    return scene;
}

TEST(Scene, CountsAndFlattensDeepChainsOfGroupsWithoutRecursion) {
    const Scene scene = hand_built_chain(200'000);
    EXPECT_EQ(scene.instanced_triangle_count(), 1u);
    const std::vector<std::uint64_t> triangles{1};
    EXPECT_EQ(expand_groups(scene, triangles)[0].levels, 200'001u);
    const Mesh flat = flatten(scene);
    ASSERT_EQ(flat.positions.size(), 3u);
    // 200 000 translations by 1 in single precision: exact (integers below 2^24).
    EXPECT_EQ(flat.positions[0], Vec3f(2e5f, 0.0f, 0.0f));
}

TEST(Scene, CountingRefusesACycleInAHandBuiltScene) {
    Scene scene = hand_built_chain(3);
    scene.file = "hand.json";
    scene.groups[3].children.push_back({Instance::Kind::Group, 1, Affine3f::Identity()});
    const std::vector<std::uint64_t> triangles{1};
    try {
        expand_groups(scene, triangles);
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_STREQ(e.what(), "hand.json: group instances form a cycle");
    }
}

}  // namespace
}  // namespace mrt
