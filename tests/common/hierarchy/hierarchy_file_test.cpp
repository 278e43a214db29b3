// The hierarchy file (.mrh): exact round trips, optional channels left out, and refusal, by the
// writer and by the reader, of every inconsistent hierarchy. The bad files are written here
// section by section with SectionFileWriter, restating the layout of hierarchy_file.h, so they
// are valid containers whose checksums pass and only the hierarchy's references are wrong.

#include "common/hierarchy/hierarchy_file.h"

#include "common/hierarchy/section_file.h"
#include "common/system/error.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

namespace mrt {
namespace {

namespace fs = std::filesystem;
using mrt::testing::error_message;
using mrt::testing::ScratchDirectory;

HierarchyNode make_node(std::array<float, 3> origin, float side, std::uint32_t first_point,
                        std::uint32_t point_count, std::uint32_t first_triangle,
                        std::uint32_t triangle_count, std::uint32_t parent, std::uint8_t level) {
    HierarchyNode n{};
    n.origin = origin;
    n.side = side;
    n.sphere_centre = {origin[0] + side / 2, origin[1] + side / 2, origin[2] + side / 2};
    n.sphere_radius = side;
    n.first_point = first_point;
    n.point_count = point_count;
    n.first_triangle = first_triangle;
    n.triangle_count = triangle_count;
    n.parent = parent;
    n.level = level;
    return n;
}

/// A mesh object: a root cube [0, 2)³ with children in octants 1 (+x) and 6 (+y, +z), five
/// points with every channel, two triangles over four vertices, one kept in the root and one
/// in the first child; and the world, a group object of one node holding two instances of it.
HierarchyData small_hierarchy() {
    HierarchyData d;
    d.grid = 4;
    d.world_object = 1;
    d.objects = {{0, 3, HierarchyObjectKind::Mesh, 0, 2, 0, 4, 0},
                 {3, 1, HierarchyObjectKind::Group, 0, 0, 0, 0, 0}};
    d.instances = {{{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0}, 0, {}},
                   {{0, -2, 0, 5, 2, 0, 0, -1, 0, 0, 0.5f, 3}, 0, {}}};
    d.scene_json = R"({"camera": {}})";
    HierarchyNode root = make_node({0, 0, 0}, 2, 0, 2, 0, 1, 0xffffffffu, 0);
    root.child_mask = (1u << 1) | (1u << 6);
    root.first_child = 1;
    HierarchyNode world = make_node({-4, -4, -4}, 12, 5, 0, 2, 0, 0xffffffffu, 0);
    world.instance_count = 2;
    d.nodes = {root, make_node({1, 0, 0}, 1, 2, 1, 1, 1, 0, 1),
               make_node({0, 1, 1}, 1, 3, 2, 2, 0, 0, 1), world};
    for (std::uint8_t i = 0; i < 5; ++i) {
        const std::uint8_t k = static_cast<std::uint8_t>(i + 1);
        d.core.push_back(
            {{static_cast<std::uint8_t>(i % 4), static_cast<std::uint8_t>(3 - i % 4),
              static_cast<std::uint8_t>((i + 1) % 4)},
             static_cast<std::uint8_t>(50 * i),
             {static_cast<std::uint16_t>(1000 * k), static_cast<std::uint16_t>(7 * k)}});
        d.offset.push_back({static_cast<std::int8_t>(40 * i - 90)});
        d.diffuse.push_back({{static_cast<std::uint8_t>(10 * k), static_cast<std::uint8_t>(20 * k),
                              static_cast<std::uint8_t>(30 * k)},
                             0});
        d.specular.push_back(
            {{static_cast<std::uint8_t>(40 * k), 2, 3}, static_cast<std::uint8_t>(k)});
        d.mirror.push_back({static_cast<std::uint8_t>(k),
                            static_cast<std::uint8_t>(2 * k),
                            static_cast<std::uint16_t>(300 * k),
                            {static_cast<std::uint16_t>(0x3c00 + k), 1, 2,
                             static_cast<std::uint16_t>(0xbc00 + k)}});
        d.refraction.push_back(
            {static_cast<std::uint8_t>(11 * k), static_cast<std::uint8_t>(13 * k)});
        d.emission.push_back({{static_cast<std::uint16_t>(0x4c40 + k), 0x4a00, 0x0001}});
        d.opacity.push_back({static_cast<std::uint8_t>(51 * k)});
    }
    d.node_triangles = {1, 0};
    d.vertex_positions = {{0.5f, 0.25f, 0}, {1.5f, 0.25f, 0}, {0.5f, 1.75f, 1}, {-0.0f, 3e-7f, 2}};
    d.vertex_normals = {{1, 2}, {3, 4}, {5, 6}, {65534, 0}};
    d.vertex_uvs = {{0, 0}, {1, 0}, {0, 1}, {0.5f, -2}};
    d.triangles = {{{0, 1, 2}}, {{1, 3, 2}}};
    d.triangle_materials = {0, 2};
    d.build_json = R"({"grid": 4, "seconds": 0.125})";
    return d;
}

/// The same without specular, mirror, refraction, emission, opacity and texture coordinates.
HierarchyData plain_hierarchy() {
    HierarchyData d = small_hierarchy();
    d.specular.clear();
    d.mirror.clear();
    d.refraction.clear();
    d.emission.clear();
    d.opacity.clear();
    d.vertex_uvs.clear();
    return d;
}

HierarchyHeader header_of(const HierarchyData& d) {
    HierarchyHeader h{};
    h.grid = static_cast<std::uint32_t>(d.grid);
    h.node_count = static_cast<std::uint32_t>(d.nodes.size());
    h.point_count = static_cast<std::uint32_t>(d.core.size());
    h.object_count = static_cast<std::uint32_t>(d.objects.size());
    h.instance_count = static_cast<std::uint32_t>(d.instances.size());
    h.world_object = d.world_object;
    return h;
}

/// Adds `node` as the last node of the mesh object (the group's node moves up one).
void insert_mesh_node(HierarchyData& d, const HierarchyNode& node) {
    d.nodes.insert(d.nodes.begin() + 3, node);
    ++d.objects[0].node_count;
    ++d.objects[1].first_node;
}

template <class T>
void add_raw(SectionFileWriter& w, const char (&name)[5], const std::vector<T>& v,
             std::uint32_t skip, bool optional = false) {
    if (section_tag(name) != skip && !(optional && v.empty())) {
        w.add_array<T>(section_tag(name), v);
    }
}

/// The file of hierarchy_file.h written by hand, without any of the writer's checks: `head` as
/// given and the section `skip` (a tag, or 0) left out.
void write_raw(const fs::path& path, const HierarchyData& d, const HierarchyHeader& head,
               std::uint32_t skip = 0) {
    SectionFileWriter w(kHierarchyFileVersion);
    add_raw(w, "HEAD", std::vector<HierarchyHeader>{head}, skip);
    add_raw(w, "OBJS", d.objects, skip);
    add_raw(w, "INST", d.instances, skip);
    add_raw(w, "NODE", d.nodes, skip);
    add_raw(w, "PCOR", d.core, skip);
    add_raw(w, "POFS", d.offset, skip);
    add_raw(w, "PDIF", d.diffuse, skip);
    add_raw(w, "PSPC", d.specular, skip, true);
    add_raw(w, "PMIR", d.mirror, skip, true);
    add_raw(w, "PTRN", d.refraction, skip, true);
    add_raw(w, "PEMI", d.emission, skip, true);
    add_raw(w, "POPA", d.opacity, skip, true);
    add_raw(w, "NTRI", d.node_triangles, skip);
    add_raw(w, "VPOS", d.vertex_positions, skip);
    add_raw(w, "VNRM", d.vertex_normals, skip);
    add_raw(w, "VTUV", d.vertex_uvs, skip, true);
    add_raw(w, "TRIS", d.triangles, skip);
    add_raw(w, "TMAT", d.triangle_materials, skip);
    if (skip != section_tag("SCEN")) {
        w.add(section_tag("SCEN"), std::as_bytes(std::span(d.scene_json)));
    }
    if (skip != section_tag("BILD")) {
        w.add(section_tag("BILD"), std::as_bytes(std::span(d.build_json)));
    }
    w.write(path);
}

std::vector<char> file_bytes(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Same length and the same object representation, record for record.
template <class T>
void expect_same_records(std::span<const T> read, const std::vector<T>& written, const char* what) {
    ASSERT_EQ(read.size(), written.size()) << what;
    for (std::size_t i = 0; i < read.size(); ++i) {
        EXPECT_EQ(std::memcmp(&read[i], &written[i], sizeof(T)), 0) << what << " record " << i;
    }
}

TEST(HierarchyFile, RoundTripsEveryRecordExactly) {
    ScratchDirectory dir("mrt_hierarchy_file");
    const fs::path path = dir.path() / "small.mrh";
    const HierarchyData d = small_hierarchy();
    write_hierarchy_file(path, d);

    const HierarchyFile f = HierarchyFile::open(path, 3);
    EXPECT_EQ(f.grid(), 4);
    EXPECT_EQ(f.world_object(), 1u);
    expect_same_records(f.objects(), d.objects, "objects");
    expect_same_records(f.instances(), d.instances, "instances");
    expect_same_records(f.nodes(), d.nodes, "nodes");
    expect_same_records(f.core(), d.core, "core");
    expect_same_records(f.offset(), d.offset, "offset");
    expect_same_records(f.diffuse(), d.diffuse, "diffuse");
    expect_same_records(f.specular(), d.specular, "specular");
    expect_same_records(f.mirror(), d.mirror, "mirror");
    expect_same_records(f.refraction(), d.refraction, "refraction");
    expect_same_records(f.emission(), d.emission, "emission");
    expect_same_records(f.opacity(), d.opacity, "opacity");
    expect_same_records(f.node_triangles(), d.node_triangles, "node triangles");
    expect_same_records(f.vertex_positions(), d.vertex_positions, "positions");
    expect_same_records(f.vertex_normals(), d.vertex_normals, "normals");
    expect_same_records(f.vertex_uvs(), d.vertex_uvs, "uvs");
    expect_same_records(f.triangles(), d.triangles, "triangles");
    expect_same_records(f.triangle_materials(), d.triangle_materials, "materials");
    EXPECT_EQ(f.build_json(), d.build_json);
    EXPECT_EQ(f.scene_json(), d.scene_json);
    const Affine3f second = f.instances()[1].affine();
    EXPECT_EQ(second * Vec3f(1, 2, 3), Vec3f(1, 1, 4.5f));
    EXPECT_EQ(HierarchyInstance::pack(second), d.instances[1].transform);

    // The header record, read through the container directly.
    const auto head = f.sections().array<HierarchyHeader>(section_tag("HEAD"));
    ASSERT_EQ(head.size(), 1u);
    EXPECT_EQ(head[0].grid, 4u);
    EXPECT_EQ(head[0].node_count, 4u);
    EXPECT_EQ(head[0].point_count, 5u);
    EXPECT_EQ(head[0].object_count, 2u);
    EXPECT_EQ(head[0].instance_count, 2u);
    EXPECT_EQ(head[0].world_object, 1u);
    for (const std::uint32_t r : head[0].reserved) {
        EXPECT_EQ(r, 0u);
    }
}

TEST(HierarchyFile, WriterProducesTheLayoutRestatedByHand) {
    ScratchDirectory dir("mrt_hierarchy_file");
    for (const HierarchyData& d : {small_hierarchy(), plain_hierarchy()}) {
        write_hierarchy_file(dir.path() / "writer.mrh", d);
        write_raw(dir.path() / "hand.mrh", d, header_of(d));
        EXPECT_EQ(file_bytes(dir.path() / "writer.mrh"), file_bytes(dir.path() / "hand.mrh"));
    }
}

TEST(HierarchyFile, LeavesOutUnusedChannels) {
    ScratchDirectory dir("mrt_hierarchy_file");
    write_hierarchy_file(dir.path() / "full.mrh", small_hierarchy());
    write_hierarchy_file(dir.path() / "plain.mrh", plain_hierarchy());

    const HierarchyFile full = HierarchyFile::open(dir.path() / "full.mrh");
    const HierarchyFile plain = HierarchyFile::open(dir.path() / "plain.mrh");
    for (const std::uint32_t tag :
         {section_tag("PSPC"), section_tag("PMIR"), section_tag("PTRN"), section_tag("PEMI"),
          section_tag("POPA"), section_tag("VTUV")}) {
        EXPECT_TRUE(full.sections().has(tag)) << tag_name(tag);
        EXPECT_FALSE(plain.sections().has(tag)) << tag_name(tag);
    }
    EXPECT_LT(plain.sections().file_size(), full.sections().file_size());
    EXPECT_TRUE(plain.specular().empty());
    EXPECT_TRUE(plain.mirror().empty());
    EXPECT_TRUE(plain.refraction().empty());
    EXPECT_TRUE(plain.emission().empty());
    EXPECT_TRUE(plain.opacity().empty());
    EXPECT_TRUE(plain.vertex_uvs().empty());
    EXPECT_EQ(plain.core().size(), 5u);
    EXPECT_EQ(plain.diffuse().size(), 5u);
    EXPECT_EQ(plain.vertex_normals().size(), 4u);
}

struct WriterCase {
    const char* name;
    std::function<void(HierarchyData&)> damage;
    std::string location;
    std::string problem;
};

TEST(HierarchyFileWriter, RefusesInconsistentDataAndWritesNothing) {
    ScratchDirectory dir("mrt_hierarchy_file");
    const std::vector<WriterCase> cases = {
        {"diffuse short", [](HierarchyData& d) { d.diffuse.pop_back(); }, "section 'PDIF'",
         "4 records, expected 5 (one per point)"},
        {"offset long", [](HierarchyData& d) { d.offset.push_back({}); }, "section 'POFS'",
         "6 records, expected 5 (one per point)"},
        {"diffuse missing", [](HierarchyData& d) { d.diffuse.clear(); }, "section 'PDIF'",
         "0 records, expected 5 (one per point)"},
        {"specular long", [](HierarchyData& d) { d.specular.push_back({}); }, "section 'PSPC'",
         "6 records, expected 5 (one per point) or none"},
        {"mirror short", [](HierarchyData& d) { d.mirror.pop_back(); }, "section 'PMIR'",
         "4 records, expected 5"},
        {"refraction short", [](HierarchyData& d) { d.refraction.resize(1); }, "section 'PTRN'",
         "1 records, expected 5"},
        {"emission short", [](HierarchyData& d) { d.emission.resize(2); }, "section 'PEMI'",
         "2 records, expected 5"},
        {"opacity long", [](HierarchyData& d) { d.opacity.push_back({}); }, "section 'POPA'",
         "6 records, expected 5 (one per point) or none"},
        {"grid 0", [](HierarchyData& d) { d.grid = 0; }, "section 'HEAD'",
         "grid resolution 0, expected 1 to 256"},
        {"grid 257", [](HierarchyData& d) { d.grid = 257; }, "section 'HEAD'",
         "grid resolution 257, expected 1 to 256"},
        {"normals short", [](HierarchyData& d) { d.vertex_normals.pop_back(); }, "section 'VNRM'",
         "3 records, expected 4 (one per vertex)"},
        {"uvs long", [](HierarchyData& d) { d.vertex_uvs.push_back({}); }, "section 'VTUV'",
         "5 records, expected 4 (one per vertex) or none"},
        {"materials short", [](HierarchyData& d) { d.triangle_materials.pop_back(); },
         "section 'TMAT'", "1 records, expected 2 (one per triangle)"},
        {"vertex index", [](HierarchyData& d) { d.triangles[0][1] = 4; }, "section 'TRIS' record 0",
         "vertex 4 does not exist"},
    };
    for (const WriterCase& c : cases) {
        HierarchyData d = small_hierarchy();
        c.damage(d);
        const fs::path path = dir.path() / (std::string(c.name) + ".mrh");
        const std::string message = error_message([&] { write_hierarchy_file(path, d); });
        EXPECT_EQ(message.rfind(path.string() + ": " + c.location + ": ", 0), 0u)
            << c.name << ": " << message;
        EXPECT_NE(message.find(c.problem), std::string::npos) << c.name << ": " << message;
        EXPECT_FALSE(fs::exists(path)) << c.name;
    }
    EXPECT_TRUE(fs::is_empty(dir.path()));
}

struct ReaderCase {
    const char* name;
    std::function<void(HierarchyData&)> damage;
    std::function<void(HierarchyHeader&)> damage_head;
    std::uint32_t skip;
    std::string location;
    std::string problem;
};

TEST(HierarchyFileReader, RefusesBadReferencesInChecksumValidFiles) {
    ScratchDirectory dir("mrt_hierarchy_file");
    const auto none = [](HierarchyData&) {};
    const auto no_head = [](HierarchyHeader&) {};
    const std::vector<ReaderCase> cases = {
        {"point range past the end", [](HierarchyData& d) { d.nodes[2].point_count = 3; }, no_head,
         0, "section 'NODE' record 2", "points [3, 3 + 3) run past the 5 points of section 'PCOR'"},
        {"point range wrapping 2^32",
         [](HierarchyData& d) {
             d.nodes[1].first_point = 0xffffffffu;
             d.nodes[1].point_count = 2;
         },
         no_head, 0, "section 'NODE' record 1", "run past the 5 points"},
        {"triangle range past the end", [](HierarchyData& d) { d.nodes[1].triangle_count = 2; },
         no_head, 0, "section 'NODE' record 1", "run past the 2 entries of section 'NTRI'"},
        {"child beyond the nodes", [](HierarchyData& d) { d.nodes[0].first_child = 3; }, no_head, 0,
         "section 'NODE' record 0", "children [3, 3 + 2) run past the 4 nodes"},
        {"child before its parent",
         [](HierarchyData& d) {
             d.nodes[2].child_mask = 1;
             d.nodes[2].first_child = 1;
         },
         no_head, 0, "section 'NODE' record 2", "first child 1 is not after the node itself"},
        {"child is the node itself",
         [](HierarchyData& d) {
             d.nodes[1].child_mask = 1;
             d.nodes[1].first_child = 1;
         },
         no_head, 0, "section 'NODE' record 1", "first child 1 is not after the node itself"},
        {"wrong parent", [](HierarchyData& d) { d.nodes[2].parent = 1; }, no_head, 0,
         "section 'NODE' record 2", "parent is 1, but node 0 lists it as a child"},
        {"orphan node",
         [](HierarchyData& d) {
             insert_mesh_node(d, make_node({1, 0, 0}, 0.5f, 0, 0, 0, 0, 1, 2));
         },
         no_head, 0, "section 'NODE' record 3",
         "parent 1 is not a node of object 0 that lists it among its children"},
        {"second root",
         [](HierarchyData& d) {
             insert_mesh_node(d, make_node({1, 0, 0}, 0.5f, 0, 0, 0, 0, 0xffffffffu, 0));
         },
         no_head, 0, "section 'NODE' record 3",
         "has no parent, but only the first node of object 0 is its root"},
        {"root with a parent", [](HierarchyData& d) { d.nodes[0].parent = 2; }, no_head, 0,
         "section 'NODE' record 0", "root of object 0 with parent 2 and level 0"},
        {"objects leave a gap", [](HierarchyData& d) { d.objects[1].first_node = 4; }, no_head, 0,
         "section 'OBJS' record 1", "nodes [4, 4 + 1), expected a non-empty range starting at 3"},
        {"objects leave nodes over",
         [](HierarchyData& d) {
             d.nodes.push_back(make_node({1, 0, 0}, 0.5f, 0, 0, 0, 0, 0xffffffffu, 0));
         },
         no_head, 0, "section 'OBJS'", "cover 4 of the 5 nodes"},
        {"no objects",
         [](HierarchyData& d) {
             d.objects.clear();
             d.world_object = 0;
         },
         no_head, 0, "section 'OBJS'", "no objects, expected at least one"},
        {"unknown kind",
         [](HierarchyData& d) { d.objects[1].kind = static_cast<HierarchyObjectKind>(7); }, no_head,
         0, "section 'OBJS' record 1", "kind 7, expected 0 (mesh) or 1 (group)"},
        {"group with triangles", [](HierarchyData& d) { d.objects[1].triangle_count = 1; }, no_head,
         0, "section 'OBJS' record 1", "a group's triangle and vertex ranges"},
        {"mesh triangles past the end", [](HierarchyData& d) { d.objects[0].triangle_count = 3; },
         no_head, 0, "section 'OBJS' record 0", "run past the 2 triangles or 4 vertices"},
        {"vertex of another object", [](HierarchyData& d) { d.objects[0].vertex_count = 3; },
         no_head, 0, "section 'TRIS' record 1", "vertex 3 is not one of its object's"},
        {"triangle of another object", [](HierarchyData& d) { d.objects[0].triangle_count = 1; },
         no_head, 0, "section 'NODE' record 0", "keeps triangle 1, which is not one of object 0's"},
        {"instances in a mesh node", [](HierarchyData& d) { d.nodes[1].instance_count = 1; },
         no_head, 0, "section 'NODE' record 1", "1 instances in a node of mesh object 0"},
        {"triangles in a group node",
         [](HierarchyData& d) {
             d.nodes[3].first_triangle = 0;
             d.nodes[3].triangle_count = 1;
         },
         no_head, 0, "section 'NODE' record 3", "1 triangles in a node of group object 1"},
        {"instances past the end", [](HierarchyData& d) { d.nodes[3].instance_count = 3; }, no_head,
         0, "section 'NODE' record 3", "instances [0, 0 + 3) run past the 2 of section"},
        {"instance of its own group", [](HierarchyData& d) { d.instances[1].object = 1; }, no_head,
         0, "section 'INST' record 1",
         "instance of object 1 in group object 1: an instance must refer to an object listed "
         "before its group"},
        {"singular transform", [](HierarchyData& d) { d.instances[1].transform[1] = 0; }, no_head,
         0, "section 'INST' record 1", "transform with determinant 0"},
        {"NaN transform",
         [](HierarchyData& d) {
             d.instances[0].transform[3] = std::numeric_limits<float>::quiet_NaN();
         },
         no_head, 0, "section 'INST' record 0", "expected finite, invertible values"},
        {"instance reserved", [](HierarchyData& d) { d.instances[0].reserved[2] = 1; }, no_head, 0,
         "section 'INST' record 0", "zero reserved fields"},
        {"world beyond the objects", none, [](HierarchyHeader& h) { h.world_object = 2; }, 0,
         "section 'HEAD'", "world object 2 does not exist (section 'OBJS' has 2)"},
        {"header object count", none, [](HierarchyHeader& h) { h.object_count = 3; }, 0,
         "section 'HEAD'",
         "3 objects and 2 instances, but sections 'OBJS' and 'INST' have 2 and 2"},
        {"points held twice", [](HierarchyData& d) { d.nodes[1].first_point = 1; }, no_head, 0,
         "section 'NODE' record 1",
         "points start at 1, expected 2 (each node's follow the previous node's)"},
        {"point held by no node", [](HierarchyData& d) { d.nodes[2].point_count = 1; }, no_head, 0,
         "section 'PCOR'", "nodes hold 4 of its 5 records, expected all"},
        {"kept triangle held twice", [](HierarchyData& d) { d.nodes[1].first_triangle = 0; },
         no_head, 0, "section 'NODE' record 1", "kept triangles start at 0, expected 1"},
        {"instance held by no node", [](HierarchyData& d) { d.nodes[3].instance_count = 1; },
         no_head, 0, "section 'INST'", "nodes hold 1 of its 2 records, expected all"},
        {"missing objects", none, no_head, section_tag("OBJS"), "section 'OBJS'", "missing"},
        {"missing instances", none, no_head, section_tag("INST"), "section 'INST'", "missing"},
        {"missing scene", none, no_head, section_tag("SCEN"), "section 'SCEN'", "missing"},
        {"child level", [](HierarchyData& d) { d.nodes[1].level = 2; }, no_head, 0,
         "section 'NODE' record 1", "level 2, expected 1"},
        {"zero side", [](HierarchyData& d) { d.nodes[1].side = 0; }, no_head, 0,
         "section 'NODE' record 1", "expected finite values and a positive side"},
        {"infinite origin",
         [](HierarchyData& d) { d.nodes[2].origin[1] = std::numeric_limits<float>::infinity(); },
         no_head, 0, "section 'NODE' record 2", "expected finite values and a positive side"},
        {"negative radius", [](HierarchyData& d) { d.nodes[0].sphere_radius = -1; }, no_head, 0,
         "section 'NODE' record 0", "expected finite values and a radius >= 0"},
        {"NaN radius",
         [](HierarchyData& d) {
             d.nodes[0].sphere_radius = std::numeric_limits<float>::quiet_NaN();
         },
         no_head, 0, "section 'NODE' record 0", "a radius >= 0"},
        {"node triangle out of range", [](HierarchyData& d) { d.node_triangles[1] = 2; }, no_head,
         0, "section 'NTRI' record 1", "triangle 2 does not exist (section 'TRIS' has 2)"},
        {"vertex index out of range", [](HierarchyData& d) { d.triangles[1][2] = 4; }, no_head, 0,
         "section 'TRIS' record 1", "vertex 4 does not exist (section 'VPOS' has 4)"},
        {"voxel outside the grid", [](HierarchyData& d) { d.core[3].voxel[2] = 4; }, no_head, 0,
         "section 'PCOR' record 3", "voxel (3, 0, 4) lies outside the 4^3 grid"},
        {"diffuse short", [](HierarchyData& d) { d.diffuse.pop_back(); }, no_head, 0,
         "section 'PDIF'", "4 records, expected 5 (one per point)"},
        {"mirror long", [](HierarchyData& d) { d.mirror.push_back({}); }, no_head, 0,
         "section 'PMIR'", "6 records, expected 5 (one per point) or none"},
        {"materials long", [](HierarchyData& d) { d.triangle_materials.push_back(0); }, no_head, 0,
         "section 'TMAT'", "3 records, expected 2 (one per triangle)"},
        {"missing normals", none, no_head, section_tag("VNRM"), "section 'VNRM'", "missing"},
        {"missing diffuse", none, no_head, section_tag("PDIF"), "section 'PDIF'", "missing"},
        {"missing offset", none, no_head, section_tag("POFS"), "section 'POFS'", "missing"},
        {"missing build", none, no_head, section_tag("BILD"), "section 'BILD'", "missing"},
        {"missing header", none, no_head, section_tag("HEAD"), "section 'HEAD'", "missing"},
        {"header grid 0", none, [](HierarchyHeader& h) { h.grid = 0; }, 0, "section 'HEAD'",
         "grid resolution 0, expected 1 to 256"},
        {"header grid 257", none, [](HierarchyHeader& h) { h.grid = 257; }, 0, "section 'HEAD'",
         "grid resolution 257, expected 1 to 256"},
        {"header node count", none, [](HierarchyHeader& h) { h.node_count = 3; }, 0,
         "section 'HEAD'", "3 nodes, but section 'NODE' has 4"},
        {"header point count", none, [](HierarchyHeader& h) { h.point_count = 4; }, 0,
         "section 'HEAD'", "4 points, but section 'PCOR' has 5"},
        {"header reserved", none, [](HierarchyHeader& h) { h.reserved[9] = 1; }, 0,
         "section 'HEAD'", "reserved fields are not zero"},
    };

    // The undamaged hand-written file is accepted, so each refusal is due to its damage.
    write_raw(dir.path() / "good.mrh", small_hierarchy(), header_of(small_hierarchy()));
    EXPECT_EQ(HierarchyFile::open(dir.path() / "good.mrh").nodes().size(), 4u);

    for (const ReaderCase& c : cases) {
        HierarchyData d = small_hierarchy();
        c.damage(d);
        HierarchyHeader head = header_of(d);
        c.damage_head(head);
        const fs::path path = dir.path() / (std::string(c.name) + ".mrh");
        write_raw(path, d, head, c.skip);
        const std::string message = error_message([&] { HierarchyFile::open(path); });
        EXPECT_EQ(message.rfind(path.string() + ": " + c.location + ": ", 0), 0u)
            << c.name << ": " << message;
        EXPECT_NE(message.find(c.problem), std::string::npos) << c.name << ": " << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << c.name << ": " << message;
    }
}

TEST(HierarchyFileReader, RefusesMaterialsBeyondTheScenes) {
    ScratchDirectory dir("mrt_hierarchy_file");
    const fs::path path = dir.path() / "materials.mrh";
    write_hierarchy_file(path, small_hierarchy());  // materials {0, 2}
    EXPECT_NO_THROW(HierarchyFile::open(path));
    EXPECT_NO_THROW(HierarchyFile::open(path, 3));
    EXPECT_EQ(
        error_message([&] { HierarchyFile::open(path, 2); }),
        path.string() + ": section 'TMAT' record 1: material 2 does not exist (the scene has 2)");
    EXPECT_EQ(
        error_message([&] { HierarchyFile::open(path, 0); }),
        path.string() + ": section 'TMAT' record 0: material 0 does not exist (the scene has 0)");
}

TEST(HierarchyFileReader, SpansStayValidWhenTheFileIsMoved) {
    ScratchDirectory dir("mrt_hierarchy_file");
    const fs::path path = dir.path() / "moved.mrh";
    const HierarchyData d = small_hierarchy();
    write_hierarchy_file(path, d);
    HierarchyFile first = HierarchyFile::open(path);
    const HierarchyFile moved = std::move(first);
    expect_same_records(moved.core(), d.core, "core");
    expect_same_records(moved.triangles(), d.triangles, "triangles");
}

TEST(HierarchyFileReader, RefusesAFileWithoutAChannelTheScenesMaterialsNeed) {
    ScratchDirectory dir("mrt_hierarchy_file");
    const HierarchyData d = small_hierarchy();
    const fs::path whole = dir.path() / "whole.mrh";
    write_hierarchy_file(whole, d);
    HierarchyChannels all;
    all.specular = all.mirror = all.refraction = all.emission = all.opacity = true;
    EXPECT_NO_THROW(HierarchyFile::open(whole).check_channels(all));
    const struct {
        const char (&tag)[5];
        bool HierarchyChannels::*channel;
        std::string what;
    } cases[] = {
        {"PSPC", &HierarchyChannels::specular,
         "specular channel, which a material with a specular colour needs"},
        {"PMIR", &HierarchyChannels::mirror,
         "mirror channel (reflectivity, roughness, normal gradients), which a reflecting or "
         "refracting material needs"},
        {"PTRN", &HierarchyChannels::refraction,
         "refraction channel (transparency, index of refraction), which a transparent material "
         "needs"},
        {"PEMI", &HierarchyChannels::emission,
         "emission channel, which an emitting material needs"},
        {"POPA", &HierarchyChannels::opacity, "opacity channel, which a cut-out material needs"},
    };
    for (const auto& c : cases) {
        const fs::path path = dir.path() / (std::string("without-") + c.tag + ".mrh");
        write_raw(path, d, header_of(d), section_tag(c.tag));
        const HierarchyFile file = HierarchyFile::open(path);  // a valid file in itself
        HierarchyChannels needed;
        EXPECT_NO_THROW(file.check_channels(needed)) << c.tag;
        needed.*c.channel = true;
        EXPECT_EQ(error_message([&] { file.check_channels(needed); }),
                  path.string() + ": section '" + c.tag +
                      "': missing: the scene record's materials need the " + c.what)
            << c.tag;
    }
}

}  // namespace
}  // namespace mrt
