#include "common/hierarchy/hierarchy_file.h"

#include "common/math/invertibility.h"
#include "common/system/error.h"

#include <fmt/format.h>

#include <array>
#include <bit>
#include <cmath>
#include <limits>

namespace mrt {

namespace {

constexpr std::uint32_t kHead = section_tag("HEAD");
constexpr std::uint32_t kNode = section_tag("NODE");
constexpr std::uint32_t kCore = section_tag("PCOR");
constexpr std::uint32_t kOffset = section_tag("POFS");
constexpr std::uint32_t kDiffuse = section_tag("PDIF");
constexpr std::uint32_t kSpecular = section_tag("PSPC");
constexpr std::uint32_t kMirror = section_tag("PMIR");
constexpr std::uint32_t kRefraction = section_tag("PTRN");
constexpr std::uint32_t kEmission = section_tag("PEMI");
constexpr std::uint32_t kOpacity = section_tag("POPA");
constexpr std::uint32_t kNodeTriangles = section_tag("NTRI");
constexpr std::uint32_t kPositions = section_tag("VPOS");
constexpr std::uint32_t kNormals = section_tag("VNRM");
constexpr std::uint32_t kUvs = section_tag("VTUV");
constexpr std::uint32_t kTriangles = section_tag("TRIS");
constexpr std::uint32_t kMaterials = section_tag("TMAT");
constexpr std::uint32_t kBuild = section_tag("BILD");
constexpr std::uint32_t kObjects = section_tag("OBJS");
constexpr std::uint32_t kInstances = section_tag("INST");
constexpr std::uint32_t kScene = section_tag("SCEN");

constexpr std::uint32_t kNoParent = 0xffffffffu;

std::string where(std::uint32_t tag) {
    return fmt::format("section '{}'", tag_name(tag));
}

std::string where(std::uint32_t tag, std::size_t record) {
    return fmt::format("section '{}' record {}", tag_name(tag), record);
}

/// The arrays of a hierarchy, from memory (before writing) or from the mapping (after reading),
/// so the writer and the reader check the same references with the same messages.
bool valid_grid(std::int64_t grid) {
    return grid >= 1 && grid <= kMaxVoxelGridResolution;
}

/// Whether a per-item channel may be left out.
enum class Channel : std::uint8_t {
    Required,  ///< One record per item.
    Optional,  ///< One record per item, or none (every item has the default).
};

/// A channel of one record per `count` items, or (an optional channel) no records at all.
void check_length(const std::filesystem::path& file, std::uint32_t tag, std::size_t size,
                  std::size_t count, const char* items, Channel channel) {
    const bool optional = channel == Channel::Optional;
    if (size == count || (optional && size == 0)) {
        return;
    }
    throw Error(file, where(tag),
                fmt::format("{} records, expected {} (one per {}){}", size, count, items,
                            optional ? " or none" : ""));
}

void check_lengths(const std::filesystem::path& file, const HierarchyView& a) {
    const std::size_t points = a.core.size();
    check_length(file, kOffset, a.offset.size(), points, "point", Channel::Required);
    check_length(file, kDiffuse, a.diffuse.size(), points, "point", Channel::Required);
    check_length(file, kSpecular, a.specular.size(), points, "point", Channel::Optional);
    check_length(file, kMirror, a.mirror.size(), points, "point", Channel::Optional);
    check_length(file, kRefraction, a.refraction.size(), points, "point", Channel::Optional);
    check_length(file, kEmission, a.emission.size(), points, "point", Channel::Optional);
    check_length(file, kOpacity, a.opacity.size(), points, "point", Channel::Optional);
    check_length(file, kNormals, a.vertex_normals.size(), a.vertex_positions.size(), "vertex",
                 Channel::Required);
    check_length(file, kUvs, a.vertex_uvs.size(), a.vertex_positions.size(), "vertex",
                 Channel::Optional);
    check_length(file, kMaterials, a.triangle_materials.size(), a.triangles.size(), "triangle",
                 Channel::Required);
}

bool finite3(const std::array<float, 3>& v) {
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

/// One node's own fields and the ranges it refers to.
void check_node(const std::filesystem::path& file, const HierarchyView& a, std::size_t i) {
    const HierarchyNode& n = a.nodes[i];
    const std::string at = where(kNode, i);
    if (!finite3(n.origin) || !std::isfinite(n.side) || !(n.side > 0.0f)) {
        throw Error(file, at,
                    fmt::format("cube origin ({}, {}, {}) side {}: expected finite values and a "
                                "positive side",
                                n.origin[0], n.origin[1], n.origin[2], n.side));
    }
    if (!finite3(n.sphere_centre) || !std::isfinite(n.sphere_radius) || !(n.sphere_radius >= 0)) {
        throw Error(file, at,
                    fmt::format("bounding sphere centre ({}, {}, {}) radius {}: expected finite "
                                "values and a radius >= 0",
                                n.sphere_centre[0], n.sphere_centre[1], n.sphere_centre[2],
                                n.sphere_radius));
    }
    // In 64 bits, so that a range wrapping around 2^32 cannot pass.
    if (std::uint64_t{n.first_point} + n.point_count > a.core.size()) {
        throw Error(file, at,
                    fmt::format("points [{}, {} + {}) run past the {} points of section '{}'",
                                n.first_point, n.first_point, n.point_count, a.core.size(),
                                tag_name(kCore)));
    }
    if (std::uint64_t{n.first_triangle} + n.triangle_count > a.node_triangles.size()) {
        throw Error(file, at,
                    fmt::format("triangles [{}, {} + {}) run past the {} entries of section '{}'",
                                n.first_triangle, n.first_triangle, n.triangle_count,
                                a.node_triangles.size(), tag_name(kNodeTriangles)));
    }
    if (n.child_mask == 0) {
        return;
    }
    const unsigned children = static_cast<unsigned>(std::popcount(n.child_mask));
    // Breadth-first order puts children after their parent, which also rules out cycles.
    if (n.first_child <= i) {
        throw Error(file, at,
                    fmt::format("first child {} is not after the node itself (breadth-first "
                                "order puts children after their parent)",
                                n.first_child));
    }
    if (std::uint64_t{n.first_child} + children > a.nodes.size()) {
        throw Error(file, at,
                    fmt::format("children [{}, {} + {}) run past the {} nodes", n.first_child,
                                n.first_child, children, a.nodes.size()));
    }
    for (std::uint32_t c = n.first_child; c < n.first_child + children; ++c) {
        const HierarchyNode& child = a.nodes[c];
        if (child.parent != i) {
            throw Error(
                file, where(kNode, c),
                fmt::format("parent is {}, but node {} lists it as a child", child.parent, i));
        }
        if (int{child.level} != int{n.level} + 1) {
            throw Error(file, where(kNode, c),
                        fmt::format("level {}, expected {} (one below its parent, node {})",
                                    child.level, int{n.level} + 1, i));
        }
    }
}

/// A range [first, first + count) inside [0, size), in 64 bits so that wrapping cannot pass.
bool within(std::uint64_t first, std::uint64_t count, std::uint64_t size) {
    return first + count <= size;
}

/// The objects partition the nodes in order, each one tree rooted at its first node (every
/// other node the child of the node its parent field names, inside the object); a mesh object's
/// nodes keep only its own triangles, whose vertices are its own; a group object's nodes keep
/// instances of objects listed before it, so instancing has no cycles.
void check_objects(const std::filesystem::path& file, const HierarchyView& a) {
    if (a.objects.empty()) {
        throw Error(file, where(kObjects), "no objects, expected at least one");
    }
    if (a.world_object >= a.objects.size()) {
        throw Error(file, where(kHead),
                    fmt::format("world object {} does not exist (section '{}' has {})",
                                a.world_object, tag_name(kObjects), a.objects.size()));
    }
    std::uint64_t next_node = 0;
    // Each node's points, kept triangles and instances follow the previous node's, so every
    // record is held by exactly one node (none drawn twice, none left out).
    std::array<std::uint64_t, 3> next{0, 0, 0};
    const auto follows = [&](std::size_t i, std::size_t which, std::uint64_t first,
                             std::uint64_t count) {
        static constexpr std::array<const char*, 3> kWhat{"points", "kept triangles", "instances"};
        if (count == 0) {
            return;
        }
        if (first != next[which]) {
            throw Error(file, where(kNode, i),
                        fmt::format("{} start at {}, expected {} (each node's follow the previous "
                                    "node's)",
                                    kWhat[which], first, next[which]));
        }
        next[which] += count;
    };
    for (std::size_t o = 0; o < a.objects.size(); ++o) {
        const HierarchyObject& object = a.objects[o];
        const std::string at = where(kObjects, o);
        if (object.first_node != next_node || object.node_count == 0 ||
            !within(object.first_node, object.node_count, a.nodes.size())) {
            throw Error(file, at,
                        fmt::format("nodes [{}, {} + {}), expected a non-empty range starting at "
                                    "{} inside the {} nodes (objects partition them in order)",
                                    object.first_node, object.first_node, object.node_count,
                                    next_node, a.nodes.size()));
        }
        next_node += object.node_count;
        const bool mesh = object.kind == HierarchyObjectKind::Mesh;
        if (!mesh && object.kind != HierarchyObjectKind::Group) {
            throw Error(file, at,
                        fmt::format("kind {}, expected 0 (mesh) or 1 (group)",
                                    static_cast<std::uint32_t>(object.kind)));
        }
        if (object.reserved != 0 || (!mesh && (object.first_triangle | object.triangle_count |
                                               object.first_vertex | object.vertex_count) != 0)) {
            throw Error(file, at,
                        "a group's triangle and vertex ranges and the reserved field "
                        "must be zero");
        }
        if (!within(object.first_triangle, object.triangle_count, a.triangles.size()) ||
            !within(object.first_vertex, object.vertex_count, a.vertex_positions.size())) {
            throw Error(
                file, at,
                fmt::format("triangles [{}, {} + {}) or vertices [{}, {} + {}) run past "
                            "the {} triangles or {} vertices",
                            object.first_triangle, object.first_triangle, object.triangle_count,
                            object.first_vertex, object.first_vertex, object.vertex_count,
                            a.triangles.size(), a.vertex_positions.size()));
        }
        for (std::uint64_t t = object.first_triangle;
             t < std::uint64_t{object.first_triangle} + object.triangle_count; ++t) {
            for (const std::uint32_t v : a.triangles[t]) {
                if (v < object.first_vertex ||
                    v >= std::uint64_t{object.first_vertex} + object.vertex_count) {
                    throw Error(file, where(kTriangles, t),
                                fmt::format("vertex {} is not one of its object's ({}: [{}, {} "
                                            "+ {}))",
                                            v, o, object.first_vertex, object.first_vertex,
                                            object.vertex_count));
                }
            }
        }
        const std::uint64_t end = std::uint64_t{object.first_node} + object.node_count;
        for (std::uint64_t i = object.first_node; i < end; ++i) {
            const HierarchyNode& n = a.nodes[i];
            const std::string node_at = where(kNode, i);
            if (i == object.first_node) {
                if (n.parent != kNoParent || n.level != 0) {
                    throw Error(file, node_at,
                                fmt::format("root of object {} with parent {} and level {}, "
                                            "expected 0xffffffff and 0",
                                            o, n.parent, n.level));
                }
            } else {
                const std::uint32_t p = n.parent;
                const bool listed =
                    p >= object.first_node && p < i && a.nodes[p].child_mask != 0 &&
                    a.nodes[p].first_child <= i &&
                    i < std::uint64_t{a.nodes[p].first_child} +
                            static_cast<unsigned>(std::popcount(a.nodes[p].child_mask));
                if (!listed) {
                    throw Error(file, node_at,
                                p == kNoParent
                                    ? fmt::format("has no parent, but only the first node of "
                                                  "object {} is its root",
                                                  o)
                                    : fmt::format("parent {} is not a node of object {} that "
                                                  "lists it among its children",
                                                  p, o));
                }
            }
            if (n.child_mask != 0 &&
                std::uint64_t{n.first_child} + static_cast<unsigned>(std::popcount(n.child_mask)) >
                    end) {
                throw Error(file, node_at,
                            fmt::format("children from {} run past the nodes of object {}",
                                        n.first_child, o));
            }
            if (mesh) {
                if (n.instance_count != 0) {
                    throw Error(file, node_at,
                                fmt::format("{} instances in a node of mesh object {}",
                                            n.instance_count, o));
                }
                for (std::uint32_t k = 0; k < n.triangle_count; ++k) {
                    const std::uint32_t t = a.node_triangles[n.first_triangle + k];
                    if (t < object.first_triangle ||
                        t >= std::uint64_t{object.first_triangle} + object.triangle_count) {
                        throw Error(file, node_at,
                                    fmt::format("keeps triangle {}, which is not one of object "
                                                "{}'s",
                                                t, o));
                    }
                }
                follows(i, 0, n.first_point, n.point_count);
                follows(i, 1, n.first_triangle, n.triangle_count);
                continue;
            }
            if (n.triangle_count != 0) {
                throw Error(
                    file, node_at,
                    fmt::format("{} triangles in a node of group object {}", n.triangle_count, o));
            }
            if (!within(n.first_instance, n.instance_count, a.instances.size())) {
                throw Error(file, node_at,
                            fmt::format("instances [{}, {} + {}) run past the {} of section '{}'",
                                        n.first_instance, n.first_instance, n.instance_count,
                                        a.instances.size(), tag_name(kInstances)));
            }
            for (std::uint32_t k = 0; k < n.instance_count; ++k) {
                const std::uint32_t child = a.instances[n.first_instance + k].object;
                if (child >= o) {
                    throw Error(file, where(kInstances, n.first_instance + k),
                                fmt::format("instance of object {} in group object {}: an "
                                            "instance must refer to an object listed before "
                                            "its group",
                                            child, o));
                }
            }
            follows(i, 0, n.first_point, n.point_count);
            follows(i, 2, n.first_instance, n.instance_count);
        }
    }
    if (next_node != a.nodes.size()) {
        throw Error(file, where(kObjects),
                    fmt::format("the objects cover {} of the {} nodes, expected all", next_node,
                                a.nodes.size()));
    }
    const std::array<std::pair<std::uint32_t, std::size_t>, 3> held{
        {{kCore, a.core.size()},
         {kNodeTriangles, a.node_triangles.size()},
         {kInstances, a.instances.size()}}};
    for (std::size_t which = 0; which < 3; ++which) {
        if (next[which] != held[which].second) {
            throw Error(file, where(held[which].first),
                        fmt::format("nodes hold {} of its {} records, expected all", next[which],
                                    held[which].second));
        }
    }
    for (std::size_t i = 0; i < a.instances.size(); ++i) {
        const HierarchyInstance& instance = a.instances[i];
        bool finite = true;
        for (const float x : instance.transform) {
            finite = finite && std::isfinite(x);
        }
        const float det = instance.affine().linear().determinant();
        // Invertibility is decided scale-free, as the scene loader decides it: a scale of 1e13
        // has a determinant beyond float's range and a perfectly representable inverse.
        if (!finite || !invertible_in_single_precision(instance.affine().linear().cast<double>()) ||
            (instance.reserved[0] | instance.reserved[1] | instance.reserved[2]) != 0) {
            throw Error(file, where(kInstances, i),
                        fmt::format("transform with determinant {}: expected finite, "
                                    "invertible values and zero reserved fields",
                                    det));
        }
    }
}

void check_materials(const std::filesystem::path& file, const HierarchyView& a,
                     std::uint32_t material_count) {
    for (std::size_t i = 0; i < a.triangle_materials.size(); ++i) {
        if (a.triangle_materials[i] >= material_count) {
            throw Error(file, where(kMaterials, i),
                        fmt::format("material {} does not exist (the scene has {})",
                                    a.triangle_materials[i], material_count));
        }
    }
}

/// Every cross-reference of the arrays (lengths were checked before).
void check_references(const std::filesystem::path& file, const HierarchyView& a,
                      std::optional<std::uint32_t> material_count) {
    for (std::size_t i = 0; i < a.nodes.size(); ++i) {
        check_node(file, a, i);
    }
    for (std::size_t i = 0; i < a.core.size(); ++i) {
        const VoxelCode& v = a.core[i].voxel;
        for (int axis = 0; axis < 3; ++axis) {
            if (int{v[axis]} >= a.grid) {
                throw Error(file, where(kCore, i),
                            fmt::format("voxel ({}, {}, {}) lies outside the {}^3 grid", v[0], v[1],
                                        v[2], a.grid));
            }
        }
    }
    for (std::size_t i = 0; i < a.node_triangles.size(); ++i) {
        if (a.node_triangles[i] >= a.triangles.size()) {
            throw Error(file, where(kNodeTriangles, i),
                        fmt::format("triangle {} does not exist (section '{}' has {})",
                                    a.node_triangles[i], tag_name(kTriangles), a.triangles.size()));
        }
    }
    for (std::size_t i = 0; i < a.vertex_positions.size(); ++i) {
        if (!finite3(a.vertex_positions[i])) {
            throw Error(file, where(kPositions, i), "position is not finite");
        }
    }
    for (std::size_t i = 0; i < a.triangles.size(); ++i) {
        for (const std::uint32_t v : a.triangles[i]) {
            if (v >= a.vertex_positions.size()) {
                throw Error(file, where(kTriangles, i),
                            fmt::format("vertex {} does not exist (section '{}' has {})", v,
                                        tag_name(kPositions), a.vertex_positions.size()));
            }
        }
    }
    check_objects(file, a);
    if (material_count) {
        check_materials(file, a, *material_count);
    }
}

template <class T>
void add_if_present(SectionFileWriter& writer, std::uint32_t tag, const std::vector<T>& values) {
    if (!values.empty()) {
        writer.add_array<T>(tag, values);
    }
}

/// A section that is absent when no point or vertex needs it: empty then.
template <class T>
std::span<const T> optional_array(const SectionFile& file, std::uint32_t tag) {
    return file.has(tag) ? file.array<T>(tag) : std::span<const T>();
}

}  // namespace

void write_hierarchy_file(const std::filesystem::path& path, const HierarchyData& data) {
    if (!valid_grid(data.grid)) {
        throw Error(path, where(kHead),
                    fmt::format("grid resolution {}, expected 1 to {}", data.grid,
                                kMaxVoxelGridResolution));
    }
    constexpr std::size_t kMaxCount = std::numeric_limits<std::uint32_t>::max();
    if (data.nodes.size() > kMaxCount || data.core.size() > kMaxCount ||
        data.objects.size() > kMaxCount || data.instances.size() > kMaxCount) {
        throw Error(path, where(kHead),
                    fmt::format("{} nodes, {} points, {} objects and {} instances: at most "
                                "2^32 - 1 of each fit",
                                data.nodes.size(), data.core.size(), data.objects.size(),
                                data.instances.size()));
    }
    const HierarchyView a = data.view();
    check_lengths(path, a);
    check_references(path, a, std::nullopt);

    HierarchyHeader head{};
    head.grid = static_cast<std::uint32_t>(data.grid);
    head.node_count = static_cast<std::uint32_t>(data.nodes.size());
    head.point_count = static_cast<std::uint32_t>(data.core.size());
    head.object_count = static_cast<std::uint32_t>(data.objects.size());
    head.instance_count = static_cast<std::uint32_t>(data.instances.size());
    head.world_object = data.world_object;

    SectionFileWriter writer(kHierarchyFileVersion);
    writer.add_array<HierarchyHeader>(kHead, std::span(&head, 1));
    writer.add_array<HierarchyObject>(kObjects, data.objects);
    writer.add_array<HierarchyInstance>(kInstances, data.instances);
    writer.add_array<HierarchyNode>(kNode, data.nodes);
    writer.add_array<PointCore>(kCore, data.core);
    writer.add_array<PointOffset>(kOffset, data.offset);
    writer.add_array<PointDiffuse>(kDiffuse, data.diffuse);
    add_if_present(writer, kSpecular, data.specular);
    add_if_present(writer, kMirror, data.mirror);
    add_if_present(writer, kRefraction, data.refraction);
    add_if_present(writer, kEmission, data.emission);
    add_if_present(writer, kOpacity, data.opacity);
    writer.add_array<std::uint32_t>(kNodeTriangles, data.node_triangles);
    writer.add_array<std::array<float, 3>>(kPositions, data.vertex_positions);
    writer.add_array<NormalCode>(kNormals, data.vertex_normals);
    add_if_present(writer, kUvs, data.vertex_uvs);
    writer.add_array<std::array<std::uint32_t, 3>>(kTriangles, data.triangles);
    writer.add_array<std::uint32_t>(kMaterials, data.triangle_materials);
    writer.add(kScene, std::as_bytes(std::span(data.scene_json)));
    writer.add(kBuild, std::as_bytes(std::span(data.build_json)));
    writer.write(path);
}

Affine3f HierarchyInstance::affine() const {
    Affine3f a = Affine3f::Identity();
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c) {
            a.matrix()(r, c) = transform[static_cast<std::size_t>(4 * r + c)];
        }
    }
    return a;
}

