#include "common/scene_io/scene_record.h"

#include "common/scene/scene.h"
#include "common/scene_io/scene_loader.h"
#include "common/system/error.h"
#include "tests/support/test_support.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace mrt {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;
using testing::error_message;
using testing::ScratchDirectory;

/// The hierarchy file a record is said to come from: named by errors, never opened.
const fs::path kRecordFile = "/hierarchies/scene.mrh";
constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;

fs::path repo_scene(const std::string& name) {
    return fs::path(MRT_SOURCE_DIR) / "data" / "scenes" / name;
}

Scene round_trip(const Scene& scene) {
    return load_scene_record(scene_record_json(scene), kRecordFile);
}

std::uint32_t bits(float x) {
    return std::bit_cast<std::uint32_t>(x);
}

// Bitwise, so that -0 differs from 0 and every last ulp counts.
void expect_same(float original, float record, const std::string& field) {
    EXPECT_EQ(bits(original), bits(record))
        << fmt::format("{}: original {} ({:#010x}), record {} ({:#010x})", field, original,
                       bits(original), record, bits(record));
}

template <typename Vector>
void expect_same(const Vector& original, const Vector& record, const std::string& field) {
    for (Eigen::Index i = 0; i < original.size(); ++i) {
        expect_same(original[i], record[i], fmt::format("{}[{}]", field, i));
    }
}

void expect_same(const Camera& original, const Camera& record) {
    SCOPED_TRACE(::testing::Message() << "original " << original << "\nrecord   " << record);
    expect_same(original.eye, record.eye, "eye");
    expect_same(original.look_at, record.look_at, "look_at");
    expect_same(original.up, record.up, "up");
    expect_same(original.vertical_fov, record.vertical_fov, "vertical_fov");
    EXPECT_EQ(original.width, record.width);
    EXPECT_EQ(original.height, record.height);
    expect_same(original.aperture_radius, record.aperture_radius, "aperture_radius");
    expect_same(original.focal_distance, record.focal_distance, "focal_distance");
    expect_same(original.pixel_aspect, record.pixel_aspect, "pixel_aspect");
}

void expect_same(const Material& original, const Material& record) {
    SCOPED_TRACE(::testing::Message() << "original " << original << "\nrecord   " << record);
    EXPECT_EQ(original.name, record.name);
    expect_same(original.diffuse, record.diffuse, "diffuse");
    expect_same(original.specular, record.specular, "specular");
    expect_same(original.phong_exponent, record.phong_exponent, "phong_exponent");
    expect_same(original.reflectivity, record.reflectivity, "reflectivity");
    expect_same(original.transparency, record.transparency, "transparency");
    expect_same(original.ior, record.ior, "ior");
    expect_same(original.roughness, record.roughness, "roughness");
    expect_same(original.emission, record.emission, "emission");
    EXPECT_EQ(original.texture, record.texture);
    EXPECT_EQ(original.opacity_texture, record.opacity_texture);
    const Eigen::Matrix3f a = original.uv_transform.matrix();
    const Eigen::Matrix3f b = record.uv_transform.matrix();
    for (int row = 0; row < 3; ++row) {
        for (int column = 0; column < 3; ++column) {
            expect_same(a(row, column), b(row, column),
                        fmt::format("uv_transform({}, {})", row, column));
        }
    }
}

void expect_same(const PointLight& original, const PointLight& record) {
    expect_same(original.position, record.position, "position");
    expect_same(original.intensity, record.intensity, "intensity");
}

void expect_same(const EllipticalAreaLight& original, const EllipticalAreaLight& record) {
    expect_same(original.center, record.center, "center");
    expect_same(original.semi_axis_u, record.semi_axis_u, "semi_axis_u");
    expect_same(original.semi_axis_v, record.semi_axis_v, "semi_axis_v");
    expect_same(original.radiance, record.radiance, "radiance");
    EXPECT_EQ(original.two_sided, record.two_sided);
}

