#pragma once
// The point hierarchy as stored in a .mrh file (DESIGN.md "The hierarchy file"): flat arrays of
// quantized, fixed-size records in the sections of a SectionFile (common/hierarchy/section_file.h),
// read in place from the memory map. Per-point data is split into channels, and a channel that no
// point of the scene needs is left out of the file:
//
//   'HEAD' always         grid resolution and counts       (HierarchyHeader, 64 bytes)
//   'PCOR' always         voxel, coverage, normal          (PointCore, 8 bytes)
//   'POFS' always         surface offset along the normal  (PointOffset, 1 byte)
//   'PDIF' always         diffuse colour, normals' spread  (PointDiffuse, 4 bytes)
//   'PSPC' any specular   specular colour, Phong exponent  (PointSpecular, 4 bytes)
//   'PMIR' any mirror     reflectivity, roughness, normal gradient, tangent angle
//          or refraction                                   (PointMirror, 12 bytes)
//   'PTRN' any refraction transparency, index of refraction (PointRefraction, 2 bytes)
//   'PEMI' any emission   emitted radiance                 (PointEmission, 6 bytes)
//   'POPA' any cut-out    share of the area that stands    (PointOpacity, 1 byte)
//
// Geometry is instanced (DESIGN.md, Wand & Straßer §6 "hierarchical instantiation"): the file
// holds objects ('OBJS', HierarchyObject), each a tree of nodes in its own space. A mesh object
// is the point octree of one unique mesh; a group object is a tree over instances ('INST',
// HierarchyInstance: an object and its transform into the group's space) whose inner nodes
// carry group-space points approximating every instance below them, so a far-away field of
// plants costs a few points, not one traversal per plant. An instance refers only to an object
// listed before its group (no cycles); the world is one object of the header. A flattened build
// is a single mesh object over every triangle of the world.
//
// Nodes ('NODE', Node, 64 bytes) are grouped by object; within one, breadth-first, so a node's
// children are consecutive. Triangles kept in nodes are listed in 'NTRI' (indices into 'TRIS');
// vertices in 'VPOS' (float positions, object space), 'VNRM' (quantized normals) and, when
// anything is textured, 'VTUV'. 'TMAT' holds each triangle's material. 'SCEN' is the scene
// record (common/scene_io/scene_record.h: camera, lights, materials, textures; JSON text), 'BILD'
// JSON text: the build parameters.

#include "common/hierarchy/hierarchy_channels.h"
#include "common/hierarchy/section_file.h"
#include "common/math/math.h"
#include "common/math/quantization.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace mrt {

/// Format version of .mrh files this build reads and writes.
inline constexpr std::uint32_t kHierarchyFileVersion = 4;

/// The single record of the 'HEAD' section: the grid of every node and the counts the arrays
/// are checked against.
struct HierarchyHeader {
    std::uint32_t grid;                      ///< Voxels per node side, k in [1, 256].
    std::uint32_t node_count;                ///< Records in 'NODE'.
    std::uint32_t point_count;               ///< Records in 'PCOR' and in every point channel.
    std::uint32_t object_count;              ///< Records in 'OBJS' (at least one).
    std::uint32_t instance_count;            ///< Records in 'INST'.
    std::uint32_t world_object;              ///< The object that is the scene (world space).
    std::array<std::uint32_t, 10> reserved;  ///< Zero; room for later versions.
};
static_assert(sizeof(HierarchyHeader) == 64);

/// One octree node. Children are nodes [first_child, first_child + popcount(child_mask)) in
/// octant order; octant bit i set means a child in octant i (x = bit 0, y = bit 1, z = bit 2).
/// Positions are in the space of the node's object.
struct HierarchyNode {
    std::array<float, 3> origin;         ///< Minimum corner of the node's cube.
    float side;                          ///< Edge of the cube; voxel = side / grid.
    std::array<float, 3> sphere_centre;  ///< Bounding sphere of the whole subtree.
    float sphere_radius;
    std::uint32_t first_point;
    std::uint32_t point_count;
    std::uint32_t first_triangle;  ///< Into 'NTRI'.
    std::uint32_t triangle_count;
    std::uint32_t first_child;  ///< Meaningful when child_mask ≠ 0.
    std::uint32_t parent;       ///< The root's is 0xffffffff.
    std::uint8_t child_mask;
    std::uint8_t level;            ///< Depth below the root of its object's tree.
    std::uint16_t instance_count;  ///< Group objects: instances held in this node.
    std::uint32_t first_instance;  ///< Into 'INST'; meaningful when instance_count ≠ 0.
};
static_assert(sizeof(HierarchyNode) == 64);

/// What an object is made of.
enum class HierarchyObjectKind : std::uint32_t {
    Mesh = 0,   ///< A point octree over triangles: nodes hold points and triangles.
    Group = 1,  ///< A tree over instances: nodes hold points and instances.
};

