// The MTL reader against libraries holding every statement it reads, each kind of error it
// reports (with file and line), the warnings for what it skips, and the Cornell box's own library.

#include "common/mesh/mtl_library.h"
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

TEST(MtlLibrary, ReadsEveryStatementItSupports) {
    const testing::ScratchDirectory dir("mtl");
    write_file(dir.path() / "wood.png", "not read here");
    write_file(dir.path() / "leaf mask.png", "not read here");
    const std::string text =
        "# a library\n"
        "newmtl glass  # trailing comment\n"
        "\tKa 0.1 0.1 0.1\n"
        "  Kd 0.2 0.3 0.4\n"
        "Ks 0.9\n"
        "Ke 17 12 4\n"
        "Tf 0.5 0.6 0.7\n"
        "Ns 250\n"
        "Ni 1.33\n"
        "d 0.25\n"
        "illum 7\n"
        "newmtl wood\r\n"
        "Tr 0.1\r\n"
        "map_Kd -s 4 2 1 -o 0.5 0.25 wood.png\r\n"
        "map_d leaf mask.png\r\n";
    const MtlLibrary library = parse_mtl(dir.path() / "lib.mtl", text);
    ASSERT_EQ(library.materials.size(), 2u);
    const MtlMaterial& glass = library.materials[0];
    EXPECT_EQ(glass.name, "glass");
    EXPECT_EQ(glass.line, 2u);
    EXPECT_TRUE(glass.diffuse->isApprox(Rgb(0.2f, 0.3f, 0.4f)));
    EXPECT_TRUE(glass.specular->isApprox(Rgb(0.9f, 0.9f, 0.9f)));  // one value is grey
    EXPECT_TRUE(glass.emission->isApprox(Rgb(17.0f, 12.0f, 4.0f)));
    EXPECT_TRUE(glass.transmission->isApprox(Rgb(0.5f, 0.6f, 0.7f)));
    EXPECT_FLOAT_EQ(*glass.exponent, 250.0f);
    EXPECT_FLOAT_EQ(*glass.ior, 1.33f);
    EXPECT_FLOAT_EQ(*glass.dissolve, 0.25f);
    EXPECT_EQ(*glass.illum, 7);
    EXPECT_FALSE(glass.diffuse_map);

    const MtlMaterial& wood = library.materials[1];
    EXPECT_EQ(wood.line, 12u);
    EXPECT_FLOAT_EQ(*wood.dissolve, 0.9f);  // Tr is 1 − d
    EXPECT_FALSE(wood.diffuse);
    ASSERT_TRUE(wood.diffuse_map);
    EXPECT_EQ(wood.diffuse_map->file, fs::weakly_canonical(dir.path() / "wood.png"));
    EXPECT_EQ(wood.diffuse_map->scale, Vec2f(4.0f, 2.0f));
    EXPECT_EQ(wood.diffuse_map->offset, Vec2f(0.5f, 0.25f));
    EXPECT_EQ(wood.diffuse_map->line, 14u);
    ASSERT_TRUE(wood.alpha_map);  // a file name with a space
    EXPECT_EQ(wood.alpha_map->file.filename(), "leaf mask.png");
    EXPECT_EQ(library.find("wood"), &wood);
    EXPECT_EQ(library.find("stone"), nullptr);
}

TEST(MtlLibrary, WarnsOnceNamingFileAndLineForWhatItSkips) {
    const testing::ScratchDirectory dir("mtl");
    write_file(dir.path() / "t.png", "");
    std::vector<std::string> warnings;
    const MtlLibrary library =
        parse_mtl(dir.path() / "lib.mtl",
                  "newmtl a\nmap_Bump t.png\nbump t.png\nmap_Bump t.png\nrefl -type sphere t.png\n"
                  "map_Kd -clamp on -bm 0.5 t.png\nnewmtl b\nmap_Kd -clamp off t.png\n",
                  [&](const std::string& w) { warnings.push_back(w); });
    ASSERT_EQ(warnings.size(), 5u);
    EXPECT_TRUE(contains(warnings[0], "lib.mtl: line 2: 'map_Bump'")) << warnings[0];
    EXPECT_TRUE(contains(warnings[1], "line 3: 'bump'")) << warnings[1];
    EXPECT_TRUE(contains(warnings[2], "line 5: 'refl'")) << warnings[2];
    EXPECT_TRUE(contains(warnings[3], "line 6: 'map_Kd' option '-clamp'")) << warnings[3];
    EXPECT_TRUE(contains(warnings[4], "line 6: 'map_Kd' option '-bm'")) << warnings[4];
    // The skipped options' values are not taken for the file name.
    EXPECT_EQ(library.materials[1].diffuse_map->file.filename(), "t.png");
}