/// Every field of `record` but the geometry equals `original`'s, bit for bit; `record` has no
/// geometry and names the hierarchy file.
void expect_same_scene_without_geometry(const Scene& original, const Scene& record) {
    EXPECT_EQ(record.file, kRecordFile);
    expect_same(original.camera, record.camera);
    expect_same(original.background, record.background, "background");
    expect_same(original.ambient, record.ambient, "ambient");
    EXPECT_EQ(original.max_depth, record.max_depth);
    EXPECT_EQ(original.world_origin, record.world_origin);
    ASSERT_EQ(original.point_lights.size(), record.point_lights.size());
    for (std::size_t i = 0; i < original.point_lights.size(); ++i) {
        SCOPED_TRACE(fmt::format("point light {}", i));
        expect_same(original.point_lights[i], record.point_lights[i]);
    }
    ASSERT_EQ(original.area_lights.size(), record.area_lights.size());
    for (std::size_t i = 0; i < original.area_lights.size(); ++i) {
        SCOPED_TRACE(fmt::format("area light {}", i));
        expect_same(original.area_lights[i], record.area_lights[i]);
    }
    ASSERT_EQ(original.materials.size(), record.materials.size());
    for (std::size_t i = 0; i < original.materials.size(); ++i) {
        expect_same(original.materials[i], record.materials[i]);
    }
    ASSERT_EQ(original.textures.size(), record.textures.size());
    for (std::size_t i = 0; i < original.textures.size(); ++i) {
        EXPECT_EQ(original.textures[i].path, record.textures[i].path) << "texture " << i;
        EXPECT_EQ(original.textures[i].srgb, record.textures[i].srgb) << "texture " << i;
        EXPECT_EQ(original.textures[i].channel, record.textures[i].channel) << "texture " << i;
    }
    EXPECT_TRUE(record.meshes.empty());
    ASSERT_EQ(record.groups.size(), 1u);
    EXPECT_EQ(record.root, 0u);
    EXPECT_TRUE(record.groups[0].children.empty());
}

/// Keys anywhere in a JSON document.
void collect_keys(const Json& value, std::set<std::string>& keys) {
    if (value.is_object()) {
        for (const auto& [key, member] : value.items()) {
            keys.insert(key);
            collect_keys(member, keys);
        }
    } else if (value.is_array()) {
        for (const Json& element : value) {
            collect_keys(element, keys);
        }
    }
}

/// Image files for textures: the loader resolves them but does not decode them.
class TextureFiles {
  public:
    TextureFiles() : m_directory("mrt_scene_record") {}

    fs::path make(const std::string& name) const {
        const fs::path path = (m_directory.path() / name).lexically_normal();
        std::ofstream(path, std::ios::binary) << "not decoded by the loader";
        return path;
    }

  private:
    ScratchDirectory m_directory;
};

