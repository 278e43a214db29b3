// Materials from the mesh file: OBJ `mtllib`/`usemtl` per face mapped onto the project's
// materials (docs/scene-format.md, "Materials from the mesh file"), the fallback and default
// materials, the errors naming the OBJ or MTL file and line, and the lights its emissive faces
// make (common/scene/emissive_lights.h).

#include "common/scene/emissive_lights.h"
#include "common/scene_io/scene_loader.h"
#include "common/scene_io/scene_record.h"
#include "common/system/error.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

namespace mrt {
namespace {

namespace fs = std::filesystem;
using testing::contains;
using testing::error_message;
using testing::write_file;

/// Two unit quads side by side (x 0..1 and 1..2, in the z = 0 plane, facing +z) and a third one
/// above them; `statements` go before each quad's face line.
std::string three_quads(const std::string& first, const std::string& second,
                        const std::string& third) {
    return "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n"
           "v 0 2 0\nv 1 2 0\nv 1 3 0\nv 0 3 0\n"
           "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n" +
           first + "f 1/1 2/2 3/3 4/4\n" + second + "f 2/1 5/2 6/3 3/4\n" + third +
           "f 7/1 8/2 9/3 10/4\n";
}

const Material& material_of(const Scene& scene, std::size_t triangle) {
    return scene.materials[scene.meshes[0].materials[triangle]];
}

Scene load(const fs::path& dir, const std::string& object_extras,
           std::vector<std::string>* warnings = nullptr) {
    const fs::path scene = dir / "scene.json";
    write_file(scene, R"({"camera": {"eye": [0, 0, 5], "look_at": [0, 0, 0]},
                     "materials": {"red": {"diffuse": [1, 0, 0]}},
                     "objects": [{"shape": "mesh", "file": "quads.obj")" +
                          object_extras + "}]}");
    SceneLoadOptions options;
    if (warnings != nullptr) {
        options.warn = [warnings](const std::string& w) { warnings->push_back(w); };
    }
    return load_scene(scene, options);
}

TEST(MeshMaterials, EachFaceTakesItsUsemtlMaterialMappedFromTheLibrary) {
    const testing::ScratchDirectory dir("mesh_materials");
    write_file(dir.path() / "wood.png", "");
    write_file(dir.path() / "lib.mtl",
               "newmtl matte\nKd 0.2 0.4 0.6\nKs 0.5 0.5 0.5\nNs 20\nillum 1\n"
               "newmtl mirror\nKd 0.1 0.1 0.1\nKs 0.7 0.6 0.5\nNs 300\nillum 3\n"
               "newmtl glass\nKs 0.1\nNi 1.45\nillum 7\n"
               "newmtl veil\nd 0.25\nillum 2\n"
               "newmtl lamp\nKe 4 3 2\n"
               "newmtl wood\nmap_Kd -s 2 3 -o 0.5 0 wood.png\n");
    write_file(dir.path() / "quads.obj",
               "mtllib lib.mtl\n" +
                   three_quads("usemtl matte\n", "usemtl mirror\n", "usemtl glass\n") +
                   "v 5 0 0\nv 6 0 0\nv 6 1 0\nusemtl veil\nf 11 12 13\nusemtl lamp\nf 11 12 13\n"
                   "usemtl wood\nf 11/1 12/2 13/3\n");
    const Scene scene = load(dir.path(), "");
    ASSERT_EQ(scene.meshes.size(), 1u);
    ASSERT_EQ(scene.meshes[0].triangle_count(), 9u);

    const Material& matte = material_of(scene, 0);
    EXPECT_EQ(matte.name, "lib.mtl:matte");
    EXPECT_TRUE(matte.diffuse.isApprox(Rgb(0.2f, 0.4f, 0.6f)));
    EXPECT_TRUE(matte.specular.isZero()) << "illum 1 has no highlight";
    EXPECT_EQ(&material_of(scene, 1), &matte);  // both triangles of the quad

    const Material& mirror = material_of(scene, 2);
    EXPECT_TRUE(mirror.specular.isApprox(Rgb(0.7f, 0.6f, 0.5f)));
    EXPECT_FLOAT_EQ(mirror.phong_exponent, 300.0f);
    EXPECT_FLOAT_EQ(mirror.reflectivity, 0.7f);
    EXPECT_FLOAT_EQ(mirror.transparency, 0.0f);

    const Material& glass = material_of(scene, 4);
    EXPECT_FLOAT_EQ(glass.reflectivity, 0.1f);
    EXPECT_FLOAT_EQ(glass.transparency, 0.9f);  // all but what is mirrored
    EXPECT_FLOAT_EQ(glass.ior, 1.45f);

    const Material& veil = material_of(scene, 6);
    EXPECT_FLOAT_EQ(veil.transparency, 0.75f);
    EXPECT_FLOAT_EQ(veil.ior, 1.0f) << "dissolve lets light through without bending it";

    const Material& lamp = material_of(scene, 7);
    EXPECT_TRUE(lamp.emission.isApprox(Rgb(4.0f, 3.0f, 2.0f)));
    EXPECT_TRUE(lamp.diffuse.isApprox(Rgb(0.8f, 0.8f, 0.8f)));

    const Material& wood = material_of(scene, 8);
    ASSERT_GE(wood.texture, 0);
    EXPECT_EQ(scene.textures[static_cast<std::size_t>(wood.texture)].path.filename(), "wood.png");
    EXPECT_TRUE((wood.uv_transform * Vec2f(1.0f, 1.0f)).isApprox(Vec2f(2.5f, 3.0f)));

    // The scene record carries the emission, so a hierarchy file's scene keeps its lights.
    const Scene record = load_scene_record(scene_record_json(scene), dir.path() / "x.mrh");
    const auto it = std::find_if(record.materials.begin(), record.materials.end(),
                                 [](const Material& m) { return m.name == "lib.mtl:lamp"; });
    ASSERT_NE(it, record.materials.end());
    EXPECT_TRUE(it->emission.isApprox(Rgb(4.0f, 3.0f, 2.0f)));
}

TEST(MeshMaterials, MapDIsTheCutOutsOpacityReadAsStoredThroughTheColoursUvTransform) {
    const testing::ScratchDirectory dir("mesh_materials_cutout");
    write_file(dir.path() / "leaf.png", "");
    write_file(dir.path() / "mask.png", "");
    write_file(dir.path() / "lib.mtl",
               "newmtl leaf\nmap_Kd -s 2 2 leaf.png\nmap_d -s 2 2 leaf.png\n"
               "newmtl stencil\nmap_d -o 0.5 0 mask.png\n"
               "newmtl skewed\nmap_Kd leaf.png\nmap_d -s 3 3 mask.png\n");
    write_file(
        dir.path() / "quads.obj",
        "mtllib lib.mtl\n" + three_quads("usemtl leaf\n", "usemtl stencil\n", "usemtl skewed\n"));
    std::vector<std::string> warnings;
    const Scene scene = load(dir.path(), "", &warnings);
    const Material& leaf = material_of(scene, 0);
    ASSERT_TRUE(leaf.cut_out());
    ASSERT_GE(leaf.texture, 0);
    const Texture& colour = scene.textures[static_cast<std::size_t>(leaf.texture)];
    const Texture& opacity = scene.textures[static_cast<std::size_t>(leaf.opacity_texture)];
    EXPECT_EQ(colour.path, opacity.path) << "one file, read twice";
    EXPECT_EQ(colour.channel, TextureChannel::Colour);
    EXPECT_TRUE(colour.srgb);
    EXPECT_EQ(opacity.channel, TextureChannel::Opacity);
    EXPECT_FALSE(opacity.srgb) << "an opacity is read as stored";
    EXPECT_TRUE(leaf.uv_transform.matrix().isApprox(Affine2f(Eigen::Scaling(2.0f, 2.0f)).matrix()));
    // Without a colour texture the cut-out's own options place it.
    const Material& stencil = material_of(scene, 2);
    EXPECT_EQ(stencil.texture, -1);
    ASSERT_TRUE(stencil.cut_out());
    EXPECT_TRUE(stencil.uv_transform.translation().isApprox(Vec2f(0.5f, 0.0f)));
    // Options that differ from the colour's are the colour's, with a warning naming the line.
    const Material& skewed = material_of(scene, 4);
    EXPECT_TRUE(skewed.uv_transform.matrix().isIdentity());
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_TRUE(contains(warnings[0],
                         "lib.mtl: line 8: 'map_d' of material 'skewed' has other "
                         "-s/-o options than its 'map_Kd' (line 7)"))
        << warnings[0];
    // The scene record keeps the cut-outs.
    const Scene record = load_scene_record(scene_record_json(scene), dir.path() / "x.mrh");
    for (std::size_t m = 0; m < scene.materials.size(); ++m) {
        EXPECT_EQ(record.materials[m].opacity_texture, scene.materials[m].opacity_texture);
    }
}

TEST(MeshMaterials, FacesWithoutUsemtlTakeTheObjectsMaterialOrTheDefault) {
    const testing::ScratchDirectory dir("mesh_materials");
    write_file(dir.path() / "lib.mtl", "newmtl green\nKd 0 1 0\n");
    write_file(dir.path() / "quads.obj",
               "mtllib lib.mtl\n" + three_quads("", "usemtl green\n", ""));
    const Scene with_fallback = load(dir.path(), R"(, "material": "red")");
    EXPECT_EQ(material_of(with_fallback, 0).name, "red");
    EXPECT_EQ(material_of(with_fallback, 2).name, "lib.mtl:green");
    EXPECT_EQ(material_of(with_fallback, 4).name, "lib.mtl:green") << "usemtl holds until the next";

    const Scene without = load(dir.path(), "");
    EXPECT_EQ(material_of(without, 0).name, "default");
    EXPECT_TRUE(material_of(without, 0).diffuse.isApprox(Material{}.diffuse));
    EXPECT_EQ(material_of(without, 2).name, "lib.mtl:green");

    // A mesh without any usemtl and no material is all default.
    write_file(dir.path() / "quads.obj", three_quads("", "", ""));
    const Scene plain = load(dir.path(), "");
    EXPECT_EQ(material_of(plain, 5).name, "default");
}

TEST(MeshMaterials, MissingLibrariesAndMaterialsNameTheFileAndLine) {
    const testing::ScratchDirectory dir("mesh_materials");
    const fs::path obj = dir.path() / "quads.obj";
    const auto message = [&] { return error_message([&] { load(dir.path(), ""); }); };

    write_file(obj, "# header\nmtllib absent.mtl\n" + three_quads("", "", ""));
    std::string m = message();
    EXPECT_TRUE(contains(m, obj.string() + ": line 2: material library 'absent.mtl' not found"))
        << m;
    EXPECT_TRUE(contains(m, (dir.path() / "absent.mtl").string())) << m;

    write_file(dir.path() / "lib.mtl", "newmtl known\n");
    write_file(obj, "mtllib lib.mtl\n" + three_quads("", "usemtl unknown\n", ""));
    m = message();
    EXPECT_TRUE(contains(m, "line 17: material 'unknown' is in none of its libraries (lib.mtl)"))
        << m;

    write_file(obj, three_quads("usemtl known\n", "", ""));
    m = message();
    EXPECT_TRUE(contains(m, "'usemtl known' but the file names no material library")) << m;

    write_file(dir.path() / "lib.mtl", "newmtl known\nmap_Kd gone.png\n");
    write_file(obj, "mtllib lib.mtl\n" + three_quads("usemtl known\n", "", ""));
    m = message();
    EXPECT_TRUE(contains(m, (dir.path() / "lib.mtl").string() + ": line 2: 'map_Kd' texture "
                                                                "'gone.png' not found"))
        << m;

    write_file(dir.path() / "lib.mtl", "newmtl known\nmap_Ks shiny.png\n");
    std::vector<std::string> warnings;
    load(dir.path(), "", &warnings);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_TRUE(contains(warnings[0], "lib.mtl: line 2: 'map_Ks' is not supported")) << warnings[0];
}

TEST(MeshMaterials, EmissiveFacesBecomeOneLightPerFlatConnectedRegion) {
    const testing::ScratchDirectory dir("mesh_materials");
    write_file(dir.path() / "lib.mtl", "newmtl lamp\nKe 2 2 2\nnewmtl other\nKe 1 0 0\n");
    // The two side-by-side quads are one region; the third quad touches neither.
    write_file(dir.path() / "quads.obj",
               "mtllib lib.mtl\n" + three_quads("usemtl lamp\n", "", "usemtl other\n"));
    const fs::path scene_file = dir.path() / "scene.json";
    write_file(scene_file, R"({"camera": {"eye": [0, 0, 5], "look_at": [0, 0, 0]},
        "objects": [{"shape": "mesh", "file": "quads.obj"},
                    {"shape": "mesh", "file": "quads.obj",
                     "transform": [{"scale": [-2, 1, 1]}, {"translate": [0, 0, 3]}]}]})");
    const Scene scene = load_scene(scene_file);
    ASSERT_EQ(scene.mesh_lights.size(), 4u);
    const MeshAreaLight& lamp = scene.mesh_lights[0];
    EXPECT_EQ(lamp.triangles().size(), 4u);
    EXPECT_FLOAT_EQ(lamp.area(), 2.0f);
    EXPECT_TRUE(lamp.centroid().isApprox(Vec3f(1.0f, 0.5f, 0.0f)));
    EXPECT_TRUE(lamp.normal().isApprox(Vec3f(0.0f, 0.0f, 1.0f)));
    EXPECT_TRUE(lamp.radiance().isApprox(Rgb(2.0f, 2.0f, 2.0f)));
    EXPECT_FLOAT_EQ(scene.mesh_lights[1].area(), 1.0f);
    EXPECT_TRUE(scene.mesh_lights[1].radiance().isApprox(Rgb(1.0f, 0.0f, 0.0f)));
    // The mirrored, stretched copy still faces +z, with twice the area, where it was put.
    const MeshAreaLight& copy = scene.mesh_lights[2];
    EXPECT_FLOAT_EQ(copy.area(), 4.0f);
    EXPECT_TRUE(copy.normal().isApprox(Vec3f(0.0f, 0.0f, 1.0f)));
    EXPECT_TRUE(copy.centroid().isApprox(Vec3f(-2.0f, 0.5f, 3.0f)));
    for (const MeshAreaLight::Triangle& t : copy.triangles()) {
        EXPECT_GT((t[1] - t[0]).cross(t[2] - t[0]).dot(copy.normal()), 0.0f)
            << "winding faces the emitting side";
    }
}

TEST(MeshMaterials, TheCornellBoxTakesItsColoursAndLightFromItsLibrary) {
    const auto obj = testing::find_data_file("meshes/cornell-box/CornellBox-Original.obj");
    if (!obj) {
        GTEST_SKIP() << "the shared data's Cornell box is not on the data path";
    }
    const testing::ScratchDirectory dir("mesh_materials");
    const fs::path scene_file = dir.path() / "scene.json";
    write_file(scene_file, R"({"camera": {"eye": [0, 1, 3.9], "look_at": [0, 1, 0]},
        "objects": [{"shape": "mesh", "file": ")" +
                               obj->string() + R"("}]})");
    const Scene scene = load_scene(scene_file);
    EXPECT_EQ(scene.materials.size(), 8u);
    ASSERT_EQ(scene.mesh_lights.size(), 1u);
    const MeshAreaLight& light = scene.mesh_lights[0];
    EXPECT_EQ(light.triangles().size(), 2u);
    EXPECT_NEAR(light.area(), 0.47f * 0.38f, 1e-6f);
    EXPECT_TRUE(light.normal().isApprox(Vec3f(0.0f, -1.0f, 0.0f))) << "it shines down";
    EXPECT_TRUE(light.centroid().isApprox(Vec3f(-0.005f, 1.98f, -0.03f), 1e-5f));
    EXPECT_TRUE(light.radiance().isApprox(Rgb(17.0f, 12.0f, 4.0f)));
}

}  // namespace
}  // namespace mrt
