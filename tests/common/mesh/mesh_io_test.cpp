#include "common/mesh/mesh_io.h"
#include "common/mesh/mesh.h"
#include "common/scene_io/data_path.h"
#include "common/system/error.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace mrt {
namespace {

namespace fs = std::filesystem;

// ------------------------------------------------------------------------------------------
// Helpers.

/// A fresh directory under the system temp dir, removed with everything in it afterwards.
class TempDir {
  public:
    TempDir() {
        static std::atomic<int> counter{0};
        std::random_device random;
        const std::string unique =
            "mrt_mesh_io_test_" + std::to_string(random()) + "_" + std::to_string(counter++);
        path_ = fs::temp_directory_path() / unique;
        fs::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ignored;
        fs::remove_all(path_, ignored);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    fs::path write(const std::string& name, std::string_view contents) const {
        const fs::path file = path_ / name;
        std::ofstream out(file, std::ios::binary);
        out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
        return file;
    }
    const fs::path& path() const { return path_; }

  private:
    fs::path path_;
};

/// Little-endian byte strings for the binary formats.
class Bytes {
  public:
    Bytes& text(std::string_view s) {
        data_.append(s);
        return *this;
    }
    Bytes& f32(float v) {
        std::uint32_t bits = 0;
        std::memcpy(&bits, &v, 4);
        return u32(bits);
    }
    Bytes& u32(std::uint32_t v) {
        for (int i = 0; i < 4; ++i) {
            data_.push_back(static_cast<char>((v >> (8 * i)) & 0xffu));
        }
        return *this;
    }
    Bytes& i32(std::int32_t v) { return u32(static_cast<std::uint32_t>(v)); }
    Bytes& u16(std::uint16_t v) {
        data_.push_back(static_cast<char>(v & 0xffu));
        data_.push_back(static_cast<char>(v >> 8));
        return *this;
    }
    Bytes& u8(std::uint8_t v) {
        data_.push_back(static_cast<char>(v));
        return *this;
    }
    const std::string& str() const { return data_; }

  private:
    std::string data_;
};

/// The message load_mesh throws, or "" when it does not throw.
std::string load_error(const fs::path& file) {
    try {
        load_mesh(file, 0);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

/// Expects load_mesh to refuse `file` with a message starting with the file's path and
/// containing every piece of `expected`.
void expect_refused(const fs::path& file, std::initializer_list<std::string_view> expected) {
    const std::string message = load_error(file);
    ASSERT_FALSE(message.empty()) << file << " was accepted";
    EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0u) << message;
    for (const std::string_view piece : expected) {
        EXPECT_NE(message.find(piece), std::string::npos)
            << "'" << message << "' lacks '" << piece << "'";
    }
    EXPECT_EQ(message.find('\n'), std::string::npos) << "not one line: " << message;
}

double triangle_area(const Mesh& m, std::size_t t) {
    const Vec3d a = m.positions[m.triangles[t][0]].cast<double>();
    const Vec3d b = m.positions[m.triangles[t][1]].cast<double>();
    const Vec3d c = m.positions[m.triangles[t][2]].cast<double>();
    return 0.5 * (b - a).cross(c - a).norm();
}

double total_area(const Mesh& m) {
    double sum = 0.0;
    for (std::size_t t = 0; t < m.triangle_count(); ++t) {
        sum += triangle_area(m, t);
    }
    return sum;
}

Vec3f geometric_normal(const Mesh& m, std::size_t t) {
    const Vec3f& a = m.positions[m.triangles[t][0]];
    const Vec3f& b = m.positions[m.triangles[t][1]];
    const Vec3f& c = m.positions[m.triangles[t][2]];
    return (b - a).cross(c - a).normalized();
}

/// Checks the invariants every loaded mesh must satisfy.
void expect_well_formed(const Mesh& m) {
    ASSERT_EQ(m.normals.size(), m.positions.size());
    if (m.has_uvs()) {
        ASSERT_EQ(m.uvs.size(), m.positions.size());
    }
    ASSERT_EQ(m.materials.size(), m.triangles.size());
    for (const auto& t : m.triangles) {
        for (const std::uint32_t v : t) {
            ASSERT_LT(v, m.positions.size());
        }
    }
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        ASSERT_TRUE(m.positions[v].allFinite()) << "vertex " << v;
        ASSERT_TRUE(m.normals[v].allFinite()) << "vertex " << v;
        ASSERT_NEAR(m.normals[v].norm(), 1.0f, 1e-5f) << "vertex " << v;
    }
}

/// Index of the vertex at `p` with uv `uv`, or nothing.
std::optional<std::size_t> find_vertex(const Mesh& m, const Vec3f& p,
                                       std::optional<Vec2f> uv = std::nullopt) {
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        if ((m.positions[v] - p).norm() < 1e-6f && (!uv || (m.uvs[v] - *uv).norm() < 1e-6f)) {
            return v;
        }
    }
    return std::nullopt;
}

// ------------------------------------------------------------------------------------------
// Mesh basics (common/mesh/mesh.cpp).

Mesh make_mesh(std::vector<Vec3f> positions, std::vector<std::array<std::uint32_t, 3>> triangles) {
    Mesh m;
    m.name = "test";
    m.positions = std::move(positions);
    m.triangles = std::move(triangles);
    m.materials.resize(m.triangles.size());
    for (std::size_t i = 0; i < m.materials.size(); ++i) {
        m.materials[i] = static_cast<std::uint32_t>(i);
    }
    return m;
}

TEST(Mesh, BoundsOfEmptyMeshAreInfinitelyInverted) {
    const Eigen::AlignedBox3f b = Mesh{}.bounds();
    EXPECT_EQ(b.min(), Vec3f::Constant(kInfinity));
    EXPECT_EQ(b.max(), Vec3f::Constant(-kInfinity));
}

TEST(Mesh, BoundsAreTightAroundPositions) {
    const Mesh m = make_mesh({{1, -2, 3}, {-4, 5, 0.5f}, {0, 0, -6}}, {{0, 1, 2}});
    EXPECT_EQ(m.bounds().min(), Vec3f(-4, -2, -6));
    EXPECT_EQ(m.bounds().max(), Vec3f(1, 5, 3));
}

TEST(Mesh, VertexNormalsWeightFacesByCornerAngle) {
    // At the origin, the +z face has a 90° corner and the +x face a 45° one; both have area 1/2,
    // so area weighting alone would give (1, 0, 1)/√2.
    Mesh m = make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 1, 1}}, {{0, 1, 2}, {0, 2, 3}});
    compute_vertex_normals(m);
    ASSERT_EQ(m.normals.size(), 4u);
    const Vec3f expected = Vec3f(1, 0, 2).normalized();
    EXPECT_LT((m.normals[0] - expected).norm(), 1e-6f) << m.normals[0].transpose();
    EXPECT_LT((m.normals[1] - Vec3f(0, 0, 1)).norm(), 1e-6f);
    EXPECT_LT((m.normals[3] - Vec3f(1, 0, 0)).norm(), 1e-6f);
}