/// A scene with every field of every type set away from its default, with values chosen to be
/// hard to write: an angle no float number of degrees reaches, the bounds of ranges, -0,
/// subnormals, the largest float, a uv transform with rotation and shear, names to escape.
Scene every_field_scene(const TextureFiles& files) {
    Scene scene;
    scene.file = "hand-made.json";
    Camera& c = scene.camera;
    c.eye = Vec3f(1.5f, -2.25f, 7e-3f);
    c.look_at = Vec3f(0.1f, 0.2f, -0.3f);
    c.up = Vec3f(0.3f, 1.0f, 0.1f);
    // float(d · π/180) is not this float for any float d: only a double number of degrees gives
    // it back.
    c.vertical_fov = 0.00109083124f;
    c.width = 640;
    c.height = 361;
    c.aperture_radius = 0.1f;
    c.focal_distance = 3.7f;
    // The lowest accepted aspect: its float lies below 0.01, so only the decimal 0.01 reads back.
    c.pixel_aspect = 0.01f;
    scene.background = Rgb(0.1f, 0.2f, 0.3f);
    scene.ambient = Rgb(-0.0f, std::numeric_limits<float>::denorm_min(), 1e-40f);
    scene.max_depth = 1000;
    // A double the floats of the scene cannot hold, and a sub-float magnitude.
    scene.world_origin = Vec3d(1e6 + 0.1, -3.3e38, 1e-300);

    scene.point_lights.push_back(PointLight{Vec3f(-1e30f, std::numeric_limits<float>::max(), -0.0f),
                                            Rgb(1.0f / 3.0f, 0, 7)});
    scene.point_lights.push_back(PointLight{Vec3f(2, 3, 4), Rgb(0.7f, 0.8f, 0.9f)});
    scene.area_lights.push_back(EllipticalAreaLight{Vec3f(0, 4, 0), Vec3f(0.3f, 0.01f, 0),
                                                    Vec3f(0.1f, 0, -0.7f), Rgb(5, 4.5f, 4), true});
    scene.area_lights.push_back(EllipticalAreaLight{Vec3f(-1, 2.5f, 3), Vec3f(0, 0.25f, 0),
                                                    Vec3f(0, 0, 0.125f), Rgb(0.2f), false});

    scene.textures.push_back(Texture{files.make("wood.png"), true});
    // The same file as a cut-out's opacity: another texture.
    scene.textures.push_back(Texture{files.make("wood.png"), false, TextureChannel::Opacity});
    scene.textures.push_back(Texture{files.make("data.png"), false});
    scene.textures.push_back(Texture{files.make("stencil.png"), false, TextureChannel::Opacity});

    Material wood;
    wood.name = "wood";
    wood.diffuse = Rgb(0.9f, 0.7f, 0.5f);
    wood.specular = Rgb(0.12f, 0.13f, 0.14f);
    wood.phong_exponent = 40.5f;
    wood.roughness = 0.05f;
    wood.emission = Rgb(17.0f, 0.1f, 1e-7f);  // a glowing surface, an OBJ `Ke`
    wood.texture = 0;
    wood.opacity_texture = 1;
    wood.uv_transform = Affine2f::Identity();
    wood.uv_transform.translate(Vec2f(0.5f, -0.25f))
        .rotate(Eigen::Rotation2Df(0.3f))
        .scale(Vec2f(4.0f, -2.0f));
    wood.uv_transform.linear()(0, 1) += 0.1f;  // A shear, which uv_scale/uv_rotate cannot say.
    Material glass;
    glass.name = "glass/frosted~1";  // "/" and "~" are escaped in JSON pointers.
    glass.diffuse = Rgb(0, 0, 0);
    glass.specular = Rgb(1, 1, 1);
    glass.phong_exponent = 0.0f;
    glass.reflectivity = 0.1f;
    glass.transparency = 0.9f;
    glass.ior = 1.33f;
    glass.roughness = 0.2f;
    Material data;
    data.name = "data";
    data.reflectivity = 1.0f;
    data.ior = 0.75f;
    data.texture = 2;
    data.uv_transform = Affine2f(Eigen::Translation2f(1e-3f, 2e30f));
    Material stencil;  // A cut-out without a colour texture: its uv transform is the opacity's.
    stencil.name = "stencil";
    stencil.opacity_texture = 3;
    stencil.uv_transform = Affine2f(Eigen::Scaling(3.0f, 0.5f));
    Material shared = wood;  // The same texture again, with another transform.
    shared.name = "";
    shared.uv_transform = Affine2f(Eigen::Rotation2Df(-2.0f));
    scene.materials = {wood, glass, data, stencil, shared};
    return scene;
}

// ---- Round trips -------------------------------------------------------------------------------

TEST(SceneRecord, TwoSpheresComeBackBitForBitWithoutTheirGeometry) {
    const Scene scene = load_scene(repo_scene("two-spheres.json"));
    ASSERT_FALSE(scene.meshes.empty());
    ASSERT_EQ(scene.area_lights.size(), 1u);
    expect_same_scene_without_geometry(scene, round_trip(scene));
}

TEST(SceneRecord, DeskComesBackBitForBitWithItsTexturesAndUvScale) {
    const Scene scene = load_scene(repo_scene("desk.json"));
    ASSERT_EQ(scene.textures.size(), 4u);
    ASSERT_EQ(scene.area_lights.size(), 2u);
    bool scaled = false;
    for (const Material& m : scene.materials) {
        scaled = scaled || (m.texture >= 0 && !m.uv_transform.matrix().isIdentity());
    }
    ASSERT_TRUE(scaled) << "desk.json should have a texture with a uv_scale";
    expect_same_scene_without_geometry(scene, round_trip(scene));
}

TEST(SceneRecord, EveryFieldSetAwayFromItsDefaultComesBackBitForBit) {
    const TextureFiles files;
    const Scene scene = every_field_scene(files);
    expect_same_scene_without_geometry(scene, round_trip(scene));
}

TEST(SceneRecord, ARecordOfARecordIsTheSameText) {
    const TextureFiles files;
    const std::string record = scene_record_json(every_field_scene(files));
    EXPECT_EQ(scene_record_json(load_scene_record(record, kRecordFile)), record);
}

