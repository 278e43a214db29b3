#pragma once
// The point hierarchy as stored in a .mrh file (DESIGN.md "The hierarchy file"): flat arrays of
// quantized, fixed-size records in the sections of a SectionFile (common/section_file.h), read
// in place from the memory map. Per-point data is split into channels, and a channel that no
// point of the scene needs is left out of the file:
//
//   'HEAD' always         grid resolution and counts       (HierarchyHeader, 64 bytes)
//   'PCOR' always         voxel, coverage, normal          (PointCore, 8 bytes)
//   'PDIF' always         diffuse colour                   (PointDiffuse, 4 bytes)
//   'PSPC' any specular   specular colour, Phong exponent  (PointSpecular, 4 bytes)
//   'PMIR' any mirror     reflectivity, roughness, normal gradient, tangent angle
//          or refraction                                   (PointMirror, 12 bytes)
//   'PTRN' any refraction transparency, index of refraction (PointRefraction, 2 bytes)
//
// Nodes ('NODE', Node, 64 bytes) are in breadth-first order, so a node's children are
// consecutive. Triangles kept in nodes are listed in 'NTRI' (indices into 'TRIS'); vertices in
// 'VPOS' (float positions), 'VNRM' (quantized normals) and, when anything is textured, 'VTUV'.
// 'TMAT' holds each triangle's material. 'BILD' is JSON text: the build parameters and times.

#include "common/math.h"
#include "common/quantization.h"
#include "common/section_file.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace mrt {

/// Format version of .mrh files this build reads and writes.
inline constexpr std::uint32_t kHierarchyFileVersion = 1;

/// The single record of the 'HEAD' section: the grid of every node and the counts the arrays
/// are checked against.
struct HierarchyHeader {
    std::uint32_t grid;                      ///< Voxels per node side, k in [1, 256].
    std::uint32_t node_count;                ///< Records in 'NODE'.
    std::uint32_t point_count;               ///< Records in 'PCOR' and in every point channel.
    std::array<std::uint32_t, 13> reserved;  ///< Zero; room for later versions.
};
static_assert(sizeof(HierarchyHeader) == 64);

/// One octree node. Children are nodes [first_child, first_child + popcount(child_mask)) in
/// octant order; octant bit i set means a child in octant i (x = bit 0, y = bit 1, z = bit 2).
struct HierarchyNode {
    std::array<float, 3> origin;         ///< Minimum corner of the node's cube (world).
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
    std::uint8_t level;
    std::uint16_t reserved0;
    std::uint32_t reserved1;
};
static_assert(sizeof(HierarchyNode) == 64);

struct PointCore {
    VoxelCode voxel;        ///< Voxel of the node's grid; the point sits at its centre.
    std::uint8_t coverage;  ///< Samples' weight relative to a plane's, encode_unit8(min(1, c/2)).
    NormalCode normal;
};
static_assert(sizeof(PointCore) == 8);

struct PointDiffuse {
    std::array<std::uint8_t, 3> rgb;  ///< encode_rgb8 of the linear albedo.
    std::uint8_t reserved;
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

/// The records of a hierarchy, wherever they live (in memory before writing, or in the
/// mapped file): what the consistency checks and the tracer read.
struct HierarchyView {
    int grid = 0;
    std::span<const HierarchyNode> nodes;
    std::span<const PointCore> core;
    std::span<const PointDiffuse> diffuse;
    std::span<const PointSpecular> specular;      ///< May be empty.
    std::span<const PointMirror> mirror;          ///< May be empty.
    std::span<const PointRefraction> refraction;  ///< May be empty.
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
    std::vector<HierarchyNode> nodes;
    std::vector<PointCore> core;
    std::vector<PointDiffuse> diffuse;
    std::vector<PointSpecular> specular;
    std::vector<PointMirror> mirror;
    std::vector<PointRefraction> refraction;
    std::vector<std::uint32_t> node_triangles;
    std::vector<std::array<float, 3>> vertex_positions;
    std::vector<NormalCode> vertex_normals;
    std::vector<std::array<float, 2>> vertex_uvs;  ///< Empty, or one per vertex.
    std::vector<std::array<std::uint32_t, 3>> triangles;
    std::vector<std::uint32_t> triangle_materials;
    std::string build_json = "{}";  ///< Build parameters and times.

    HierarchyView view() const {
        return {grid,
                nodes,
                core,
                diffuse,
                specular,
                mirror,
                refraction,
                node_triangles,
                vertex_positions,
                vertex_normals,
                vertex_uvs,
                triangles,
                triangle_materials};
    }
};

/// Writes `data` to `path` atomically; throws mrt::Error naming the file and what is
/// inconsistent (a channel of the wrong length, an index out of range) before writing anything.
void write_hierarchy_file(const std::filesystem::path& path, const HierarchyData& data);

/// A .mrh file opened for reading: the file is validated as a SectionFile and every index
/// (points, children, parents, node triangles, vertices, materials below `material_count`
/// when given) is checked before open() returns; the spans read the mapped bytes in place.
class HierarchyFile {
  public:
    static HierarchyFile open(const std::filesystem::path& path,
                              std::optional<std::uint32_t> material_count = std::nullopt);

    const HierarchyView& view() const { return m_view; }
    int grid() const { return m_view.grid; }
    std::span<const HierarchyNode> nodes() const { return m_view.nodes; }
    std::span<const PointCore> core() const { return m_view.core; }
    std::span<const PointDiffuse> diffuse() const { return m_view.diffuse; }
    std::span<const PointSpecular> specular() const { return m_view.specular; }
    std::span<const PointMirror> mirror() const { return m_view.mirror; }
    std::span<const PointRefraction> refraction() const { return m_view.refraction; }
    std::span<const std::uint32_t> node_triangles() const { return m_view.node_triangles; }
    std::span<const std::array<float, 3>> vertex_positions() const {
        return m_view.vertex_positions;
    }
    std::span<const NormalCode> vertex_normals() const { return m_view.vertex_normals; }
    std::span<const std::array<float, 2>> vertex_uvs() const { return m_view.vertex_uvs; }
    std::span<const std::array<std::uint32_t, 3>> triangles() const { return m_view.triangles; }
    std::span<const std::uint32_t> triangle_materials() const { return m_view.triangle_materials; }
    const std::string& build_json() const { return m_build_json; }
    const SectionFile& sections() const { return m_file; }

  private:
    explicit HierarchyFile(SectionFile file);

    SectionFile m_file;
    HierarchyView m_view;  ///< Spans into m_file's mapping.
    std::string m_build_json;
};

}  // namespace mrt