TEST(Mesh, VertexNormalsSkipDegenerateFacesAndDefaultToZ) {
    // Vertex 3 only touches a zero-area triangle; vertex 5 touches nothing.
    Mesh m = make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {2, 0, 0}, {0, 0, 0}, {7, 7, 7}},
                       {{0, 2, 1}, {0, 1, 3}, {0, 4, 1}});
    compute_vertex_normals(m);
    EXPECT_LT((m.normals[0] - Vec3f(0, 1, 0)).norm(), 1e-6f);
    EXPECT_LT((m.normals[3] - Vec3f(0, 0, 1)).norm(), 1e-6f);
    EXPECT_LT((m.normals[5] - Vec3f(0, 0, 1)).norm(), 1e-6f);
    for (const Vec3f& n : m.normals) {
        EXPECT_TRUE(n.allFinite());
    }
}

TEST(Mesh, VertexNormalsOfBackToBackFacesStayUnit) {
    // Two coincident faces of opposite orientation cancel exactly; the result must still be a
    // unit normal of one of them, not NaN.
    Mesh m = make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 1}});
    compute_vertex_normals(m);
    for (const Vec3f& n : m.normals) {
        EXPECT_NEAR(n.norm(), 1.0f, 1e-6f);
        EXPECT_NEAR(std::abs(n.z()), 1.0f, 1e-6f);
    }
}

TEST(Mesh, RemoveDegenerateTrianglesDropsZeroAreaRepeatedAndNonFinite) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    Mesh m = make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {nan, 0, 0}, {1e-30f, 0, 0}},
                       {
                           {0, 1, 2},  // kept, material 0
                           {0, 1, 3},  // collinear
                           {0, 0, 2},  // repeated index
                           {0, 1, 4},  // NaN vertex
                           {1, 2, 0},  // kept, material 4
                           {0, 5, 2},  // edge below float resolution next to the others
                           {0, 1, 9},  // index out of range
                       });
    EXPECT_EQ(remove_degenerate_triangles(m), 5u);
    ASSERT_EQ(m.triangles.size(), 2u);
    EXPECT_EQ(m.triangles[0], (std::array<std::uint32_t, 3>{0, 1, 2}));
    EXPECT_EQ(m.triangles[1], (std::array<std::uint32_t, 3>{1, 2, 0}));
    EXPECT_EQ(m.materials, (std::vector<std::uint32_t>{0, 4}));
}

TEST(Mesh, RemoveDegenerateTrianglesKeepsThinButRealTriangles) {
    // A 1000:1 sliver far from the origin is thin, not degenerate.
    Mesh m = make_mesh({{1000, 0, 0}, {1001, 0, 0}, {1000.5f, 0.001f, 0}}, {{0, 1, 2}});
    EXPECT_EQ(remove_degenerate_triangles(m), 0u);
    EXPECT_EQ(m.triangles.size(), 1u);
}

TEST(Mesh, StreamOutputNamesMeshCountsAndBounds) {
    Mesh m = make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 2, 0}}, {{0, 1, 2}});
    m.name = "tri.obj";
    std::ostringstream os;
    os << m;
    const std::string s = os.str();
    EXPECT_NE(s.find("tri.obj"), std::string::npos) << s;
    EXPECT_NE(s.find("3 vertices"), std::string::npos) << s;
    EXPECT_NE(s.find("1 triangles"), std::string::npos) << s;
    EXPECT_NE(s.find("(0, 0, 0)"), std::string::npos) << s;
    EXPECT_NE(s.find("(1, 2, 0)"), std::string::npos) << s;
    EXPECT_EQ(s.find('\n'), std::string::npos) << s;
}

// ------------------------------------------------------------------------------------------
// Loading good files.

constexpr std::string_view kObjQuad =
    "# unit quad in the XY plane, as two triangles\n"
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 1 1 0\n"
    "v 0 1 0\n"
    "f 1 2 3\n"
    "f 1 3 4\n";

TEST(MeshIo, LoadsObjTrianglesAndComputesNormals) {
    TempDir dir;
    const MeshLoadResult r = load_mesh(dir.write("quad.obj", kObjQuad), 7);
    const Mesh& m = r.mesh;
    expect_well_formed(m);
    EXPECT_EQ(m.name, "quad.obj");
    EXPECT_EQ(m.positions.size(), 4u);
    EXPECT_EQ(m.triangle_count(), 2u);
    EXPECT_FALSE(m.has_uvs());
    EXPECT_FALSE(r.normals_from_file);
    EXPECT_EQ(r.degenerate_triangles_removed, 0u);
    EXPECT_EQ(m.positions[2], Vec3f(1, 1, 0));
    EXPECT_EQ(m.triangles[1], (std::array<std::uint32_t, 3>{0, 2, 3}));
    for (const Vec3f& n : m.normals) {
        EXPECT_LT((n - Vec3f(0, 0, 1)).norm(), 1e-6f);
    }
    EXPECT_EQ(m.materials, (std::vector<std::uint32_t>{7, 7}));
}