TEST(MtlLibrary, ReportsEachKindOfErrorWithFileAndLine) {
    const testing::ScratchDirectory dir("mtl");
    const fs::path file = dir.path() / "bad.mtl";
    const auto error = [&](const std::string& text) {
        return error_message([&] { parse_mtl(file, text); });
    };
    const auto expect = [&](const std::string& text, const std::string& location,
                            const std::string& part) {
        const std::string message = error(text);
        EXPECT_TRUE(contains(message, file.string() + ": " + location)) << message;
        EXPECT_TRUE(contains(message, part)) << message;
    };
    expect("Kd 1 1 1\n", "line 1", "'Kd' before any 'newmtl'");
    expect("newmtl\n", "line 1", "'newmtl' without a name");
    expect("newmtl a\nnewmtl b\nnewmtl a\n", "line 3",
           "second material 'a' (the first is on line 1)");
    expect("newmtl a\nKd 1 1\n", "line 2", "'Kd' has 2 values");
    expect("newmtl a\nKs 1 x 1\n", "line 2", "'x', expected a finite number");
    expect("newmtl a\nKe 1 nan 1\n", "line 2", "expected a finite number");
    expect("newmtl a\nKd 1 -0.5 1\n", "line 2", "negative component");
    expect("newmtl a\nKd spectral f.rfl\n", "line 2", "'Kd spectral' colours are not supported");
    expect("newmtl a\nKd xyz 1 1 1\n", "line 2", "'Kd xyz' colours are not supported");
    expect("newmtl a\nNs -1\n", "line 2", "'Ns' is -1, expected at least 0");
    expect("newmtl a\nNi 0\n", "line 2", "expected an index of refraction above 0");
    expect("newmtl a\nd 1.5\n", "line 2", "'d' is 1.5, expected a fraction");
    expect("newmtl a\nTr -0.1\n", "line 2", "'Tr' is -0.1");
    expect("newmtl a\nNs 1 2\n", "line 2", "'Ns' has 2 values, expected one");
    expect("newmtl a\nillum 11\n", "line 2", "'illum 11': expected an integer from 0 to 10");
    expect("newmtl a\nillum 2.5\n", "line 2", "expected an integer");
    expect("newmtl a\n\nmap_Kd\n", "line 3", "'map_Kd' without a texture file");
    expect("newmtl a\nmap_Kd -s 2 2\n", "line 2", "'map_Kd' without a texture file");
    expect("newmtl a\nmap_Kd -q 1 t.png\n", "line 2", "unknown option '-q'");
    expect("newmtl a\nmap_Kd -s\n", "line 2", "option '-s' needs 1 value");
    expect("newmtl a\nmap_d missing.png\n", "line 2",
           "'map_d' texture 'missing.png' not found (looked for " +
               (dir.path() / "missing.png").string());
    EXPECT_TRUE(contains(error_message([&] { read_mtl(dir.path() / "absent.mtl"); }),
                         (dir.path() / "absent.mtl").string() + ": cannot be opened"));
}

TEST(MtlLibrary, ReadsTheCornellBoxLibrary) {
    const auto file = testing::find_data_file("meshes/cornell-box/CornellBox-Original.mtl");
    if (!file) {
        GTEST_SKIP() << "the shared data's Cornell box is not on the data path";
    }
    std::vector<std::string> warnings;
    const MtlLibrary library =
        read_mtl(*file, [&](const std::string& w) { warnings.push_back(w); });
    EXPECT_TRUE(warnings.empty());
    ASSERT_EQ(library.materials.size(), 8u);
    const MtlMaterial* light = library.find("light");
    ASSERT_NE(light, nullptr);
    EXPECT_TRUE(light->emission->isApprox(Rgb(17.0f, 12.0f, 4.0f)));
    const MtlMaterial* left = library.find("leftWall");
    ASSERT_NE(left, nullptr);
    EXPECT_TRUE(left->diffuse->isApprox(Rgb(0.63f, 0.065f, 0.05f)));  // "# Red" is a comment
    EXPECT_TRUE(left->emission->isZero());
    EXPECT_EQ(*left->illum, 2);
}

}  // namespace
}  // namespace mrt