TEST(SceneRecord, EveryFloatFieldOfViewComesBack) {
    // About 18000 angles spread over (1e-6, π), each through its own record.
    Scene scene;
    scene.camera.focal_distance = 5.0f;
    const std::uint32_t first = bits(1e-6f);
    const std::uint32_t last = bits(std::nextafter(std::numbers::pi_v<float>, 0.0f));
    int unreachable_from_float_degrees = 0;
    for (std::uint32_t b = first; b <= last; b += 9973) {
        const float fov = std::bit_cast<float>(b);
        scene.camera.vertical_fov = fov;
        const Scene record = round_trip(scene);
        ASSERT_EQ(bits(record.camera.vertical_fov), b) << "vertical_fov " << fov;
        const auto degrees = static_cast<float>(static_cast<double>(fov) / kRadiansPerDegree);
        bool reachable = false;
        for (float d = std::nextafter(std::nextafter(degrees, 0.0f), 0.0f);
             d <= std::nextafter(std::nextafter(degrees, 180.0f), 180.0f);
             d = std::nextafter(d, 180.0f)) {
            reachable = reachable || static_cast<float>(d * kRadiansPerDegree) == fov;
        }
        unreachable_from_float_degrees += reachable ? 0 : 1;
    }
    // The loader converts the file's double; degrees rounded to float first would miss these.
    EXPECT_GT(unreachable_from_float_degrees, 0);
}

TEST(SceneRecord, ArbitraryFloatBitsComeBack) {
    Scene scene;
    scene.camera.focal_distance = 5.0f;
    std::mt19937 rng(20240611);
    std::uniform_int_distribution<std::uint32_t> any_bits;
    const auto finite = [&] {
        float x = 0.0f;
        do {
            x = std::bit_cast<float>(any_bits(rng));
        } while (!std::isfinite(x));
        return x;
    };
    for (int i = 0; i < 2000; ++i) {
        scene.point_lights.push_back(PointLight{Vec3f(finite(), finite(), finite()),
                                                Rgb(finite(), finite(), finite()).abs()});
    }
    scene.point_lights.push_back(PointLight{
        Vec3f(std::numeric_limits<float>::lowest(), std::numeric_limits<float>::min(),
              -std::numeric_limits<float>::denorm_min()),
        Rgb(std::numeric_limits<float>::max(), 0.0f, std::numeric_limits<float>::denorm_min())});
    expect_same_scene_without_geometry(scene, round_trip(scene));
}

TEST(SceneRecord, FocalDistanceZeroComesBackAsTheDistanceToLookAt) {
    Scene scene;
    scene.camera.eye = Vec3f(1, 2, 3);
    scene.camera.look_at = Vec3f(1, 5, 7);
    scene.camera.up = Vec3f(1, 0, 0);
    ASSERT_EQ(scene.camera.focal_distance, 0.0f);  // Camera's default: "focus on look_at".
    Scene record = round_trip(scene);
    EXPECT_EQ(record.camera.focal_distance, 5.0f);
    record.camera.focal_distance = 0.0f;
    expect_same_scene_without_geometry(scene, record);
}

// ---- What the text looks like ------------------------------------------------------------------

TEST(SceneRecord, NumbersAreTheShortDecimalsOfTheSceneFile) {
    const Scene scene = load_scene(repo_scene("two-spheres.json"));
    const Json record = Json::parse(scene_record_json(scene));
    EXPECT_EQ(record["camera"]["fov"].dump(), "42.0");
    EXPECT_EQ(record["background"].dump(), "[0.3,0.42,0.62]");
    EXPECT_EQ(record["materials"]["glass"]["transparency"].dump(), "0.9");
    EXPECT_EQ(record["materials"]["glass"]["ior"].dump(), "1.5");
    EXPECT_EQ(record["camera"]["resolution"].dump(), "[512,512]");
}

TEST(SceneRecord, HoldsNoGeometry) {
    const Scene scene = load_scene(repo_scene("desk.json"));
    ASSERT_FALSE(scene.meshes.empty());
    ASSERT_GT(scene.groups.size(), 1u);
    const Json record = Json::parse(scene_record_json(scene));
    std::set<std::string> top;
    for (const auto& [key, value] : record.items()) {
        top.insert(key);
    }
    EXPECT_EQ(top, (std::set<std::string>{"ambient", "background", "camera", "lights", "materials",
                                          "max_depth", "objects", "world_origin"}));
    EXPECT_EQ(record["objects"], Json::array());
    std::set<std::string> keys;
    collect_keys(record, keys);
    for (const char* geometry : {"groups", "shape", "instance", "transform", "tiles"}) {
        EXPECT_EQ(keys.count(geometry), 0u) << geometry;
    }
}