TEST(MeshIo, UsesObjNormalsNormalisedAndRecomputesBadOnes) {
    TempDir dir;
    const fs::path file = dir.write("normals.obj",
                                    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                                    "vn 0 0 3\n"    // not unit: normalised
                                    "vn 0 0 0\n"    // zero: recomputed
                                    "vn 1 0 0\n"    // deliberately not the face normal
                                    "vn nan 0 1\n"  // non-finite: recomputed
                                    "f 1//1 2//2 3//3\n"
                                    "f 2//1 4//4 3//3\n");
    const MeshLoadResult r = load_mesh(file, 0);
    expect_well_formed(r.mesh);
    EXPECT_TRUE(r.normals_from_file);
    const Mesh& m = r.mesh;
    // Vertex 2 (index 1) appears with normals 2 and 1: two vertices at the same position.
    EXPECT_EQ(m.positions.size(), 5u);
    EXPECT_LT((m.normals[0] - Vec3f(0, 0, 1)).norm(), 1e-6f);
    EXPECT_LT((m.normals[2] - Vec3f(1, 0, 0)).norm(), 1e-6f);  // from the file, as written
    EXPECT_LT((m.normals[3] - Vec3f(0, 0, 1)).norm(), 1e-6f);  // recomputed
    EXPECT_LT((m.normals[1] - Vec3f(0, 0, 1)).norm(), 1e-6f);  // recomputed
}

TEST(MeshIo, TriangulatesObjPolygons) {
    TempDir dir;
    // A unit square as one quad and a regular-ish pentagon next to it.
    const fs::path file = dir.write("polygons.obj",
                                    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                    "v 2 0 0\nv 2.5 0.5 0\nv 2 1 0\n"
                                    "f 1 2 3 4\n"
                                    "f 2 5 6 7 3\n");
    const MeshLoadResult r = load_mesh(file, 0);
    expect_well_formed(r.mesh);
    EXPECT_EQ(r.mesh.positions.size(), 7u);
    EXPECT_EQ(r.mesh.triangle_count(), 5u);
    EXPECT_NEAR(total_area(r.mesh), 1.0 + 1.0 + 0.25, 1e-6);
    for (std::size_t t = 0; t < r.mesh.triangle_count(); ++t) {
        EXPECT_GT(geometric_normal(r.mesh, t).z(), 0.99f) << "triangle " << t;
    }
}

TEST(MeshIo, KeepsPerCornerUvsOfTriangulatedObjQuad) {
    // OpenMesh's TriMesh importer puts a polygon's corner texcoords on the wrong halfedges once
    // it has triangulated it; every vertex here must keep exactly its own uv.
    TempDir dir;
    const fs::path file = dir.write("quad_uv.obj",
                                    "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\n"
                                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                    "f 1/1 2/2 3/3 4/4\n");
    const MeshLoadResult r = load_mesh(file, 0);
    const Mesh& m = r.mesh;
    expect_well_formed(m);
    ASSERT_TRUE(m.has_uvs());
    ASSERT_EQ(m.positions.size(), 4u);
    EXPECT_EQ(m.triangle_count(), 2u);
    for (std::size_t v = 0; v < 4; ++v) {
        EXPECT_LT((m.uvs[v] - m.positions[v].head<2>() / 2.0f).norm(), 1e-6f) << "vertex " << v;
    }
}

TEST(MeshIo, SplitsObjVerticesAtUvSeamAndKeepsNormalsSmooth) {
    // Two triangles folded along the shared edge 2–3; vertex 2 carries a different uv in each
    // face (a seam), vertex 3 the same one. Only vertex 2 is split.
    TempDir dir;
    const fs::path file = dir.write("seam.obj",
                                    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 1 0 1\n"
                                    "vt 0 0\nvt 1 0\nvt 0.5 0.5\nvt 0 1\nvt 0.9 0.1\n"
                                    "f 1/1 2/2 3/3\n"
                                    "f 2/5 4/4 3/3\n");
    const MeshLoadResult r = load_mesh(file, 0);
    const Mesh& m = r.mesh;
    expect_well_formed(m);
    ASSERT_TRUE(m.has_uvs());
    ASSERT_EQ(m.positions.size(), 5u);
    const auto a = find_vertex(m, Vec3f(1, 0, 0), Vec2f(1, 0));
    const auto b = find_vertex(m, Vec3f(1, 0, 0), Vec2f(0.9f, 0.1f));
    ASSERT_TRUE(a && b);
    EXPECT_NE(*a, *b);
    // The seam is in the texture only: both copies get the same, averaged normal.
    EXPECT_LT((m.normals[*a] - m.normals[*b]).norm(), 1e-6f);
    // Both faces have a right angle there: the +z and −x normals count equally.
    EXPECT_LT((m.normals[*a] - Vec3f(-1, 0, 1).normalized()).norm(), 1e-6f)
        << m.normals[*a].transpose();
    // Each triangle uses its own copy.
    const auto uses = [&](std::size_t t, std::size_t v) {
        return std::find(m.triangles[t].begin(), m.triangles[t].end(), v) != m.triangles[t].end();
    };
    EXPECT_TRUE(uses(0, *a));
    EXPECT_TRUE(uses(1, *b));
}

TEST(MeshIo, SharesObjVerticesWhoseCornersAgree) {
    TempDir dir;
    const fs::path file = dir.write("shared.obj",
                                    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                    "f 1/1 2/2 3/3\n"
                                    "f 1/1 3/3 4/4\n");
    const MeshLoadResult r = load_mesh(file, 0);
    EXPECT_EQ(r.mesh.positions.size(), 4u);
    EXPECT_EQ(r.mesh.triangle_count(), 2u);
}

TEST(MeshIo, ResolvesNegativeObjIndices) {
    TempDir dir;
    const fs::path file = dir.write("negative.obj",
                                    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
                                    "v 5 5 5\nv 6 5 5\nv 5 6 5\nf -3 -2 -1\n");
    const MeshLoadResult r = load_mesh(file, 0);
    ASSERT_EQ(r.mesh.triangle_count(), 2u);
    EXPECT_EQ(r.mesh.triangles[0], (std::array<std::uint32_t, 3>{0, 1, 2}));
    EXPECT_EQ(r.mesh.triangles[1], (std::array<std::uint32_t, 3>{3, 4, 5}));
}

