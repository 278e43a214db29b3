#pragma once
// The multi-resolution traversal of Wand & Straßer §5.1: one ray cone through the hierarchy
// file's trees, filling a per-ray A-buffer (trace/cone/abuffer.h) with weighted point and triangle
// fragments. From an object's root, recursively:
//
//   1. the cone against the node's bounding sphere (§4.6, trace/cone/cone_bounds.h); nothing more
//      when it misses, or when the sphere lies wholly behind what is already opaque;
//   2. the triangles kept in the node (§4.5, trace/cone/cone_triangle.h);
//   3. the minimum diameter of the (anisotropy-clamped) footprint at the node against the
//      node's point spacing: points dense enough are intersected (§4.3, trace/cone/cone_ray.h) and
//      the traversal stops; otherwise it goes on to the children, nearest first, and in a group
//      object to the instances the node holds, with the cone mapped into their object space.
//
// A node's points stand for everything below it (preprocess/octree/point_octree.h): in a mesh
// octree the children's triangles, not the node's own (those are intersected in step 2 at any
// level); in an instance tree the instances in its subtree. A leaf of a mesh octree has no points,
// only its triangles.
//
// Level blending (the paper's "mip-mapping"): with s = log2(d_min / h) ∈ [0, 1) for the chosen
// level (h its spacing, d_min the footprint's minimum diameter), its points are weighted by s
// and the next finer representation — each child's kept triangles and points, or where a child
// has none its whole subtree — by 1 − s. s → 1 is where the coarser level's own threshold is
// reached, s = 0 where this level's is, so the weights are continuous as a cone's footprint
// grows through the levels.
//
// One footprint per node (§5.2): the footprint is evaluated and eigen-decomposed once at the
// depth of the node's sphere centre (per cluster of triangles where it changes by more than
// 10 % across the node), for its points, for the level choice and for culling triangles; the
// triangles the cull keeps are weighed with the footprint at each vertex's own depth (the
// exact version), unless `node_frames` asks for the node's.

#include "common/hierarchy/hierarchy_file.h"
#include "common/math/math.h"
#include "common/scene/scene.h"
#include "common/texture/texture.h"
#include "trace/cone/abuffer.h"
#include "trace/cone/closed_surfaces.h"
#include "trace/cone/cone_bound_block.h"
#include "trace/cone/cone_cluster_plane.h"
#include "trace/cone/cone_cluster_spheres.h"
#include "trace/cone/cone_instance_bound.h"
#include "trace/cone/cone_ray.h"
#include "trace/cone/cone_surface.h"
#include "trace/cone/cone_triangle.h"
#include "trace/cone/cone_triangle_block.h"
#include "trace/cone/glinting_nodes.h"
#include "trace/cone/highlight_mixture.h"
#include "trace/cone/meshes_below.h"

#include <array>
#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <vector>