/// One object of 'OBJS': its nodes and, for a mesh, its triangles and vertices, each a range.
struct HierarchyObject {
    std::uint32_t first_node;  ///< Its root; the tree is [first_node, first_node + node_count).
    std::uint32_t node_count;
    HierarchyObjectKind kind;
    std::uint32_t first_triangle;  ///< Mesh: its triangles in 'TRIS' (zero for a group).
    std::uint32_t triangle_count;
    std::uint32_t first_vertex;  ///< Mesh: the vertices its triangles use (zero for a group).
    std::uint32_t vertex_count;
    std::uint32_t reserved;  ///< Zero.
};
static_assert(sizeof(HierarchyObject) == 32);

/// One record of 'INST': `object` placed in its group's space by the affine map `transform`
/// (row-major 3×4, object space → group space; finite and invertible).
struct HierarchyInstance {
    std::array<float, 12> transform;
    std::uint32_t object;                   ///< Listed before the group that holds it.
    std::array<std::uint32_t, 3> reserved;  ///< Zero.

    Affine3f affine() const;
    static std::array<float, 12> pack(const Affine3f& transform);
};
static_assert(sizeof(HierarchyInstance) == 64);

struct PointCore {
    VoxelCode voxel;  ///< Voxel of the node's grid; the point sits at its centre.
    /// Area the point stands for over the voxel face (OctreePoint::coverage), encode_coverage8.
    std::uint8_t coverage;
    NormalCode normal;
};
static_assert(sizeof(PointCore) == 8);

struct PointOffset {
    /// encode_offset8 of OctreePoint::offset: the surface is at voxel centre + decode·voxel
    /// side·normal (within ±1/254 of a voxel side).
    std::int8_t along_normal;
};
static_assert(sizeof(PointOffset) == 1);

struct PointDiffuse {
    std::array<std::uint8_t, 3> rgb;  ///< encode_rgb8 of the linear albedo.
    /// encode_normal_length8 of OctreePoint::normal_length: how far the normals the point
    /// stands for spread, which widens its highlight (Toksvig). In this always-present channel
    /// because it fits its spare byte.
    std::uint8_t normal_length;
};
static_assert(sizeof(PointDiffuse) == 4);

struct PointSpecular {
    std::array<std::uint8_t, 3> rgb;  ///< encode_rgb8 of the linear specular colour.
    std::uint8_t phong;               ///< encode_phong8.
};
static_assert(sizeof(PointSpecular) == 4);

struct PointMirror {
    std::uint8_t reflectivity;    ///< encode_unit8.
    std::uint8_t roughness;       ///< encode_unit8.
    std::uint16_t tangent_angle;  ///< encode_tangent_angle of the gradient's frame.
    GradientCode gradient;        ///< Half floats, column-major, in the tangent frame.
};
static_assert(sizeof(PointMirror) == 12);

struct PointRefraction {
    std::uint8_t transparency;  ///< encode_unit8.
    std::uint8_t ior;           ///< encode_ior8.
};
static_assert(sizeof(PointRefraction) == 2);

struct PointEmission {
    /// encode_half of the emitted radiance per channel: a light's radiance is far above 1, which
    /// encode_rgb8 could not hold (relative step 2⁻¹¹ up to 65504).
    std::array<std::uint16_t, 3> rgb;
};
static_assert(sizeof(PointEmission) == 6);

/// The share of the surface a point stands for that a cut-out leaves standing (its opacity
/// averaged over the point's prefilter, Material::opacity_texture). Kept apart from the
/// coverage, which stays the surface's whole area: the cone tracer saturates coverage to fill
/// a surface's interior, and then lets through what the opacity does not stop.
struct PointOpacity {
    std::uint8_t opacity;  ///< encode_unit8.
};
static_assert(sizeof(PointOpacity) == 1);

/// Where a stored point's surface lies, in its node's space: the voxel centre moved along the
/// decoded normal by the decoded offset (PointOffset), what a tracer intersects; here from the
/// decoded voxel centre, voxel side and normal.
inline Vec3f point_position(const Vec3f& voxel_centre, float voxel, const Vec3f& normal,
                            const PointOffset& offset) {
    return voxel_centre + decode_offset8(offset.along_normal) * voxel * normal;
}

/// The same from the records alone.
inline Vec3f point_position(const HierarchyNode& node, int grid, const PointCore& core,
                            const PointOffset& offset) {
    const Vec3f origin(node.origin[0], node.origin[1], node.origin[2]);
    return point_position(decode_voxel(core.voxel, origin, node.side, grid),
                          node.side / static_cast<float>(grid), decode_normal(core.normal), offset);
}

/// The records of a hierarchy, wherever they live (in memory before writing, or in the
/// mapped file): what the consistency checks and the tracer read.
struct HierarchyView {
    int grid = 0;
    std::uint32_t world_object = 0;
    std::span<const HierarchyObject> objects;
    std::span<const HierarchyInstance> instances;
    std::span<const HierarchyNode> nodes;
    std::span<const PointCore> core;
    std::span<const PointOffset> offset;
    std::span<const PointDiffuse> diffuse;
    std::span<const PointSpecular> specular;      ///< May be empty.
    std::span<const PointMirror> mirror;          ///< May be empty.
    std::span<const PointRefraction> refraction;  ///< May be empty.
    std::span<const PointEmission> emission;      ///< May be empty.
    std::span<const PointOpacity> opacity;        ///< May be empty.
    std::span<const std::uint32_t> node_triangles;
    std::span<const std::array<float, 3>> vertex_positions;
    std::span<const NormalCode> vertex_normals;
    std::span<const std::array<float, 2>> vertex_uvs;  ///< May be empty.
    std::span<const std::array<std::uint32_t, 3>> triangles;
    std::span<const std::uint32_t> triangle_materials;
};