TEST(MeshIo, AcceptsUppercaseExtension) {
    TempDir dir;
    const MeshLoadResult r = load_mesh(dir.write("QUAD.OBJ", kObjQuad), 0);
    EXPECT_EQ(r.mesh.triangle_count(), 2u);
}

std::string ply_vertex_header(std::string_view format, int vertices, int faces) {
    return "ply\nformat " + std::string(format) +
           " 1.0\n"
           "comment written by mesh_io_test\n"
           "element vertex " +
           std::to_string(vertices) +
           "\n"
           "property float x\nproperty float y\nproperty float z\n"
           "property float nx\nproperty float ny\nproperty float nz\n"
           "element face " +
           std::to_string(faces) +
           "\n"
           "property list uchar int vertex_indices\n"
           "end_header\n";
}

TEST(MeshIo, LoadsAsciiPlyWithNormals) {
    TempDir dir;
    const fs::path file = dir.write("square.ply", ply_vertex_header("ascii", 4, 1) +
                                                      "0 0 0 0 0 2\n"
                                                      "1 0 0 0 0 2\n"
                                                      "1 1 0 0 0 2\n"
                                                      "0 1 0 0 0 2\n"
                                                      "4 0 1 2 3\n");
    const MeshLoadResult r = load_mesh(file, 3);
    const Mesh& m = r.mesh;
    expect_well_formed(m);
    EXPECT_TRUE(r.normals_from_file);
    EXPECT_EQ(m.positions.size(), 4u);
    EXPECT_EQ(m.triangle_count(), 2u);
    EXPECT_EQ(m.positions[2], Vec3f(1, 1, 0));
    for (const Vec3f& n : m.normals) {
        EXPECT_EQ(n, Vec3f(0, 0, 1));
    }
    EXPECT_NEAR(total_area(m), 1.0, 1e-6);
}

Bytes binary_ply(const std::vector<Vec3f>& positions,
                 const std::vector<std::vector<std::int32_t>>& faces) {
    Bytes b;
    b.text("ply\nformat binary_little_endian 1.0\nelement vertex " +
           std::to_string(positions.size()) +
           "\nproperty float x\nproperty float y\nproperty float z\n"
           "element face " +
           std::to_string(faces.size()) + "\nproperty list uchar int vertex_indices\nend_header\n");
    for (const Vec3f& p : positions) {
        b.f32(p.x()).f32(p.y()).f32(p.z());
    }
    for (const auto& f : faces) {
        b.u8(static_cast<std::uint8_t>(f.size()));
        for (const std::int32_t i : f) {
            b.i32(i);
        }
    }
    return b;
}

TEST(MeshIo, LoadsBinaryLittleEndianPly) {
    TempDir dir;
    const fs::path file =
        dir.write("tetra.ply", binary_ply({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
                                          {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}})
                                   .str());
    const MeshLoadResult r = load_mesh(file, 0);
    const Mesh& m = r.mesh;
    expect_well_formed(m);
    EXPECT_FALSE(r.normals_from_file);
    EXPECT_EQ(m.positions.size(), 4u);
    EXPECT_EQ(m.triangle_count(), 4u);
    EXPECT_EQ(m.positions[3], Vec3f(0, 0, 1));
    // A closed, outward-wound tetrahedron: the corner normal at the origin points inwards-out.
    EXPECT_LT((m.normals[0] - Vec3f(-1, -1, -1).normalized()).norm(), 1e-5f);
}

TEST(MeshIo, LoadsOffAndTriangulatesItsQuads) {
    TempDir dir;
    const fs::path file = dir.write("square.off",
                                    "OFF\n"
                                    "5 2 0\n"
                                    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0\n"
                                    "4 0 1 2 3\n"
                                    "3 1 4 2\n");
    const MeshLoadResult r = load_mesh(file, 0);
    expect_well_formed(r.mesh);
    EXPECT_EQ(r.mesh.positions.size(), 5u);
    EXPECT_EQ(r.mesh.triangle_count(), 3u);
    EXPECT_NEAR(total_area(r.mesh), 1.5, 1e-6);
}

Bytes binary_off(const std::vector<Vec3f>& positions,
                 const std::vector<std::vector<std::uint32_t>>& faces) {
    Bytes b;
    b.text("OFF BINARY\n");
    b.u32(static_cast<std::uint32_t>(positions.size()));
    b.u32(static_cast<std::uint32_t>(faces.size()));
    b.u32(0);
    for (const Vec3f& p : positions) {
        b.f32(p.x()).f32(p.y()).f32(p.z());
    }
    for (const auto& f : faces) {
        b.u32(static_cast<std::uint32_t>(f.size()));
        for (const std::uint32_t i : f) {
            b.u32(i);
        }
    }
    return b;
}

TEST(MeshIo, LoadsBinaryOff) {
    TempDir dir;
    const fs::path file =
        dir.write("square.off",
                  binary_off({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2, 3}}).str());
    const MeshLoadResult r = load_mesh(file, 0);
    expect_well_formed(r.mesh);
    EXPECT_EQ(r.mesh.triangle_count(), 2u);
    EXPECT_NEAR(total_area(r.mesh), 1.0, 1e-6);
}

TEST(MeshIo, LoadsPerVertexUvsFromPly) {
    TempDir dir;
    const fs::path file = dir.write("uv.ply",
                                    "ply\nformat ascii 1.0\nelement vertex 3\n"
                                    "property float x\nproperty float y\nproperty float z\n"
                                    "property float u\nproperty float v\n"
                                    "element face 1\nproperty list uchar int vertex_indices\n"
                                    "end_header\n"
                                    "0 0 0 0 0\n2 0 0 1 0\n0 2 0 0 1\n3 0 1 2\n");
    const MeshLoadResult r = load_mesh(file, 0);
    ASSERT_TRUE(r.mesh.has_uvs());
    for (std::size_t v = 0; v < 3; ++v) {
        EXPECT_EQ(r.mesh.uvs[v], r.mesh.positions[v].head<2>() / 2.0f);
    }
}