namespace mrt {

struct ConeTraversalOptions {
    /// False: classic cone tracing (§6, method cone-classic): points are never used, every
    /// cone descends to the triangles.
    bool points = true;
    /// Blend each chosen level with the next finer one (see the file comment).
    bool blend_levels = true;
    /// Mask: each triangle and point is inserted with the samples of the cone's cross-section it
    /// covers (trace/cone/coverage_mask.h), for a buffer compositing by masks (better than the
    /// paper's on every comparison scene, at 1.08–1.2× its cost with mask_every_cone off:
    /// docs/cone-tracer.md, "Coverage masks" and "Where masks pay"). Alpha: the paper's
    /// A-buffer.
    Compositing compositing = Compositing::Mask;
    /// With masks, also the secondary cones that composite by alpha otherwise: a cone whose
    /// spread had to be bounded, and one inside a solid after the cone tree's first
    /// interaction (ConeTracer::secondary_compositing). False: alpha for those, where masks
    /// cost most and changed the images least (docs/cone-tracer.md, "Where masks pay").
    bool mask_every_cone = false;
    /// Weigh triangles with the node's one footprint (§5.2's faster version) instead of each
    /// vertex's own. Measured on the default scene it leaves seams of a few per cent of alpha
    /// where a surface's triangles are kept in different nodes, so the exact version is the
    /// default; the node's footprint still culls the triangles before they are weighed.
    bool node_frames = false;
    TriangleWeight triangle_weight = TriangleWeight::Coverage;
    /// §5.1: the footprint's minor axis is widened to at least 1/max_anisotropy of its major
    /// axis before levels are chosen and weights computed.
    float max_anisotropy = 8.0f;
    /// Texture lookups on triangles filter over the footprint times this: the texture filter
    /// (Igehy §4, OpenImageIO's derivatives) takes a pixel's spacing, while the primary cone is
    /// scaled to the reconstruction filter's width (1/cone_pixel_scale, trace/cone/cone_tracer.h).
    float texture_footprint_scale = 1.0f;
    /// Skip the back faces of closed surfaces (trace/cone/closed_surfaces.h) for cones whose apex
    /// lies outside them: they would double a thin solid's coverage.
    bool cull_closed_back_faces = true;
    /// Test an instance's root sphere in its group's space before mapping the cone into the
    /// instance (ConeInstanceBound); false enters every instance a node holds, to compare.
    bool instance_bounds = true;
    /// Primary cones and blurred ones (rough reflections) use the points of nodes whose points
    /// glint (GlintingNodes) where their spacing is at most this fraction of the footprint's
    /// minor diameter, others' where it is at most the diameter (§5.1). Chosen on the field,
    /// where the glass bunnies' glints are most of the error, and the glossy scene, whose rough
    /// reflections average the spheres' glints (docs/cone-tracer.md, "Highlights").
    float highlight_level_scale = 0.5f;
    /// Each fragment's highlights from the mixture of its points' and triangles' own lobes
    /// (trace/cone/highlight_mixture.h); false: from its mean normal alone, Toksvig-widened.
    bool highlight_mixture = true;
};

/// What traversals did, for --stats; add up over rays and threads with +=.
struct ConeTraversalStats {
    std::uint64_t rays = 0;               ///< Cones traversed.
    std::uint64_t nodes_visited = 0;      ///< Nodes whose bounding sphere the cone touched.
    std::uint64_t spheres_tested = 0;     ///< Bounding-sphere tests.
    std::uint64_t points_tested = 0;      ///< Cone–point intersections computed.
    std::uint64_t points_hit = 0;         ///< … with a weight above the clip.
    std::uint64_t triangles_tested = 0;   ///< Cone–triangle intersections computed.
    std::uint64_t triangles_hit = 0;      ///< … with a weight above the clip.
    std::uint64_t instances_entered = 0;  ///< Cones mapped into an instance's object space.
    std::uint64_t culled_by_opacity = 0;  ///< Nodes skipped behind an opaque fragment.
    std::uint64_t back_faces_culled = 0;  ///< Triangles and points on a closed surface's back.
    /// Nodes whose points were used, and the sum of their levels (depth below their object's
    /// root) weighted by the blend weight they were used with: level_sum / level_weight is
    /// the mean level the cones chose.
    std::uint64_t point_nodes = 0;
    double level_sum = 0.0;
    double level_weight = 0.0;
    ABufferStats abuffer;  ///< Fragments merged, overflows.

    /// The mean level the cones chose (level_sum / level_weight); none when no points were used.
    std::optional<double> mean_point_level() const;

    /// Named as --stats writes them; the A-buffer's fields are written among these.
    static constexpr auto fields = std::tuple{
        Field{"cones", &ConeTraversalStats::rays},
        Field{"nodes_visited", &ConeTraversalStats::nodes_visited},
        Field{"spheres_tested", &ConeTraversalStats::spheres_tested},
        Field{"points_tested", &ConeTraversalStats::points_tested},
        Field{"points_hit", &ConeTraversalStats::points_hit},
        Field{"triangles_tested", &ConeTraversalStats::triangles_tested},
        Field{"triangles_hit", &ConeTraversalStats::triangles_hit},
        Field{"instances_entered", &ConeTraversalStats::instances_entered},
        Field{"nodes_culled_by_opacity", &ConeTraversalStats::culled_by_opacity},
        Field{"back_faces_culled", &ConeTraversalStats::back_faces_culled},
        Field{"point_nodes", &ConeTraversalStats::point_nodes},
        Field{"level_sum", &ConeTraversalStats::level_sum},
        Field{"level_weight", &ConeTraversalStats::level_weight},
        Field{"mean_point_level", &ConeTraversalStats::mean_point_level},
        Embedded{&ConeTraversalStats::abuffer},
    };
    ConeTraversalStats& operator+=(const ConeTraversalStats& o) { return add_fields(*this, o); }
};

std::ostream& operator<<(std::ostream& os, const ConeTraversalStats& s);

/// A run of a node's points or kept triangles, close together in space, with a bounding
/// sphere: a cone whose clip ellipse misses the sphere skips the run. A node keeps its points
/// over a k³ grid (k = 16: hundreds of points a cone's footprint meets a few of) and up to
/// hundreds of triangles, so without these a cone tests them all.
struct ConeCluster {
    std::array<float, 3> centre;
    float radius;
    std::uint32_t first;  ///< Into ConeGeometry::point_order() or triangle_order().
    std::uint32_t count;
};
static_assert(sizeof(ConeCluster) == 24);

/// A node's clusters: [first, first + count) of the point or triangle clusters.
struct ConeNodeClusters {
    std::uint32_t first_point_cluster = 0;
    std::uint32_t point_cluster_count = 0;
    std::uint32_t first_triangle_cluster = 0;
    std::uint32_t triangle_cluster_count = 0;
};
static_assert(sizeof(ConeNodeClusters) == 16);

/// The hierarchy file prepared for tracing, read-only and shared by every thread: the file's
/// records, each instance's inverse transform, the scene's materials and textures for the
/// triangles' attributes, and each node's points and triangles in Morton order of their
/// positions, cut into clusters.
class ConeGeometry {
  public:
    /// The records `view` spans (a mapped HierarchyFile's, or HierarchyData in memory), `scene`
    /// (the materials its triangles index, checked by whoever loaded the two together) and
    /// `textures` must outlive this.
    ConeGeometry(const HierarchyView& view, const Scene& scene, const TextureSampler& textures);