/// Everything a hierarchy file holds, in memory, before writing. Optional channels are empty
/// when the scene does not need them; present ones have one record per point.
struct HierarchyData {
    int grid = 16;
    std::uint32_t world_object = 0;
    std::vector<HierarchyObject> objects;
    std::vector<HierarchyInstance> instances;
    std::vector<HierarchyNode> nodes;
    std::vector<PointCore> core;
    std::vector<PointOffset> offset;
    std::vector<PointDiffuse> diffuse;
    std::vector<PointSpecular> specular;
    std::vector<PointMirror> mirror;
    std::vector<PointRefraction> refraction;
    std::vector<PointEmission> emission;
    std::vector<PointOpacity> opacity;
    std::vector<std::uint32_t> node_triangles;
    std::vector<std::array<float, 3>> vertex_positions;
    std::vector<NormalCode> vertex_normals;
    std::vector<std::array<float, 2>> vertex_uvs;  ///< Empty, or one per vertex.
    std::vector<std::array<std::uint32_t, 3>> triangles;
    std::vector<std::uint32_t> triangle_materials;
    std::string scene_json = "{}";  ///< The scene record (common/scene_io/scene_record.h).
    std::string build_json = "{}";  ///< Build parameters.

    HierarchyView view() const {
        return {grid,           world_object, objects,   instances,         nodes,
                core,           offset,       diffuse,   specular,          mirror,
                refraction,     emission,     opacity,   node_triangles,    vertex_positions,
                vertex_normals, vertex_uvs,   triangles, triangle_materials};
    }
};

/// Writes `data` to `path` atomically; throws mrt::Error naming the file and what is
/// inconsistent (a channel of the wrong length, an index out of range) before writing anything.
void write_hierarchy_file(const std::filesystem::path& path, const HierarchyData& data);

/// A .mrh file opened for reading: the file is validated as a SectionFile and every index
/// (objects' ranges, instances and their order, points, children, parents, node triangles,
/// vertices, materials below `material_count` when given) is checked before open() returns; the
/// spans read the mapped bytes in place.
class HierarchyFile {
  public:
    static HierarchyFile open(const std::filesystem::path& path,
                              std::optional<std::uint32_t> material_count = std::nullopt);

    const HierarchyView& view() const { return m_view; }
    int grid() const { return m_view.grid; }
    std::uint32_t world_object() const { return m_view.world_object; }
    std::span<const HierarchyObject> objects() const { return m_view.objects; }
    std::span<const HierarchyInstance> instances() const { return m_view.instances; }
    std::span<const HierarchyNode> nodes() const { return m_view.nodes; }
    std::span<const PointCore> core() const { return m_view.core; }
    std::span<const PointOffset> offset() const { return m_view.offset; }
    std::span<const PointDiffuse> diffuse() const { return m_view.diffuse; }
    std::span<const PointSpecular> specular() const { return m_view.specular; }
    std::span<const PointMirror> mirror() const { return m_view.mirror; }
    std::span<const PointRefraction> refraction() const { return m_view.refraction; }
    std::span<const PointEmission> emission() const { return m_view.emission; }
    std::span<const PointOpacity> opacity() const { return m_view.opacity; }
    std::span<const std::uint32_t> node_triangles() const { return m_view.node_triangles; }
    std::span<const std::array<float, 3>> vertex_positions() const {
        return m_view.vertex_positions;
    }
    std::span<const NormalCode> vertex_normals() const { return m_view.vertex_normals; }
    std::span<const std::array<float, 2>> vertex_uvs() const { return m_view.vertex_uvs; }
    std::span<const std::array<std::uint32_t, 3>> triangles() const { return m_view.triangles; }
    std::span<const std::uint32_t> triangle_materials() const { return m_view.triangle_materials; }
    /// Throws mrt::Error (as open() with a material count would) unless every triangle's
    /// material is below `material_count`: for readers that learn the count from the file's
    /// own scene record.
    void check_materials(std::uint32_t material_count) const;
    /// Throws mrt::Error naming the file and the first point channel `needed` asks for (by
    /// needed_channels, the writer's rule) that the file lacks. A file without points needs
    /// none; the uv channel is not checked (whether a mesh has uvs is known only from it).
    void check_channels(const HierarchyChannels& needed) const;
    const std::string& scene_json() const { return m_scene_json; }
    const std::string& build_json() const { return m_build_json; }
    const SectionFile& sections() const { return m_file; }

  private:
    explicit HierarchyFile(SectionFile file);

    SectionFile m_file;
    HierarchyView m_view;  ///< Spans into m_file's mapping.
    std::string m_scene_json;
    std::string m_build_json;
};

}  // namespace mrt