std::string ascii_stl(const std::vector<std::array<Vec3f, 3>>& facets) {
    std::ostringstream s;
    s << "solid test\n";
    for (const auto& f : facets) {
        s << "  facet normal 0 0 0\n    outer loop\n";
        for (const Vec3f& p : f) {
            s << "      vertex " << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
        }
        s << "    endloop\n  endfacet\n";
    }
    s << "endsolid test\n";
    return s.str();
}

Bytes binary_stl(const std::vector<std::array<Vec3f, 3>>& facets) {
    Bytes b;
    b.text(std::string(80, ' ').replace(0, 12, "binary test "));
    b.u32(static_cast<std::uint32_t>(facets.size()));
    for (const auto& f : facets) {
        b.f32(0).f32(0).f32(0);
        for (const Vec3f& p : f) {
            b.f32(p.x()).f32(p.y()).f32(p.z());
        }
        b.u16(0);
    }
    return b;
}

// A roof: two facets meeting at a ridge along y at x = 1, z = 1.
const std::vector<std::array<Vec3f, 3>> kRoof = {
    {{{0, 0, 0}, {1, 0, 1}, {1, 1, 1}}},
    {{{0, 0, 0}, {1, 1, 1}, {0, 1, 0}}},
    {{{1, 0, 1}, {2, 0, 0}, {2, 1, 0}}},
    {{{1, 0, 1}, {2, 1, 0}, {1, 1, 1}}},
};

void expect_welded_roof(const MeshLoadResult& r) {
    const Mesh& m = r.mesh;
    expect_well_formed(m);
    EXPECT_FALSE(r.normals_from_file);
    // STL repeats each corner per facet; welding by position leaves 6 distinct vertices.
    EXPECT_EQ(m.positions.size(), 6u);
    EXPECT_EQ(m.triangle_count(), 4u);
    // Ridge vertices are shared by both slopes, so their normals point straight up.
    const auto ridge = find_vertex(m, Vec3f(1, 0, 1));
    ASSERT_TRUE(ridge);
    EXPECT_LT((m.normals[*ridge] - Vec3f(0, 0, 1)).norm(), 1e-6f);
    EXPECT_NEAR(total_area(m), 2.0 * std::sqrt(2.0), 1e-5);
}

TEST(MeshIo, LoadsAsciiStlWeldingCorners) {
    TempDir dir;
    expect_welded_roof(load_mesh(dir.write("roof.stl", ascii_stl(kRoof)), 0));
}

TEST(MeshIo, LoadsBinaryStlWeldingCorners) {
    TempDir dir;
    expect_welded_roof(load_mesh(dir.write("roof.stl", binary_stl(kRoof).str()), 0));
}

TEST(MeshIo, LoadsBinaryStlWhoseHeaderStartsWithSolid) {
    // Many exporters write "solid" into binary headers too; the size decides.
    TempDir dir;
    std::string bytes = binary_stl(kRoof).str();
    bytes.replace(0, 5, "solid");
    expect_welded_roof(load_mesh(dir.write("roof.stl", bytes), 0));
}

// ------------------------------------------------------------------------------------------
// Degenerate input.

TEST(MeshIo, DropsAndCountsDegenerateObjTriangles) {
    TempDir dir;
    const fs::path file = dir.write("degenerate.obj",
                                    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\n"
                                    "f 1 2 3\n"
                                    "f 1 1 2\n"      // repeated index (OpenMesh drops it)
                                    "f 1 2 4\n"      // collinear
                                    "f 1 2 3 3\n");  // quad with a collapsed corner
    const MeshLoadResult r = load_mesh(file, 0);
    expect_well_formed(r.mesh);
    EXPECT_EQ(r.mesh.triangle_count(), 2u);
    EXPECT_EQ(r.degenerate_triangles_removed, 3u);
}

TEST(MeshIo, DropsAndCountsDegenerateStlFacets) {
    TempDir dir;
    auto facets = kRoof;
    facets.push_back({{{0, 0, 0}, {0, 0, 0}, {0, 1, 0}}});  // two corners weld together
    facets.push_back({{{0, 0, 0}, {1, 0, 1}, {2, 0, 2}}});  // collinear
    const MeshLoadResult r = load_mesh(dir.write("roof.stl", binary_stl(facets).str()), 0);
    EXPECT_EQ(r.mesh.triangle_count(), 4u);
    EXPECT_EQ(r.degenerate_triangles_removed, 2u);
}

TEST(MeshIo, DropsAndCountsDegeneratePlyFaces) {
    TempDir dir;
    const fs::path file = dir.write(
        "degenerate.ply",
        binary_ply({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 0, 1}, {2, 1, 1}}).str());
    const MeshLoadResult r = load_mesh(file, 0);
    EXPECT_EQ(r.mesh.triangle_count(), 1u);
    EXPECT_EQ(r.degenerate_triangles_removed, 2u);
}

// ------------------------------------------------------------------------------------------
// Refused files.

TEST(MeshIo, RefusesMissingFileWithFileName) {
    TempDir dir;
    expect_refused(dir.path() / "nothing_here.obj", {"file not found"});
}

TEST(MeshIo, RefusesDirectory) {
    TempDir dir;
    fs::create_directory(dir.path() / "folder.obj");
    expect_refused(dir.path() / "folder.obj", {"directory"});
}

TEST(MeshIo, RefusesUnknownExtensionListingSupportedOnes) {
    TempDir dir;
    expect_refused(dir.write("mesh.xyz", kObjQuad), {"'.xyz'", ".obj", ".ply", ".off", ".stl"});
    expect_refused(dir.write("mesh", kObjQuad), {"unknown mesh format", ".obj"});
}

TEST(MeshIo, RefusesEmptyFiles) {
    TempDir dir;
    for (const char* name : {"empty.obj", "empty.ply", "empty.off", "empty.stl"}) {
        expect_refused(dir.write(name, ""), {"empty"});
    }
    expect_refused(dir.write("blank.obj", "\n  \n"), {"empty"});
}

