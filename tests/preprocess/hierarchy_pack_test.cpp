// From the octree to the file and back: quantized records decode to the octree's values within
// the codecs' bounds, a scene stores only the channels its materials need (a diffuse-only
// scene's file has no gradient or transparency channel and is smaller), and mrt-preprocess
// writes a file the reader accepts.

#include "preprocess/hierarchy_pack.h"
#include "common/hierarchy/hierarchy_file.h"
#include "common/mesh/procedural.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace mrt {
namespace {

namespace fs = std::filesystem;

std::vector<Material> materials(bool glass) {
    Material m;
    m.diffuse = Rgb(0.6f, 0.3f, 0.1f);
    m.specular = Rgb::Zero();
    if (glass) {
        m.specular = Rgb(0.3f, 0.3f, 0.3f);
        m.reflectivity = 0.1f;
        m.transparency = 0.8f;
        m.ior = 1.5f;
        m.emission = Rgb(17.0f, 12.0f, 0.004f);  // a glowing glass: every channel present
    }
    return {m};
}

TEST(HierarchyPack, RecordsDecodeToTheOctreeAndRoundTripThroughTheFile) {
    const testing::ScratchDirectory scratch("mrt_hierarchy_pack_test");
    const Mesh sphere = make_sphere(1.0f, 48, 24, 0);
    const std::vector<Material> glass = materials(true);
    const PointOctree octree = build_point_octree(sphere, glass, nullptr, {});
    const HierarchyData data = pack_hierarchy(octree, sphere, glass, R"({"test": true})");
    ASSERT_EQ(data.nodes.size(), octree.nodes.size());
    ASSERT_EQ(data.mirror.size(), data.core.size());
    ASSERT_EQ(data.refraction.size(), data.core.size());
    ASSERT_EQ(data.specular.size(), data.core.size());
    ASSERT_EQ(data.emission.size(), data.core.size());
    EXPECT_TRUE(data.vertex_uvs.empty());  // nothing is textured
    std::size_t point = 0;
    for (std::size_t n = 0; n < octree.nodes.size(); ++n) {
        const OctreeNode& node = octree.nodes[n];
        const HierarchyNode& packed = data.nodes[n];
        EXPECT_EQ(packed.first_point, point);
        ASSERT_EQ(packed.point_count, node.points.size());
        for (const OctreePoint& p : node.points) {
            const PointCore& core = data.core[point];
            EXPECT_EQ(core.voxel, p.voxel);
            EXPECT_NEAR(decode_offset8(data.offset[point].along_normal), p.offset,
                        kOffset8MaxError + 1e-6f);
            // A sphere's surface lies on the normal through the voxel within the voxel.
            EXPECT_LE(std::abs(p.offset), 0.87f);
            EXPECT_LE(testing::angle_between(decode_normal(core.normal).cast<double>(),
                                             p.normal.cast<double>()),
                      kNormalMaxAngularError);
            const Mat2f g = decode_gradient(data.mirror[point].gradient);
            EXPECT_LE((g - p.gradient).cwiseAbs().maxCoeff(),
                      2.0f * kHalfRelativeError * p.gradient.cwiseAbs().maxCoeff() + 1e-6f);
            EXPECT_NEAR(decode_ior8(data.refraction[point].ior), p.ior, 4e-3f);
            for (std::size_t c = 0; c < 3; ++c) {
                // One emitting material: every point's emission is its own, to half precision.
                EXPECT_NEAR(decode_half(data.emission[point].rgb[c]),
                            p.emission[static_cast<int>(c)],
                            kHalfRelativeError * p.emission[static_cast<int>(c)]);
                EXPECT_NEAR(p.emission[static_cast<int>(c)], glass[0].emission[static_cast<int>(c)],
                            1e-5f * glass[0].emission[static_cast<int>(c)]);
            }
            ++point;
        }
        for (const std::int32_t c : node.children) {
            if (c >= 0) {
                EXPECT_EQ(data.nodes[static_cast<std::size_t>(c)].parent, n);
            }
        }
    }

    const fs::path file = scratch.path() / "sphere.mrh";
    write_hierarchy_file(file, data);
    const HierarchyFile read = HierarchyFile::open(file, 1);
    ASSERT_EQ(read.nodes().size(), data.nodes.size());
    ASSERT_EQ(read.core().size(), data.core.size());
    EXPECT_EQ(read.grid(), data.grid);
    EXPECT_EQ(
        std::memcmp(read.core().data(), data.core.data(), data.core.size() * sizeof(PointCore)), 0);
    EXPECT_EQ(read.build_json(), R"({"test": true})");
}

TEST(HierarchyPack, ADiffuseSceneStoresNoGradientOrTransparencyAndIsSmaller) {
    const testing::ScratchDirectory scratch("mrt_hierarchy_pack_test");
    const Mesh sphere = make_sphere(1.0f, 48, 24, 0);
    std::uintmax_t sizes[2] = {0, 0};
    for (const bool glass : {false, true}) {
        const std::vector<Material> m = materials(glass);
        const HierarchyData data =
            pack_hierarchy(build_point_octree(sphere, m, nullptr, {}), sphere, m, "{}");
        const fs::path file = scratch.path() / (glass ? "glass.mrh" : "diffuse.mrh");
        write_hierarchy_file(file, data);
        const HierarchyFile read = HierarchyFile::open(file);
        EXPECT_EQ(read.sections().has(section_tag("PMIR")), glass);
        EXPECT_EQ(read.sections().has(section_tag("PTRN")), glass);
        EXPECT_EQ(read.sections().has(section_tag("PSPC")), glass);
        EXPECT_FALSE(read.sections().has(section_tag("VTUV")));
        EXPECT_EQ(read.mirror().empty(), !glass);
        sizes[glass ? 1 : 0] = fs::file_size(file);
    }
    EXPECT_LT(sizes[0], sizes[1]);
}

TEST(MrtPreprocess, WritesAFileTheReaderAcceptsAndRefusesBadInput) {
    const testing::ScratchDirectory scratch("mrt_hierarchy_pack_test");
    const fs::path out = scratch.path() / "two-spheres.mrh";
    const std::string exe = MRT_PREPROCESS_EXE;
    const std::string scene = std::string(MRT_SOURCE_DIR) + "/data/scenes/two-spheres.json";
    ASSERT_EQ(std::system((exe + " " + scene + " -o " + out.string() + " -q").c_str()), 0);
    // Byte-identical for any number of threads.
    const fs::path one_thread = scratch.path() / "one-thread.mrh";
    ASSERT_EQ(
        std::system((exe + " " + scene + " -o " + one_thread.string() + " -q --threads 1").c_str()),
        0);
    std::ifstream a(out, std::ios::binary), b(one_thread, std::ios::binary);
    EXPECT_TRUE(std::equal(std::istreambuf_iterator<char>(a), std::istreambuf_iterator<char>(),
                           std::istreambuf_iterator<char>(b), std::istreambuf_iterator<char>()));
    const HierarchyFile read = HierarchyFile::open(out);
    EXPECT_GT(read.core().size(), 100u);
    EXPECT_GT(read.triangles().size(), 100u);
    const fs::path log = scratch.path() / "log.txt";
    const int missing = std::system((exe + " " + scratch.path().string() + "/nope.json -o " +
                                     out.string() + " 2>" + log.string())
                                        .c_str());
    EXPECT_NE(missing, 0);
    std::ifstream in(log);
    std::string line;
    std::getline(in, line);
    EXPECT_NE(line.find("nope.json"), std::string::npos) << line;
    EXPECT_NE(
        std::system((exe + " " + scene + " -o " + out.string() + " --grid 0 2>/dev/null").c_str()),
        0);
}

TEST(MrtPreprocess, RefusesAScenePastItsPointBudgetInOneLineNamingTheFile) {
    const testing::ScratchDirectory scratch("mrt_hierarchy_pack_test");
    const fs::path out = scratch.path() / "two-spheres.mrh";
    const fs::path log = scratch.path() / "log.txt";
    const std::string scene = std::string(MRT_SOURCE_DIR) + "/data/scenes/two-spheres.json";
    const int status = std::system((std::string(MRT_PREPROCESS_EXE) + " " + scene + " -o " +
                                    out.string() + " --budget points=100 2>" + log.string())
                                       .c_str());
    EXPECT_NE(status, 0);
    EXPECT_FALSE(fs::exists(out));
    std::ifstream in(log);
    std::string line;
    std::vector<std::string> lines;
    while (std::getline(in, line)) {
        lines.push_back(line);
    }
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_EQ(lines[0].rfind("mrt-preprocess: " + scene + ": mesh '", 0), 0u) << lines[0];
    EXPECT_NE(lines[0].find("representative points (counted so far), over the limit of 100 "
                            "(raise it with --budget points=N)"),
              std::string::npos)
        << lines[0];
}

}  // namespace
}  // namespace mrt