std::array<float, 12> HierarchyInstance::pack(const Affine3f& t) {
    std::array<float, 12> out{};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c) {
            out[static_cast<std::size_t>(4 * r + c)] = t.matrix()(r, c);
        }
    }
    return out;
}

void HierarchyFile::check_materials(std::uint32_t material_count) const {
    mrt::check_materials(m_file.path(), m_view, material_count);
}

void HierarchyFile::check_channels(const HierarchyChannels& needed) const {
    if (m_view.core.empty()) {
        return;
    }
    struct Channel {
        bool needed;
        bool present;
        std::uint32_t tag;
        const char* what;
    };
    const Channel channels[] = {
        {needed.specular, !m_view.specular.empty(), kSpecular,
         "specular channel, which a material with a specular colour needs"},
        {needed.mirror, !m_view.mirror.empty(), kMirror,
         "mirror channel (reflectivity, roughness, normal gradients), which a reflecting or "
         "refracting material needs"},
        {needed.refraction, !m_view.refraction.empty(), kRefraction,
         "refraction channel (transparency, index of refraction), which a transparent material "
         "needs"},
        {needed.emission, !m_view.emission.empty(), kEmission,
         "emission channel, which an emitting material needs"},
        {needed.opacity, !m_view.opacity.empty(), kOpacity,
         "opacity channel, which a cut-out material needs"},
    };
    for (const Channel& c : channels) {
        if (c.needed && !c.present) {
            throw Error(m_file.path(), where(c.tag),
                        fmt::format("missing: the scene record's materials need the {}", c.what));
        }
    }
}