TEST(MeshIo, RefusesFilesWithoutTriangles) {
    TempDir dir;
    expect_refused(dir.write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"), {"no triangles"});
    expect_refused(dir.write("points.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n"), {"no triangles"});
    expect_refused(dir.write("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"),
                   {"no triangles with non-zero area"});
}

TEST(MeshIo, RefusesNanCoordinateNamingVertex) {
    TempDir dir;
    // OpenMesh's OBJ reader would silently skip this line and shift every later index.
    expect_refused(dir.write("nan.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv nan 1 0\nf 1 2 3\n"),
                   {"line 4", "vertex 4", "non-finite"});
    expect_refused(dir.write("inf.obj", "v 0 0 0\nv 1e39 0 0\nv 1 1 0\nf 1 2 3\n"),
                   {"line 2", "vertex 2", "non-finite"});
    expect_refused(dir.write("nan.off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n"),
                   {"line 4", "vertex 1", "non-finite"});
    expect_refused(dir.write("nan.ply", ply_vertex_header("ascii", 3, 1) +
                                            "0 0 0 0 0 1\n1 0 0 0 0 1\n0 inf 0 0 0 1\n"
                                            "3 0 1 2\n"),
                   {"vertex 2", "non-finite"});
    const float nan = std::numeric_limits<float>::quiet_NaN();
    expect_refused(dir.write("nan_binary.ply",
                             binary_ply({{0, 0, 0}, {1, 0, 0}, {0, nan, 0}}, {{0, 1, 2}}).str()),
                   {"vertex 2", "non-finite"});
    auto facets = kRoof;
    facets[2][1].x() = nan;
    expect_refused(dir.write("nan_binary.stl", binary_stl(facets).str()),
                   {"facet 2", "non-finite"});
    expect_refused(dir.write("nan_ascii.stl", ascii_stl(facets)), {"facet 2", "finite"});
}

TEST(MeshIo, RefusesOutOfRangeIndexWithFileName) {
    TempDir dir;
    expect_refused(dir.write("index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n"),
                   {"line 5", "vertex 9", "3 vertices"});
    expect_refused(dir.write("negative.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n"),
                   {"line 4", "vertex -4"});
    expect_refused(dir.write("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"),
                   {"line 4", "vertex index '0'"});
    expect_refused(dir.write("uv_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n"),
                   {"line 5", "texture coordinate 2"});
    expect_refused(dir.write("normal_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n"),
                   {"line 4", "normal 1"});
    expect_refused(dir.write("index.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 7\n"),
                   {"line 7", "face 1", "vertex '7'"});
    expect_refused(dir.write("index.ply", ply_vertex_header("ascii", 3, 2) +
                                              "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n"
                                              "3 0 1 2\n3 0 1 5\n"),
                   {"line 18", "face 1", "vertex 5"});
    expect_refused(dir.write("index_binary.off",
                             binary_off({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 3}}).str()),
                   {"face 0", "vertex 3"});
    expect_refused(
        dir.write("index_binary.ply",
                  binary_ply({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, -1, 2}}).str()),
        {"face 1", "vertex -1"});
}

TEST(MeshIo, RefusesGarbageBytesInEveryFormat) {
    TempDir dir;
    std::mt19937 random(1234);
    std::string garbage(4096, '\0');
    for (char& c : garbage) {
        c = static_cast<char>(random() & 0xffu);
    }
    for (const char* name : {"garbage.obj", "garbage.ply", "garbage.off", "garbage.stl"}) {
        expect_refused(dir.write(name, garbage), {});
    }
    expect_refused(dir.write("text.ply", "this is not a mesh\n"), {"not a PLY file"});
    expect_refused(dir.write("text.off", "this is not a mesh\n"), {"not an OFF file"});
    expect_refused(dir.write("text.stl", "this is not a mesh\n"), {"not an STL file"});
    expect_refused(dir.write("text.obj", "this is not a mesh\n"), {"no triangles"});
}

TEST(MeshIo, RefusesTruncatedFiles) {
    TempDir dir;
    const std::string ply =
        binary_ply({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{0, 2, 1}, {0, 1, 3}}).str();
    expect_refused(dir.write("truncated.ply", ply.substr(0, ply.size() - 6)), {"truncated"});
    expect_refused(dir.write("truncated.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n"),
                   {"ends before", "face 1"});
    // A header claiming a hundred million faces must not make OpenMesh loop over them.
    std::string off = binary_off({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}).str();
    off.replace(std::string_view("OFF BINARY\n").size() + 4, 4, Bytes().u32(100000000).str());
    expect_refused(dir.write("lying.off", off), {"truncated", "face 1"});
    // A binary STL whose size does not match its facet count is not binary, and not ASCII.
    const std::string stl = binary_stl(kRoof).str();
    expect_refused(dir.write("truncated.stl", stl.substr(0, stl.size() - 10)), {"not an STL file"});
}

TEST(MeshIo, RefusesPlyWhoseFormatLineIsNotSecond) {
    // OpenMesh would read "two" as the format name here.
    TempDir dir;
    expect_refused(dir.write("comment_first.ply",
                             "ply\ncomment two triangles\nformat ascii 1.0\nelement vertex 0\n"
                             "end_header\n"),
                   {"line 2", "'format'"});
}

TEST(MeshIo, RefusesPlyHeadersOpenMeshWouldMisreadOrHangOn) {
    TempDir dir;
    const std::string vertices =
        "element vertex 3\nproperty float x\nproperty float y\n"
        "property float z\n";
    const std::string faces = "element face 1\nproperty list uchar int vertex_indices\n";
    const std::string body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    // OpenMesh loops forever on a header word that does not parse or a missing end_header.
    expect_refused(dir.write("version.ply",
                             "ply\nformat ascii one\n" + vertices + faces + "end_header\n" + body),
                   {"line 2", "format"});
    expect_refused(dir.write("count.ply", "ply\nformat ascii 1.0\nelement vertex three\n"),
                   {"line 3", "element count"});
    expect_refused(dir.write("no_end.ply", "ply\nformat ascii 1.0\n" + vertices), {"end_header"});
    // It reads any list but a face's vertex indices as one value, misaligning what follows.
    expect_refused(
        dir.write("texcoord_list.ply", "ply\nformat ascii 1.0\n" + vertices + faces +
                                           "property list uchar float texcoord\nend_header\n" +
                                           "0 0 0\n1 0 0\n0 1 0\n3 0 1 2 6 0 0 1 0 0 1\n"),
        {"'texcoord'", "list"});
    // In binary files it converts coordinates only from float types.
    Bytes int_coordinates;
    int_coordinates.text(
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty int x\n"
        "property int y\nproperty int z\n" +
        faces + "end_header\n");
    for (const std::int32_t c : {0, 0, 0, 1, 0, 0, 0, 1, 0}) {
        int_coordinates.i32(c);
    }
    int_coordinates.u8(3).i32(0).i32(1).i32(2);
    expect_refused(dir.write("int_coordinates.ply", int_coordinates.str()),
                   {"'x'", "float or double"});
    // It finds binary data 12 bytes after the last header word, so a comment there shifts it.
    std::string shifted = binary_ply({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}).str();
    shifted.insert(shifted.find("end_header"), "comment last\n");
    expect_refused(dir.write("shifted.ply", shifted), {"end_header"});
}