TEST(SceneRecord, TexturesAreWrittenByTheirAbsolutePaths) {
    const Scene scene = load_scene(repo_scene("desk.json"));
    const Json record = Json::parse(scene_record_json(scene));
    std::set<std::string> written;
    for (const auto& [name, material] : record["materials"].items()) {
        if (material.contains("texture")) {
            const std::string file = material["texture"]["file"];
            EXPECT_TRUE(fs::path(file).is_absolute()) << file;
            written.insert(file);
        }
    }
    std::set<std::string> resolved;
    for (const Texture& texture : scene.textures) {
        resolved.insert(texture.path.string());
    }
    EXPECT_EQ(written, resolved);
}

// ---- Refusals ----------------------------------------------------------------------------------

/// The error of loading the record of `scene` after `corrupt` has changed its JSON.
template <typename F>
std::string error_of_corrupted(const Scene& scene, const F& corrupt) {
    Json record = Json::parse(scene_record_json(scene));
    corrupt(record);
    return error_message([&] { load_scene_record(record.dump(), kRecordFile); });
}

TEST(SceneRecord, CorruptedRecordIsRefusedNamingTheFileAndThePointer) {
    const TextureFiles files;
    const Scene scene = every_field_scene(files);
    EXPECT_EQ(error_of_corrupted(scene, [](Json& r) { r["camera"]["eye"] = "over there"; }),
              "/hierarchies/scene.mrh: /camera/eye: found \"over there\", expected an array of 3 "
              "numbers");
    EXPECT_EQ(
        error_of_corrupted(scene, [](Json& r) { r["materials"]["wood"]["texture"]["srgb"] = 1; }),
        "/hierarchies/scene.mrh: /materials/wood/texture/srgb: found 1, expected true or "
        "false");
    EXPECT_EQ(error_of_corrupted(scene, [](Json& r) { r["lights"][2]["two_sided"] = "yes"; }),
              "/hierarchies/scene.mrh: /lights/2/two_sided: found \"yes\", expected true or false");
    EXPECT_EQ(
        error_of_corrupted(scene, [](Json& r) { r["materials"]["glass/frosted~1"]["ior"] = -1; }),
        "/hierarchies/scene.mrh: /materials/glass~1frosted~01/ior: found -1, expected a number > "
        "0");
    EXPECT_EQ(error_of_corrupted(scene, [](Json& r) { r["camera"]["resolution"][1] = 2.5; }),
              "/hierarchies/scene.mrh: /camera/resolution/1: found 2.5, expected an integer in "
              "[1, 65536]");
}

TEST(SceneRecord, TruncatedRecordIsASyntaxErrorOfTheFile) {
    const std::string record = scene_record_json(load_scene(repo_scene("two-spheres.json")));
    const std::string message =
        error_message([&] { load_scene_record(record.substr(0, record.size() / 2), kRecordFile); });
    EXPECT_EQ(message.rfind("/hierarchies/scene.mrh: line ", 0), 0u) << message;
    EXPECT_NE(message.find("JSON syntax error"), std::string::npos) << message;
}

TEST(SceneRecord, RecordWithGeometryIsRefused) {
    const Scene scene = load_scene(repo_scene("two-spheres.json"));
    EXPECT_EQ(
        error_of_corrupted(scene,
                           [](Json& r) {
                               r["objects"].push_back({{"shape", "quad"}, {"material", "glass"}});
                           }),
        "/hierarchies/scene.mrh: /objects: found [{\"shape\":\"quad\",\"material\":"
        "\"glass\"}], expected [] (a scene record holds no geometry)");
    EXPECT_EQ(error_of_corrupted(scene, [](Json& r) { r["groups"] = Json::object(); }),
              "/hierarchies/scene.mrh: /groups: found {}, expected no \"groups\" (a scene record "
              "holds no geometry)");
}

TEST(SceneRecord, MissingTextureIsReportedAtItsMaterial) {
    Scene scene;
    fs::path removed;
    {
        const TextureFiles files;
        scene.textures.push_back(Texture{files.make("gone.png"), true});
        removed = scene.textures[0].path;
    }
    scene.camera.focal_distance = 5.0f;
    Material m;
    m.name = "paper";
    m.texture = 0;
    scene.materials.push_back(m);
    const std::string message =
        error_message([&] { load_scene_record(scene_record_json(scene), kRecordFile); });
    EXPECT_EQ(message.rfind("/hierarchies/scene.mrh: /materials/paper/texture/file: file \"" +
                                removed.string() + "\" not found",
                            0),
              0u)
        << message;
}