HierarchyFile::HierarchyFile(SectionFile file) : m_file(std::move(file)) {}

HierarchyFile HierarchyFile::open(const std::filesystem::path& path,
                                  std::optional<std::uint32_t> material_count) {
    HierarchyFile h(SectionFile::open(path, kHierarchyFileVersion));
    const SectionFile& f = h.m_file;

    const std::span<const HierarchyHeader> heads = f.array<HierarchyHeader>(kHead);
    if (heads.size() != 1) {
        throw Error(path, where(kHead), fmt::format("{} records, expected 1", heads.size()));
    }
    const HierarchyHeader& head = heads[0];
    if (!valid_grid(head.grid)) {
        throw Error(path, where(kHead),
                    fmt::format("grid resolution {}, expected 1 to {}", head.grid,
                                kMaxVoxelGridResolution));
    }
    for (const std::uint32_t r : head.reserved) {
        if (r != 0) {
            throw Error(path, where(kHead), "reserved fields are not zero");
        }
    }

    HierarchyView& a = h.m_view;
    a.grid = static_cast<int>(head.grid);
    a.world_object = head.world_object;
    a.objects = f.array<HierarchyObject>(kObjects);
    a.instances = f.array<HierarchyInstance>(kInstances);
    a.nodes = f.array<HierarchyNode>(kNode);
    a.core = f.array<PointCore>(kCore);
    a.offset = f.array<PointOffset>(kOffset);
    a.diffuse = f.array<PointDiffuse>(kDiffuse);
    a.specular = optional_array<PointSpecular>(f, kSpecular);
    a.mirror = optional_array<PointMirror>(f, kMirror);
    a.refraction = optional_array<PointRefraction>(f, kRefraction);
    a.emission = optional_array<PointEmission>(f, kEmission);
    a.opacity = optional_array<PointOpacity>(f, kOpacity);
    a.node_triangles = f.array<std::uint32_t>(kNodeTriangles);
    a.vertex_positions = f.array<std::array<float, 3>>(kPositions);
    a.vertex_normals = f.array<NormalCode>(kNormals);
    a.vertex_uvs = optional_array<std::array<float, 2>>(f, kUvs);
    a.triangles = f.array<std::array<std::uint32_t, 3>>(kTriangles);
    a.triangle_materials = f.array<std::uint32_t>(kMaterials);
    const std::span<const std::byte> scene = f.bytes(kScene);
    h.m_scene_json.assign(reinterpret_cast<const char*>(scene.data()), scene.size());
    const std::span<const std::byte> build = f.bytes(kBuild);
    h.m_build_json.assign(reinterpret_cast<const char*>(build.data()), build.size());

    if (head.node_count != a.nodes.size()) {
        throw Error(path, where(kHead),
                    fmt::format("{} nodes, but section '{}' has {}", head.node_count,
                                tag_name(kNode), a.nodes.size()));
    }
    if (head.point_count != a.core.size()) {
        throw Error(path, where(kHead),
                    fmt::format("{} points, but section '{}' has {}", head.point_count,
                                tag_name(kCore), a.core.size()));
    }
    if (head.object_count != a.objects.size() || head.instance_count != a.instances.size()) {
        throw Error(path, where(kHead),
                    fmt::format("{} objects and {} instances, but sections '{}' and '{}' have {} "
                                "and {}",
                                head.object_count, head.instance_count, tag_name(kObjects),
                                tag_name(kInstances), a.objects.size(), a.instances.size()));
    }

    check_lengths(path, a);
    check_references(path, a, material_count);
    return h;
}

}  // namespace mrt