TEST(MeshIo, RefusesOffVariantsOpenMeshCannotRead) {
    TempDir dir;
    expect_refused(dir.write("four.off", "4OFF\n3 1 0\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n"),
                   {"line 1", "not supported"});
    expect_refused(dir.write("spaced.off", "  OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
                   {"line 1", "not an OFF file"});
    std::string colored = binary_off({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}).str();
    colored.insert(0, "C");
    expect_refused(dir.write("colored.off", colored), {"colors"});
}

TEST(MeshIo, RefusesMalformedObjLines) {
    TempDir dir;
    expect_refused(dir.write("short.obj", "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
                   {"line 1", "three numeric coordinates"});
    expect_refused(dir.write("corner.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n"),
                   {"line 4", "'x'"});
    expect_refused(dir.write("vt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt nan 0\nf 1 2 3\n"),
                   {"line 4", "texture coordinate 1"});
}

TEST(MeshIo, RefusesObjFacesOfFewerThanThreeCorners) {
    TempDir dir;
    const std::string vertices = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    const std::pair<std::string, std::string> cases[] = {
        {"f\n", "line 5: face has 0 corners, expected at least three"},
        {"f # nothing\n", "line 5: face has 0 corners, expected at least three"},
        {"f 1\n", "line 5: face has 1 corner, expected at least three"},
        {"f 1 2\n", "line 5: face has 2 corners, expected at least three"},
        {"f 1 3 # a comment\n", "line 5: face has 2 corners, expected at least three"},
    };
    for (const auto& [line, expected] : cases) {
        const fs::path file = dir.write("short_face.obj", vertices + line);
        EXPECT_EQ(load_error(file), file.string() + ": " + expected) << line;
    }
}

/// A file OpenMesh reads but complains about on its log streams: a missing material library.
constexpr std::string_view kObjWithMissingMaterials =
    "mtllib no_such_file.mtl\nusemtl nothing\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// A valid PLY file only OpenMesh refuses (it takes no uint list lengths).
constexpr std::string_view kPlyOpenMeshRefuses =
    "ply\nformat ascii 1.0\nelement vertex 3\n"
    "property float x\nproperty float y\nproperty float z\n"
    "element face 1\nproperty list uint int vertex_indices\nend_header\n"
    "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";

TEST(MeshIo, KeepsOpenMeshDiagnosticsOffStandardStreamsButInTheError) {
    TempDir dir;
    const fs::path warns = dir.write("warns.obj", kObjWithMissingMaterials);
    const fs::path refused = dir.write("refused.ply", kPlyOpenMeshRefuses);
    std::ostringstream err;
    std::ostringstream out;
    std::streambuf* const old_err = std::cerr.rdbuf(err.rdbuf());
    std::streambuf* const old_log = std::clog.rdbuf(err.rdbuf());
    std::streambuf* const old_out = std::cout.rdbuf(out.rdbuf());
    const std::size_t triangles = load_mesh(warns, 0).mesh.triangle_count();
    const std::string message = load_error(refused);
    std::cerr.rdbuf(old_err);
    std::clog.rdbuf(old_log);
    std::cout.rdbuf(old_out);
    EXPECT_EQ(err.str(), "");
    EXPECT_EQ(out.str(), "");
    EXPECT_EQ(triangles, 1u);
    expect_refused(refused, {"not a readable PLY file", "OpenMesh: ", "uint"});
    EXPECT_FALSE(message.empty());
}

TEST(MeshIo, RefusesUnreadableFile) {
    TempDir dir;
    const fs::path file = dir.write("locked.obj", kObjQuad);
    fs::permissions(file, fs::perms::none);
    if (std::ifstream(file).is_open()) {
        GTEST_SKIP() << "running with permissions that ignore file modes";
    }
    expect_refused(file, {"cannot be opened"});
}

TEST(MeshIo, LoadsConcurrentlyFromManyThreads) {
    // OpenMesh's readers and log streams are global; loads from parallel scene loading must not
    // trample each other.
    TempDir dir;
    const fs::path good = dir.write("warns.obj", kObjWithMissingMaterials);
    const fs::path bad = dir.write("refused.ply", kPlyOpenMeshRefuses);
    const fs::path stl = dir.write("roof.stl", binary_stl(kRoof).str());
    std::atomic<int> failures{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 8; ++t) {
        threads.emplace_back([&] {
            for (int i = 0; i < 20; ++i) {
                if (load_mesh(good, 0).mesh.triangle_count() != 1 ||
                    load_mesh(stl, 0).mesh.positions.size() != 6 || load_error(bad).empty()) {
                    ++failures;
                }
            }
        });
    }
    for (std::thread& thread : threads) {
        thread.join();
    }
    EXPECT_EQ(failures.load(), 0);
}

// ------------------------------------------------------------------------------------------
// The real meshes of ../shared/data.

Eigen::AlignedBox3f obj_bounds(const fs::path& file) {
    Eigen::AlignedBox3f box(Vec3f::Constant(kInfinity), Vec3f::Constant(-kInfinity));
    std::ifstream in(file);
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream words(line);
        std::string keyword;
        Vec3f p;
        if (words >> keyword && keyword == "v" && words >> p.x() >> p.y() >> p.z()) {
            box.extend(p);
        }
    }
    return box;
}

struct RealMesh {
    const char* file;
    std::size_t vertices;   ///< "v" lines in the file.
    std::size_t triangles;  ///< "f" lines in the file (all triangles).
    std::size_t degenerate;
    bool uvs;
    std::size_t output_vertices;  ///< After splitting at uv seams.
};

std::ostream& operator<<(std::ostream& os, const RealMesh& r) {
    return os << r.file;
}

class RealMeshes : public ::testing::TestWithParam<RealMesh> {};

TEST_P(RealMeshes, LoadWithExpectedCountsAndSaneGeometry) {
    const RealMesh& expected = GetParam();
    const std::optional<fs::path> file = testing::find_data_file(expected.file);
    ASSERT_TRUE(file) << expected.file << " not found along MRT_DATA or " << MRT_TEST_DATA_DIRS;
    const MeshLoadResult r = load_mesh(*file, 2);
    const Mesh& m = r.mesh;
    expect_well_formed(m);
    EXPECT_EQ(r.degenerate_triangles_removed, expected.degenerate);
    EXPECT_EQ(m.triangle_count(), expected.triangles - expected.degenerate);
    EXPECT_EQ(m.positions.size(), expected.output_vertices);
    EXPECT_GE(m.positions.size(), expected.vertices);
    EXPECT_EQ(m.has_uvs(), expected.uvs);
    EXPECT_FALSE(r.normals_from_file);
    for (const std::uint32_t material : m.materials) {
        ASSERT_EQ(material, 2u);
    }
    // Bounds agree exactly with the file's own "v" lines, read independently here.
    const Eigen::AlignedBox3f b = m.bounds();
    EXPECT_TRUE((b.sizes().array() > 0.0f).all()) << b.sizes().transpose();
    EXPECT_EQ(b.min(), obj_bounds(*file).min());
    EXPECT_EQ(b.max(), obj_bounds(*file).max());
    if (m.has_uvs()) {
        for (const Vec2f& uv : m.uvs) {
            ASSERT_TRUE(uv.allFinite());
        }
    }
    // Closed scans: computed normals agree with face orientation nearly everywhere.
    std::size_t agreeing = 0;
    for (std::size_t t = 0; t < m.triangle_count(); ++t) {
        const Vec3f g = geometric_normal(m, t);
        const Vec3f n = (m.normals[m.triangles[t][0]] + m.normals[m.triangles[t][1]] +
                         m.normals[m.triangles[t][2]]);
        agreeing += g.dot(n) > 0.0f ? 1 : 0;
    }
    EXPECT_GT(static_cast<double>(agreeing), 0.99 * static_cast<double>(m.triangle_count()));
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, RealMeshes,
    ::testing::Values(RealMesh{"meshes/stanford-bunny.obj", 35947, 69451, 0, false, 35947},
                      RealMesh{"meshes/cow.obj", 2903, 5804, 0, false, 2903},
                      RealMesh{"meshes/spot.obj", 2930, 5856, 0, true, 3225},
                      RealMesh{"meshes/teapot.obj", 3644, 6320, 0, false, 3644}),
    [](const ::testing::TestParamInfo<RealMesh>& param_info) {
        std::string name = fs::path(param_info.param.file).stem().string();
        std::replace(name.begin(), name.end(), '-', '_');
        return name;
    });

}  // namespace
}  // namespace mrt