/// The message of writing the record of every_field_scene() after `change`.
template <typename F>
std::string error_of_writing(const F& change) {
    const TextureFiles files;
    Scene scene = every_field_scene(files);
    change(scene, files);
    return error_message([&] { scene_record_json(scene); });
}

TEST(SceneRecord, RefusesToWriteWhatASceneFileCannotSayExactly) {
    using Files = const TextureFiles&;
    const std::string cannot = "cannot be written to a scene record: ";
    EXPECT_EQ(error_of_writing([](Scene& s, Files) { s.camera.eye.y() = std::nanf(""); }),
              "hand-made.json: /camera/eye/1: " + cannot + "found nan, expected a finite number");
    EXPECT_EQ(error_of_writing([](Scene& s, Files) { s.materials[2].name = "wood"; }),
              "hand-made.json: /materials/wood: " + cannot +
                  "a second material of this name, expected unique names");
    EXPECT_EQ(error_of_writing([](Scene& s, Files) { s.textures[1].path = "data.png"; }),
              "hand-made.json: " + cannot +
                  "texture 1 \"data.png\": expected an absolute, normal path (as the loader "
                  "resolves)");
    EXPECT_NE(error_of_writing([](Scene& s, Files) {
                  s.textures[1].path /= "../data.png";
              }).find("expected an absolute, normal path"),
              std::string::npos);
    EXPECT_NE(error_of_writing([](Scene& s, Files) {
                  s.textures[1] = s.textures[0];
              }).find("a second texture of this path, srgb flag and channel, expected one"),
              std::string::npos);
    EXPECT_EQ(error_of_writing([](Scene& s, Files f) {
                  s.textures.push_back(Texture{f.make("unused.png"), true});
              }),
              "hand-made.json: " + cannot +
                  "texture 4 is used by no material, expected every texture used");
    EXPECT_EQ(error_of_writing([](Scene& s, Files) {
                  s.materials[0].texture = 2;
                  s.materials[2].texture = 0;
              }),
              "hand-made.json: /materials/wood/texture: " + cannot +
                  "texture 2 is used before texture 0, expected textures numbered in order of "
                  "first use");
    EXPECT_EQ(error_of_writing([](Scene& s, Files) { s.materials[0].texture = 4; }),
              "hand-made.json: /materials/wood/texture: " + cannot +
                  "found texture index 4, expected -1 or an index into the 4 textures");
    EXPECT_EQ(error_of_writing([](Scene& s, Files) { s.materials[0].opacity_texture = 0; }),
              "hand-made.json: /materials/wood/opacity_texture: " + cannot +
                  "texture 0 is read as a colour, expected an opacity");
    EXPECT_NE(error_of_writing([](Scene& s, Files) {
                  s.textures[1].srgb = true;
              }).find("an sRGB opacity, expected opacities read as stored"),
              std::string::npos);
    EXPECT_EQ(error_of_writing([](Scene& s, Files) {
                  s.materials[1].uv_transform = Affine2f(Eigen::Scaling(2.0f, 2.0f));
              }),
              "hand-made.json: /materials/glass~1frosted~01/texture: " + cannot +
                  "found a uv transform without a texture, expected the identity");
    EXPECT_EQ(error_of_writing([](Scene& s, Files) {
                  s.file.clear();
                  s.area_lights[1].radiance[2] = kInfinity;
              }),
              "(scene): /lights/3/radiance/2: " + cannot + "found inf, expected a finite number");
}

// ---- The two additions to the loader the record needs -------------------------------------------