    const HierarchyView& view() const { return m_view; }
    const Scene& scene() const { return m_scene; }
    const TextureSampler& textures() const { return m_textures; }

    /// Instance i's map from its group's space into its object's.
    const Affine3f& to_object(std::uint32_t i) const { return m_to_object[i]; }
    /// Where instance i's map is a similarity, its orthogonal part (similarity_turn); the
    /// identity elsewhere.
    const Mat3f& turn(std::uint32_t i) const { return m_turn[i]; }
    /// Instance i's map of object-space normals into group space (the inverse transpose of its
    /// linear part; unnormalised results).
    const Mat3f& normal_to_group(std::uint32_t i) const { return m_normal_to_group[i]; }
    /// Instance i's object root as its group sees it.
    const ConeInstanceBound& instance_bound(std::uint32_t i) const { return m_instance_bounds[i]; }
    /// The closed surfaces of the meshes.
    const ClosedSurfaces& closed_surfaces() const { return m_closed; }
    const MeshesBelow& meshes_below() const { return m_meshes_below; }
    const GlintingNodes& glinting_nodes() const { return m_glinting; }
    /// The scene's elliptical lights and its mesh lights as ellipses (elliptical_lights).
    const std::vector<EllipticalAreaLight>& area_lights() const { return m_area_lights; }
    /// The scene's first lights, as the highlight mixture needs them.
    const HighlightLights& highlight_lights() const { return m_highlight_lights; }

    const ConeNodeClusters& clusters(std::uint32_t node) const { return m_node_clusters[node]; }
    /// The bounding spheres of a node's children (a node with children only), tested together.
    const ConeChildBlock& children(std::uint32_t node) const {
        return m_child_blocks[m_child_block[node]];
    }
    const ConeCluster& point_cluster(std::uint32_t i) const { return m_point_clusters[i]; }
    const ConeClusterPlane& point_cluster_plane(std::uint32_t i) const {
        return m_point_cluster_planes[i];
    }
    /// The voxel codes and offsets of point cluster i's points, in their point_order().
    const ConeVoxelBlock& point_voxels(std::uint32_t i) const { return m_point_voxels[i]; }
    const ConeCluster& triangle_cluster(std::uint32_t i) const { return m_triangle_clusters[i]; }
    const ConeTriangleClusterPlane& triangle_cluster_plane(std::uint32_t i) const {
        return m_triangle_cluster_planes[i];
    }
    /// The point and the triangle clusters' bounding spheres, a node's tested together.
    const ConeClusterSpheres& point_cluster_spheres() const { return m_point_cluster_spheres; }
    const ConeClusterSpheres& triangle_cluster_spheres() const {
        return m_triangle_cluster_spheres;
    }
    /// Point indices (into the file's point arrays), each node's a permutation of its range.
    std::uint32_t point_order(std::uint32_t i) const { return m_point_order[i]; }
    /// Triangle indices (into 'TRIS'), each node's its kept triangles permuted.
    std::uint32_t triangle_order(std::uint32_t i) const { return m_triangle_order[i]; }
    /// The bounding spheres of triangle cluster i's triangles, in their triangle_order(): a cone
    /// tests them before gathering the triangles' vertices (most triangles of a cluster the cone
    /// touches are still beyond its reach).
    const ConeBoundBlock& triangle_bounds(std::uint32_t i) const { return m_triangle_bounds[i]; }
    /// The vertices of triangle cluster i's triangles, in their triangle_order(): a cone rejects
    /// most of those whose spheres it reaches from these, without reading the file's indices.
    const ConeTriangleBlock& triangle_vertices(std::uint32_t i) const {
        return m_triangle_vertices[i];
    }