namespace mrt {
namespace {

/// A unit cube of 8 shared vertices and 6 quads, without normals: the Cornell box's boxes.
constexpr std::string_view kCubeObj =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 3 4 8 7\nf 2 3 7 6\nf 1 5 8 4\n";

TEST(MeshIo, CreaseAngleKeepsABoxFlatAndLeavesSmoothSurfacesAlone) {
    const TempDir dir;
    const fs::path cube = dir.write("cube.obj", kCubeObj);
    // Smooth everywhere (the default): each corner's normal is the mean of its three faces'.
    const Mesh smooth = load_mesh(cube, 0).mesh;
    EXPECT_EQ(smooth.positions.size(), 8u);
    for (std::size_t v = 0; v < smooth.positions.size(); ++v) {
        const Vec3f diagonal = (smooth.positions[v] - Vec3f::Constant(0.5f)).normalized();
        EXPECT_LT((smooth.normals[v] - diagonal).norm(), 1e-6f) << "vertex " << v;
    }
    // At 60° the faces meet at 90°: every corner takes its own face's normal, 3 copies a corner.
    const Mesh creased = load_mesh(cube, 0, 60.0 * std::numbers::pi / 180.0).mesh;
    expect_well_formed(creased);
    EXPECT_EQ(creased.positions.size(), 24u);
    for (const auto& t : creased.triangles) {
        const Vec3f face = (creased.positions[t[1]] - creased.positions[t[0]])
                               .cross(creased.positions[t[2]] - creased.positions[t[0]])
                               .normalized();
        for (const std::uint32_t v : t) {
            EXPECT_LT((creased.normals[v] - face).norm(), 1e-6f);
        }
    }
    // A crease angle wider than the box's edges changes nothing, to the bit.
    const Mesh wide = load_mesh(cube, 0, 100.0 * std::numbers::pi / 180.0).mesh;
    ASSERT_EQ(wide.normals.size(), smooth.normals.size());
    for (std::size_t v = 0; v < wide.normals.size(); ++v) {
        EXPECT_EQ(wide.normals[v], smooth.normals[v]);
    }
    // A scan's curvature is mostly far below 60°: the bunny keeps nearly all its vertices shared.
    if (const auto bunny = testing::find_data_file("meshes/stanford-bunny.obj")) {
        const std::size_t shared = load_mesh(*bunny, 0).mesh.positions.size();
        const std::size_t split =
            load_mesh(*bunny, 0, 60.0 * std::numbers::pi / 180.0).mesh.positions.size();
        EXPECT_LT(static_cast<double>(split - shared), 0.02 * static_cast<double>(shared));
    }
}

}  // namespace
}  // namespace mrt