/// A geometry-free scene file whose one material has the texture object `texture` (its "file"
/// is prepended).
std::string scene_with_texture(const fs::path& file, const std::string& texture) {
    return R"({"camera": {"eye": [0, 0, 5], "look_at": [0, 0, 0]}, "objects": [],
               "materials": {"m": {"texture": {"file": ")" +
           file.string() + "\", " + texture + "}}}}";
}

TEST(SceneLoader, UvMatrixIsAnAffineMatrixWrittenRowByRow) {
    const TextureFiles files;
    const fs::path image = files.make("image.png");
    const Scene scene =
        parse_scene(scene_with_texture(image, R"("uv_matrix": [0, -2, 0.5, 3, 0, 0.25, 0, 0, 1])"),
                    "scene.json");
    const Vec2f uv = scene.materials[0].uv_transform * Vec2f(1.0f, 1.0f);
    EXPECT_EQ(uv, Vec2f(-1.5f, 3.25f));
}

TEST(SceneLoader, AnOpacityTextureSharesTheColoursUvTransformOrHasItsOwnAlone) {
    const TextureFiles files;
    const std::string image = files.make("image.png").string();
    const auto scene_of = [&](const std::string& material) {
        return R"({"camera": {"eye": [0, 0, 5], "look_at": [0, 0, 0]}, "objects": [],
                   "materials": {"m": )" +
               material + "}}";
    };
    const Scene both = parse_scene(
        scene_of(R"({"texture": {"file": ")" + image +
                 R"(", "uv_scale": 2}, "opacity_texture": {"file": ")" + image + R"("}})"),
        "scene.json");
    ASSERT_EQ(both.textures.size(), 2u) << "one file as colour and as opacity";
    EXPECT_EQ(both.materials[0].texture, 0);
    EXPECT_EQ(both.materials[0].opacity_texture, 1);
    EXPECT_EQ(both.textures[1].channel, TextureChannel::Opacity);
    EXPECT_FALSE(both.textures[1].srgb);
    EXPECT_EQ(both.materials[0].uv_transform * Vec2f(1.0f, 1.0f), Vec2f(2.0f, 2.0f));
    const Scene alone = parse_scene(
        scene_of(R"({"opacity_texture": {"file": ")" + image + R"(", "uv_offset": [0.5, 0]}})"),
        "scene.json");
    EXPECT_EQ(alone.materials[0].texture, -1);
    EXPECT_EQ(alone.materials[0].uv_transform * Vec2f(0.0f, 0.0f), Vec2f(0.5f, 0.0f));
    EXPECT_EQ(error_message([&] {
                  parse_scene(scene_of(R"({"texture": {"file": ")" + image +
                                       R"("}, "opacity_texture": {"file": ")" + image +
                                       R"(", "uv_scale": 2}})"),
                              "scene.json");
              }),
              "scene.json: /materials/m/opacity_texture/uv_scale: unknown key (expected one of: "
              "file)");
}

TEST(SceneLoader, RefusesUvMatrixThatIsCombinedNotAffineOrSingular) {
    const TextureFiles files;
    const fs::path image = files.make("image.png");
    const auto error = [&](const std::string& texture) {
        return error_message([&] { parse_scene(scene_with_texture(image, texture), "s.json"); });
    };
    EXPECT_EQ(error(R"("uv_matrix": [1, 0, 0, 0, 1, 0, 0, 0, 1], "uv_rotate": 90)"),
              "s.json: /materials/m/texture/uv_rotate: cannot be combined with \"uv_matrix\" "
              "(expected either \"uv_matrix\" or any of \"uv_scale\", \"uv_rotate\", "
              "\"uv_offset\")");
    EXPECT_EQ(error(R"("uv_matrix": [1, 0, 0, 0, 1, 0, 0, 1, 1])"),
              "s.json: /materials/m/texture/uv_matrix: found [1,0,0,0,1,0,0,1,1], expected a "
              "last row of 0, 0, 1 (an affine matrix)");
    EXPECT_EQ(error(R"("uv_matrix": [1, 2, 0, 2, 4, 0, 0, 0, 1])"),
              "s.json: /materials/m/texture/uv_matrix: found [1,2,0,2,4,0,0,0,1], expected an "
              "invertible matrix");
    EXPECT_EQ(error(R"("uv_matrix": [1, 0, 0, 0, 1, 0])"),
              "s.json: /materials/m/texture/uv_matrix: found [1,0,0,0,1,0], expected an array "
              "of 9 numbers (3x3, row-major)");
}

TEST(SceneLoader, FovIsConvertedToRadiansFromTheFilesDoubleRoundedOnce) {
    const Scene scene = parse_scene(
        R"({"camera": {"eye": [0, 0, 5], "look_at": [0, 0, 0], "fov": 33.3}, "objects": []})",
        "scene.json");
    EXPECT_EQ(bits(scene.camera.vertical_fov), bits(static_cast<float>(33.3 * kRadiansPerDegree)));
}

}  // namespace
}  // namespace mrt