  private:
    HierarchyView m_view;
    const Scene& m_scene;
    const TextureSampler& m_textures;
    std::vector<Affine3f> m_to_object;
    std::vector<Mat3f> m_turn;
    std::vector<Mat3f> m_normal_to_group;
    std::vector<ConeInstanceBound> m_instance_bounds;
    ClosedSurfaces m_closed;
    MeshesBelow m_meshes_below;
    GlintingNodes m_glinting;
    std::vector<EllipticalAreaLight> m_area_lights;
    HighlightLights m_highlight_lights;
    std::vector<ConeNodeClusters> m_node_clusters;
    static constexpr std::uint32_t kNoChildren = 0xffffffffu;
    std::vector<std::uint32_t> m_child_block;  ///< Per node, into m_child_blocks.
    std::vector<ConeChildBlock> m_child_blocks;
    std::vector<ConeCluster> m_point_clusters;
    std::vector<ConeVoxelBlock> m_point_voxels;
    std::vector<ConeClusterPlane> m_point_cluster_planes;
    std::vector<ConeCluster> m_triangle_clusters;
    std::vector<ConeTriangleClusterPlane> m_triangle_cluster_planes;
    std::vector<std::uint32_t> m_point_order;
    std::vector<std::uint32_t> m_triangle_order;
    std::vector<ConeBoundBlock> m_triangle_bounds;
    std::vector<ConeTriangleBlock> m_triangle_vertices;
    ConeClusterSpheres m_point_cluster_spheres;
    ConeClusterSpheres m_triangle_cluster_spheres;
};

class ConeTraversal {
  public:
    /// `stop`, when given, is polled at every node: once it is set, traversals return at once
    /// (the caller's guard on classic cone tracing, which can run for hours).
    ConeTraversal(const ConeGeometry& geometry, const ConeTraversalOptions& options,
                  const std::atomic<bool>* stop = nullptr);

    /// Inserts the fragments of the world-space cone `ray` between t_min and t_max (world
    /// units along its unit direction) into `buffer`, which is not cleared first.
    ///
    /// `leaving`: the surface a cone from a fragment leaves (Fragment::surface), kAnySurface
    /// where it is not known. Near its apex a cone skips the primitives of that surface whose
    /// planes pass within its start (it cannot meet again the surface it starts on, and its
    /// footprint there is below the start's resolution), not those of another surface: a
    /// cone leaving a glass bunny's underside meets the floor it stands on.
    /// `finer_glints`: the cone uses glinting nodes' points a level finer
    /// (ConeTraversalOptions::highlight_level_scale; the cone tracer's primary cones and
    /// blurred ones).
    /// `leaving_side`: the sign of d·n of the cone's direction d and the outward normal n of
    /// where it starts (0: not known). A primitive of the surface left whose normal makes the
    /// other sign with d faces the cone from the far side (a solid's far side seen from inside
    /// it): it is not where the cone starts, however near, and only the exactly coplanar test
    /// applies to it.
    void trace(const ConeRay& ray, float t_min, float t_max, ABuffer<ConeSurface>& buffer,
               ConeTraversalStats& stats, std::uint32_t leaving = kAnySurface,
               bool finer_glints = false, float leaving_side = 0.0f) const;
    /// The same for a shadow cone: only the fragments' weights.
    void trace(const ConeRay& ray, float t_min, float t_max, ABuffer<ConeOpacity>& buffer,
               ConeTraversalStats& stats, std::uint32_t leaving = kAnySurface) const;

    const ConeTraversalOptions& options() const { return m_options; }
    const ConeGeometry& geometry() const { return m_geometry; }

  private:
    template <class Buffer>
    void traverse(const ConeRay& ray, float t_min, float t_max, Buffer& buffer,
                  ConeTraversalStats& stats, std::uint32_t leaving, bool finer_glints,
                  float leaving_side) const;

    const ConeGeometry& m_geometry;
    ConeTraversalOptions m_options;
    const std::atomic<bool>* m_stop;
};

}  // namespace mrt
