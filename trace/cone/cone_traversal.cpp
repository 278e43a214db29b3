#include "trace/cone/cone_traversal.h"

#include "common/footprint/footprint.h"
#include "common/footprint/point_weight.h"
#include "common/math/invertibility.h"
#include "common/math/quantization.h"
#include "trace/cone/apex_ellipse.h"
#include "trace/cone/cone_bounds.h"
#include "trace/cone/cone_point_lanes.h"
#include "trace/render/mesh_light.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <ostream>
#include <type_traits>

namespace mrt {

namespace {

/// The clip ellipse's radius in the units of the point weight's Gaussian (√ln 50).
constexpr float kClipRadius = 1.977883f;
/// Added to the clip radius where points and their clusters are culled before they are weighed,
/// in the Gaussian's units: their positions there are computed along another path than the
/// clusters' bounds were (rounding of a few ulps of the coordinates). A point it lets through
/// weighs at most the clip's 2 %, and is weighed exactly.
constexpr float kClipCullMargin = 1e-3f;
/// Where the tangent of the angle between a ray and a surface stops widening a point's depth
/// tolerance: a point's own extent is half a voxel, and a wider interval from the (nearly
/// weightless) points a closed object shows edge-on would glue its front and back into one
/// fragment (measured on a sphere).
constexpr float kPointToleranceTangent = 2.0f;
/// The same for triangles: those of one plane agree on its depth at the axis
/// (ConeTriangleHit) unless it is edge-on, where they weigh little.
constexpr float kTriangleToleranceTangent = 2.0f;

/// A node's triangles are weighed with one footprint (§5.2) while it changes by less than this
/// fraction across the node's depths; beyond, each vertex gets the footprint at its own depth.
constexpr float kNodeFootprintVariation = 0.1f;
/// How much wider than the weight's reach the node's one frame culls triangles before their
/// exact per-vertex weight: more than the footprint's kNodeFootprintVariation across a node.
constexpr float kCullMargin = 1.25f;
/// The anisotropy from which a cluster's triangles are tested against the cull's square in
/// their bounding spheres' block: a rounder frame's square adds little to the circle around it
/// (primary cones' triangles tested on the default scene did not change), and costs the block
/// test more than it saves.
constexpr float kSquareAnisotropy = 1.5f;
/// A cone whose apex lies within this fraction of the triangle's size (or distance) from its
/// plane left that plane: some hundred times float rounding.
constexpr float kCoplanarTolerance = 1e-5f;
/// How far from the apex, in starting radii of the cone (beyond the primitive's own size), the
/// surface a cone leaves is recognised by passing within one starting radius of the apex.
constexpr float kNearApex = 10.0f;
/// A point whose tangent plane passes within this many voxel sides of the apex of a cone that
/// left a surface stands for that surface.
constexpr float kCoplanarPoint = 0.1f;
/// A point's size for the leaving test's distance from the apex, in voxel sides.
constexpr float kPointSize = 2.0f;
/// A point's coverage mask is the disc of its area (coverage·h²) widened by this factor: discs
/// of exactly their area leave holes at the corners between a lattice's points (a disc of a
/// square's area does not reach its corners), and more where a surface runs along a layer of
/// voxels and two coincident points share its area; wider ones overstate silhouettes and thin
/// features. With the holes closed (close_holes) and each level of a blend on its own samples
/// (SampleRange), 1.3 keeps every comparison scene better than the alpha buffer, the bare plant
/// at 1.10 of the reference's coverage; narrower discs let the default scene's spheres show
/// through, wider ones widen the plant (docs/cone-tracer.md, "Each level of a blend on its own
/// samples", has the table).
constexpr float kPointDiscScale = 1.3f;
/// The coverage (share of its voxel's face) from which a point's disc gets all of
/// kPointDiscScale; below it the widening shrinks in proportion. The holes the widening closes
/// are between the points of a surface that fills its voxels; a point over a branch thinner than
/// its voxel covers a strip, which its round disc already overstates, and widened it made the
/// bare plant 1.10 of the reference's coverage. At 0.75 the plant is 1.049 and the uniform
/// plane still shows no background (1: 1.034, but the default scene's spheres show through;
/// docs/cone-tracer.md, "Discs widened by their coverage").
constexpr float kFullWideningCoverage = 0.75f;
/// A cone whose direction makes at least this cosine with the inward normal of a closed
/// surface's primitive enters the solid there (enters_solid).
constexpr float kEnteringCosine = 0.1f;
/// Per-vertex footprints need every vertex this far from the apex relative to the farthest.
constexpr float kApexRatio = 0.25f;

/// The cosine grazing_tangent divides by is floored to this, so that the quotient stays finite at
/// cos 0; the limits (at most 2, reached at cos 0.447) take over long before it matters.
constexpr float kMinimumGrazingCosine = 1e-6f;

/// A cluster's or triangle's bounding sphere is widened by this fraction of its radius, and by
/// kBoundAbsoluteMargin: rounding of the centre and of the ray frame's offsets must not make a
/// sphere miss what it bounds (a hundred float roundings); the absolute margin keeps a
/// single point's sphere of radius 0 a sphere.
constexpr float kBoundRelativeMargin = 1e-5f;
constexpr float kBoundAbsoluteMargin = 1e-30f;

float padded_bound(float radius) {
    return radius * (1.0f + kBoundRelativeMargin) + kBoundAbsoluteMargin;
}

/// tan of the angle between the ray and the surface's plane, from |n·d| = cos of the angle to
/// the normal: how far apart in depth two points of the surface a lateral unit apart are; at
/// most `limit`.
float grazing_tangent(float normal_dot_direction, float limit) {
    const float c = std::abs(normal_dot_direction);
    const float s = std::sqrt(std::max(0.0f, 1.0f - c * c));
    return std::min(s / std::max(c, kMinimumGrazingCosine), limit);
}

/// A cone seen from one object's space, and how that space maps to the world.
struct ConeSpace {
    ConeRay ray;
    float world_per_t = 1.0f;  ///< World distance along the ray per unit of this space's t.
    /// The walk's depth range [t_min, t_max] in this space's t, set where the walk enters it.
    float t_min = 0.0f;
    float t_max = 0.0f;
    /// The space this one was entered from (nullptr: the world), and the instance's map from
    /// that space's normals and to this space's vectors.
    const ConeSpace* parent = nullptr;
    const Mat3f* normal_to_parent = nullptr;
    Mat3f linear_to_object = Mat3f::Identity();

    /// Object normals → world (unnormalised), and world vectors → object vectors: needed only
    /// where a shading cone hits something, so composed on first use instead of at every
    /// instance a cone enters (hundreds per cone on the field, most of them hitting nothing).
    const Mat3f& normal_to_world() const {
        compose();
        return m_normal_to_world;
    }
    const Mat3f& to_object() const {
        compose();
        return m_to_object;
    }
    std::uint32_t id = 0;      ///< Unique within one traversal: keys the per-vertex frame cache.
    std::uint32_t object = 0;  ///< The object whose nodes the cone is in.
    /// What its intersections are to the A-buffer (ABuffer::insert): the object where it is a
    /// mesh, any surface where it is a group.
    std::uint32_t surface = 0;
    /// Whether its primitives may be of the surface the cone leaves (Walk::may_hold_left).
    bool may_be_left = true;
    float start = 0.0f;  ///< How far from the apex the cone's rays start (start_radius).
    /// The sphere tests' view of `ray.cone`, prepared once per space.
    ConeSphereTest bounds;
    /// The footprint's decompositions once for the cone where it grows from its apex.
    ApexEllipse apex;

  private:
    void compose() const {
        if (m_composed) {
            return;
        }
        if (parent != nullptr) {
            m_normal_to_world = parent->normal_to_world() * *normal_to_parent;
            m_to_object = linear_to_object * parent->to_object();
        }
        m_composed = true;
    }
    mutable bool m_composed = false;
    mutable Mat3f m_normal_to_world = Mat3f::Identity();
    mutable Mat3f m_to_object = Mat3f::Identity();
};

/// How far from the apex a cone's rays start: its footprint at t = 0.
float start_radius(const FootprintCone& cone) {
    return std::sqrt(cone.start_dev.squaredNorm() +
                     (cone.blurred ? cone.blur_start.squaredNorm() : 0.0f));
}

/// The cone of `parent` (in a group's space) in the space of an instance's object.
/// `object_scale` is the instance's ConeInstanceBound::object_scale: where it is a similarity,
/// its cone and sphere test are the parent's turned (by `turn`, similarity_turn) and scaled.
ConeSpace enter(const ConeSpace& parent, const Affine3f& to_object, const Mat3f& turn,
                const Mat3f& normal_to_group, float object_scale, float max_anisotropy) {
    ConeSpace space;
    const bool similar = object_scale > 0.0f;
    const MappedCone mapped = similar ? map_cone_similar(parent.ray, to_object, turn, object_scale)
                                      : map_cone(parent.ray, to_object);
    space.ray = mapped.ray;
    space.start = start_radius(space.ray.cone);
    space.bounds = similar ? ConeSphereTest(parent.bounds, space.ray.cone, object_scale)
                           : ConeSphereTest(space.ray.cone, max_anisotropy);
    // A similarity keeps the increments as they are (map_cone_similar), so D's decompositions.
    space.apex = similar ? parent.apex : ApexEllipse::of(space.ray.cone, max_anisotropy);
    space.world_per_t = parent.world_per_t / mapped.scale;
    space.parent = &parent;
    space.normal_to_parent = &normal_to_group;
    space.linear_to_object = to_object.linear();
    return space;
}

/// The world-space shape operator of an object-space one: n_w = N·n/|N·n|, so
/// dn_w = (I − n_w·n_wᵀ)·N·dn/|N·n| with dn = J·dp_object and dp_object = to_object·dp_w.
Mat3f shape_to_world(const Mat3f& shape, const Vec3f& normal, const ConeSpace& space) {
    const Vec3f m = space.normal_to_world() * normal;
    const float length = m.norm();
    if (!(length > 0.0f)) {
        return Mat3f::Zero();
    }
    const Vec3f n = m / length;
    const Mat3f projection = Mat3f::Identity() - n * n.transpose();
    return projection * space.normal_to_world() * shape * space.to_object() / length;
}

Vec3f to_vec(const std::array<float, 3>& a) {
    return {a[0], a[1], a[2]};
}

template <class Buffer>
class Walk {
    static constexpr bool kShade = std::is_same_v<typename Buffer::Attributes, ConeSurface>;

  public:
    Walk(const ConeGeometry& geometry, const ConeTraversalOptions& options,
         const std::atomic<bool>* stop, Buffer& buffer, ConeTraversalStats& stats, float t_min,
         float t_max, std::uint32_t leaving, float leaving_side, const HighlightLights* highlights,
         const ConeRay& world_ray, float highlight_level_scale)
        : m_geometry(geometry),
          m_view(geometry.view()),
          m_options(options),
          m_stop(stop),
          m_buffer(buffer),
          m_boxes(box_masks(buffer.sample_pattern())),
          m_stats(stats),
          m_t_min(t_min),
          m_t_max(t_max),
          m_leaving(leaving),
          m_leaving_side(leaving_side),
          m_highlights(highlights),
          m_world_origin(world_ray.origin),
          m_world_direction(world_ray.direction),
          m_highlight_level_scale(highlight_level_scale) {}

    void object(ConeSpace& space, std::uint32_t index, float weight, SampleRange samples) {
        const HierarchyObject& object = m_view.objects[index];
        space.object = index;
        space.surface = object.kind == HierarchyObjectKind::Mesh ? index : kAnySurface;
        space.may_be_left = may_hold_left(index);
        // The start's clearance keeps a cone off the surface it leaves, not off another one
        // within it: a floor under a glass's foot lies closer than the clearance.
        space.t_min = (space.may_be_left ? m_t_min : 0.0f) / space.world_per_t;
        space.t_max = m_t_max / space.world_per_t;
        visit(space, object.first_node, weight, samples, Level::ByFootprint, Circle::Untested);
    }

  private:
    /// What one node looks like through the cone.
    struct Look {
        SphereInRayFrame sphere;
        Mat2f footprint;          ///< Clamped footprint at the node's depth.
        SymmetricEigen2 ellipse;  ///< Its ellipse: the node's one decomposition (§5.2).
        float t_min = 0.0f;
        float t_max = 0.0f;
    };

    float spacing(const HierarchyNode& node) const {
        return node.side / static_cast<float>(m_view.grid);
    }

    /// Whether a node's sphere has passed the circle test of ConeSphereTest already: a node's
    /// children are tested together, in one block (children_near_cone), before they are visited.
    enum class Circle : std::uint8_t { Untested, Passed };

    /// Early termination: whether the sphere lies wholly behind what is already opaque (counted).
    bool behind_opaque(const ConeSpace& space, const SphereInRayFrame& sphere) {
        if ((sphere.t - sphere.radius) * space.world_per_t > m_buffer.opaque_depth()) {
            ++m_stats.culled_by_opacity;
            return true;
        }
        return false;
    }

    /// Steps 1 and the early termination: false when the cone cannot reach the node.
    bool look(const ConeSpace& space, const HierarchyNode& node, Circle circle, Look& look) {
        if (m_stop != nullptr && m_stop->load(std::memory_order_relaxed)) {
            return false;
        }
        look.t_min = space.t_min;
        look.t_max = space.t_max;
        look.sphere = space.ray.sphere_of(to_vec(node.sphere_centre), node.sphere_radius);
        const FootprintCone& cone = space.ray.cone;
        const float widening = kPointKernelRadius * spacing(node);
        if (circle == Circle::Untested) {
            ++m_stats.spheres_tested;
            if (!space.bounds.circle_may_touch(look.sphere, widening, look.t_min, look.t_max)) {
                return false;
            }
        }
        if (behind_opaque(space, look.sphere)) {
            return false;
        }
        // The node's one decomposition (§5.2) gives the sphere test's axes too.
        const float t = std::clamp(look.sphere.t, look.t_min, look.t_max);
        const Mat2f footprint = cone.at(t);
        look.ellipse = ellipse_at(space, t, footprint);
        if (!space.bounds.rectangle_may_touch(look.sphere, widening, look.t_min, look.t_max,
                                              look.ellipse.major_axis)) {
            return false;
        }
        ++m_stats.nodes_visited;
        look.footprint =
            FootprintCone::clamp_decomposed(footprint, m_options.max_anisotropy, look.ellipse);
        return true;
    }

    /// FootprintCone::ellipse_of(footprint), the footprint at depth t: from the cone's one
    /// decomposition where it grows from its apex.
    static SymmetricEigen2 ellipse_at(const ConeSpace& space, float t, const Mat2f& footprint) {
        return space.apex.covers(t) ? space.apex.ellipse(t) : FootprintCone::ellipse_of(footprint);
    }

    /// How a node's level is chosen.
    enum class Level : std::uint8_t {
        ByFootprint,  ///< Its points when they are as fine as the footprint, else its children.
        /// The node stands one level below its parent's points in their level blend, so its
        /// own points are used whatever the footprint, or where it has none (a mesh leaf, an
        /// instance-tree node over one instance) everything below it at whatever level the
        /// cone chooses there.
        Finer,
    };

    /// Steps 2 and 3 at one node.
    /// `samples`: the samples of the cone this subtree's masks may cover (SampleRange), as
    /// `weight` is its share of the weights.
    void visit(const ConeSpace& space, std::uint32_t index, float weight, SampleRange samples,
               Level level, Circle circle) {
        const HierarchyNode& node = m_view.nodes[index];
        Look l;
        if (!look(space, node, circle, l)) {
            return;
        }
        triangles(space, index, l, weight, samples);
        if (m_options.points && node.point_count > 0) {
            if (level == Level::Finer) {
                points(space, index, l, weight, samples);
                return;
            }
            const float h = spacing(node);
            const float scale =
                m_geometry.glinting_nodes().glinting(index) ? m_highlight_level_scale : 1.0f;
            const float min_diameter = scale * 2.0f * std::sqrt(l.ellipse.minor);
            if (h <= min_diameter) {
                const float coarse = m_options.blend_levels
                                         ? std::clamp(std::log2(min_diameter / h), 0.0f, 1.0f)
                                         : 1.0f;
                const auto [coarse_samples, finer_samples] = samples.split(coarse);
                points(space, index, l, weight * coarse, coarse_samples);
                if (coarse < 1.0f) {
                    below(space, index, weight * (1.0f - coarse), finer_samples, Level::Finer);
                }
                return;
            }
        }
        below(space, index, weight, samples, Level::ByFootprint);
    }

    /// The children, nearest first (early termination culls more behind a near surface), and
    /// the instances a group node holds.
    void below(const ConeSpace& space, std::uint32_t index, float weight, SampleRange samples,
               Level level) {
        const HierarchyNode& node = m_view.nodes[index];
        if (node.child_mask != 0) {
            const auto count = static_cast<std::uint32_t>(std::popcount(node.child_mask));
            m_stats.spheres_tested += count;
            std::array<float, kConeChildCount> nearest;
            const std::uint32_t near =
                children_near_cone(m_geometry.children(index), count, space.ray, space.bounds,
                                   space.t_min, space.t_max, nearest);
            // Those the cone may touch, nearest first (ties in the children's order).
            std::array<std::uint32_t, kConeChildCount> order;
            int kept = 0;
            for (std::uint32_t bits = near; bits != 0; bits &= bits - 1) {
                const auto k = static_cast<std::uint32_t>(std::countr_zero(bits));
                int i = kept++;
                for (; i > 0 && nearest[order[static_cast<std::size_t>(i - 1)]] > nearest[k]; --i) {
                    order[static_cast<std::size_t>(i)] = order[static_cast<std::size_t>(i - 1)];
                }
                order[static_cast<std::size_t>(i)] = k;
            }
            for (int i = 0; i < kept; ++i) {
                visit(space, node.first_child + order[static_cast<std::size_t>(i)], weight, samples,
                      level, Circle::Passed);
            }
        }
        for (std::uint32_t i = node.first_instance; i < node.first_instance + node.instance_count;
             ++i) {
            if (!reaches_instance(space, m_geometry.instance_bound(i),
                                  m_view.instances[i].object)) {
                continue;
            }
            ++m_stats.instances_entered;
            ConeSpace inner = enter(
                space, m_geometry.to_object(i), m_geometry.turn(i), m_geometry.normal_to_group(i),
                m_geometry.instance_bound(i).object_scale, m_options.max_anisotropy);
            inner.id = ++m_spaces;
            object(inner, m_view.instances[i].object, weight, samples);
        }
    }

    /// Whether a cone may meet anything of an instance, tested in the group's space before the
    /// cone is mapped into the instance's: half of the instances a cone's node leads it to
    /// (a leaf of an instance tree holds up to four) lie beside it.
    bool reaches_instance(const ConeSpace& space, const ConeInstanceBound& bound,
                          std::uint32_t object) {
        if (!m_options.instance_bounds || !bound.similarity) {
            return true;
        }
        ++m_stats.spheres_tested;
        SphereInRayFrame sphere;
        // From the depth the object's own space will start at (object(): the start's clearance
        // only where it may hold the surface the cone leaves).
        const float t_min = may_hold_left(object) ? space.t_min : 0.0f;
        if (!may_enter(bound, space.ray, space.bounds, t_min, space.t_max, sphere)) {
            return false;
        }
        return !behind_opaque(space, sphere);
    }

    /// The Gaussian frame of the (clamped) footprint at a vertex's depth. A vertex is shared by
    /// about six triangles, which a cone meets together: a small direct-mapped cache keyed by
    /// the vertex and the space saves most of the decompositions.
    GaussianFrame vertex_frame(const ConeSpace& space, std::uint32_t vertex, float t) {
        if (space.apex.covers(t)) {
            return space.apex.frame(t);
        }
        const std::size_t slot = vertex % kFrameCacheSize;
        FrameCacheEntry& entry = m_frame_cache[slot];
        if (entry.vertex != vertex || entry.space != space.id) {
            entry.vertex = vertex;
            entry.space = space.id;
            entry.frame = GaussianFrame::of_clamped(space.ray.cone.at(t), m_options.max_anisotropy);
        }
        return entry.frame;
    }

    /// Whether a primitive of the surface left with normal n (object space, any length; its
    /// n·d given) faces the cone from the other side than where the cone starts
    /// (ConeTraversal::trace's leaving_side): not where the cone starts, however near.
    bool faces_start_from_beyond(float normal_dot_direction) const {
        return m_leaving_side * normal_dot_direction < 0.0f;
    }

    /// Whether some point of a cluster may face the cone from beyond its start
    /// (faces_start_from_beyond): its members' normals lie within `spread` of the mean's.
    bool may_face_start_from_beyond(const ConeClusterPlane& plane, const Vec3f& direction) const {
        const float along = Vec3f(plane.normal[0], plane.normal[1], plane.normal[2]).dot(direction);
        return m_leaving_side != 0.0f && !(m_leaving_side * along > plane.spread);
    }

    /// Whether a shadow cone goes into the solid bounded by `closed` (nullptr: an open surface)
    /// through a primitive with normal `normal` (its winding's, or a point's, which is outward
    /// for a closed object's points): clearly against the outward normal. The surface a shadow
    /// cone leaves faces along it; its neighbours on a curved solid may face a little away,
    /// hence the margin. Such a primitive is an occluder, never the surface the cone started
    /// on. (A refracted cone does enter the solid whose surface it leaves.)
    static bool enters_solid(const ConeSpace& space, const ClosedSurface* closed,
                             const Vec3f& normal) {
        return !kShade && closed != nullptr &&
               closed->entered_through(normal.dot(space.ray.direction), normal.norm(),
                                       kEnteringCosine);
    }

    /// Whether an object's primitives may be of the surface the cone leaves, which the leaving
    /// tests and the start's clearance keep it off: another object's are met even where they
    /// touch the apex (a floor under a glass's foot); a group's points where the group holds
    /// the surface (MeshesBelow: the ground's coarse points, a voxel of many boards, are not a
    /// glass bunny's underside).
    bool may_hold_left(std::uint32_t object) const {
        return m_leaving == kAnySurface || m_geometry.meshes_below().holds(object, m_leaving);
    }

    /// Whether the primitive at `position` with unit `normal` (of size `size`) is the surface
    /// a cone leaving it starts on: its plane passes within `tolerance` of the apex — or within
    /// the cone's own starting radius when the primitive is near the apex, so a curved
    /// surface's neighbouring triangles and points, below the start's resolution, are not
    /// taken for occluders either.
    static bool leaves(const ConeSpace& space, const Vec3f& position, const Vec3f& normal,
                       float tolerance, float size, bool near_apex = true) {
        const Vec3f apart = space.ray.origin - position;
        return leaves(space, std::abs(normal.dot(apart)), apart.squaredNorm(), tolerance, size,
                      near_apex);
    }
    /// The same from the plane's distance to the apex and the primitive's squared distance.
    static bool leaves(const ConeSpace& space, float plane_distance, float squared_distance,
                       float tolerance, float size, bool near_apex = true) {
        if (!near_apex) {
            return plane_distance <= tolerance;
        }
        return is_surface_left(plane_distance, squared_distance, tolerance, space.start,
                               size + kNearApex * space.start);
    }

    /// The node's footprint as points' masks need it: the map into the Gaussian's units that
    /// the triangles' vertices use (GaussianFrame::map, y = S·x with S = (F·Fᵀ)^(−1/2)), its
    /// inverse S⁻¹ = (F·Fᵀ)^(1/2) and S⁻² = F·Fᵀ, which carry a disc's quadratic form there.
    /// Once per node, not per point.
    struct PointMaskFrame {
        GaussianFrame map;
        Mat2f root;
        Mat2f square;
        CoverageMask samples;  ///< The samples the node's level may cover (SampleRange).
        /// ‖S‖₂ = 1/√minor: a disc of radius ρ lies within ρ·‖S‖₂ of its centre in the
        /// Gaussian's units, whatever its tilt (infinite for a degenerate footprint).
        float reach_per_radius;

        PointMaskFrame(const SymmetricEigen2& e, CoverageMask level_samples)
            : map(GaussianFrame::of_ellipse(e)),
              root(std::sqrt(e.major) * e.major_axis * e.major_axis.transpose() +
                   std::sqrt(e.minor) * e.minor_axis * e.minor_axis.transpose()),
              square(e.major * e.major_axis * e.major_axis.transpose() +
                     e.minor * e.minor_axis * e.minor_axis.transpose()),
              samples(level_samples),
              reach_per_radius(e.minor > 0.0f ? 1.0f / std::sqrt(e.minor)
                                              : std::numeric_limits<float>::infinity()) {}
    };

    void points(const ConeSpace& space, std::uint32_t index, const Look& l, float weight,
                SampleRange samples) {
        const HierarchyNode& node = m_view.nodes[index];
        if (!(weight > 0.0f)) {
            return;
        }
        ++m_stats.point_nodes;
        m_stats.level_sum += static_cast<double>(weight) * node.level;
        m_stats.level_weight += weight;
        const float h = spacing(node);
        const PointWeightFrame frame = point_weight_frame(l.footprint, h);
        const std::optional<PointMaskFrame> masks =
            m_options.compositing == Compositing::Mask
                ? std::optional<PointMaskFrame>(std::in_place, l.ellipse, samples.mask())
                : std::nullopt;
        const Vec3f origin = to_vec(node.origin);
        // The widening adds (β·h)² to both eigenvalues.
        const float widening = kPointKernelRadius * h;
        const float clip_reach =
            std::sqrt(kPointWeightClipExponent * (l.ellipse.major + widening * widening));
        // A solid seen from outside: its points facing away from the apex stand for its back.
        const ClosedSurface* solid = m_geometry.closed_surfaces().of_object(space.object);
        const ClosedSurface* closed =
            m_options.cull_closed_back_faces && solid != nullptr &&
                    solid->seen_from_outside(space.ray.origin, space.start)
                ? solid
                : nullptr;
        // In the Gaussian's units a cluster's sphere (around its points' positions) stretches by
        // at most ‖G⁻¹‖₂: the circle around the clip ellipse passes a long thin cone's clusters
        // along its minor axis, this test does not. A voxel centre moves by its point's stored
        // offset along the normal, at most |offset|·h·‖G⁻¹‖₂.
        const float stretch = largest_singular_value(frame.inverse) * (1.0f + kBoundRelativeMargin);
        const float offset_stretch = h * stretch / 127.0f;  // per step of the offset's code
        const VoxelsInRayFrame voxels(space.ray, frame, origin, h, offset_stretch);
        // The points of the surface a cone leaves (point(): the leaving test, both clauses),
        // skipped a whole flat cluster at a time, or a cluster around the apex; half the
        // tolerance and the start, and the near distance short by a per cent, so that the points'
        // own test, rounded in the ray's frame, would have skipped each of them too. Where the
        // cone may enter a solid through some of them (a shadow cone on a closed surface) they
        // are tested one by one.
        const bool left = space.may_be_left;
        const bool skips_leaving = left && l.t_min > 0.0f && (kShade || solid == nullptr);
        const float leaving = 0.5f * kCoplanarPoint * h;
        const float leaving_start = 0.5f * space.start;
        const float leaving_near = 0.99f * (kPointSize * h + kNearApex * space.start);
        // The points the voxel test lets through are decoded, placed and tested a cluster at a
        // time, in SIMD lanes (weigh_points); only the hits are weighed and inserted one by one.
        PointLanesInput in;
        in.first = {voxels.first.t, voxels.first.offset.x(), voxels.first.offset.y()};
        for (std::size_t a = 0; a < 3; ++a) {
            in.step[a] = {voxels.step[a].t, voxels.step[a].offset.x(), voxels.step[a].offset.y()};
        }
        in.direction = space.ray.direction;
        in.u = space.ray.cone.u;
        in.v = space.ray.cone.v;
        in.spacing = h;
        in.inverse = frame.inverse;
        in.t_min = l.t_min;
        in.t_max = l.t_max;
        in.closed = closed;
        in.start = space.start;
        // As for triangles: the surface a cone leaves is not met again by the points that
        // stand for it (a coarse level's points reach far across the start), unless the cone
        // enters the solid through them (enters_solid). Another object's points are met: a
        // floor under the surface's edge is not the surface (may_hold_left).
        in.leaving = left && l.t_min > 0.0f;
        in.coplanar = kCoplanarPoint * h;
        in.near = kPointSize * h + kNearApex * space.start;
        in.entered = kShade ? nullptr : solid;
        in.entering_cosine = kEnteringCosine;
        in.leaving_side = m_leaving_side;
        PointLanes& lanes = m_lanes;
        const ConeNodeClusters& clusters = m_geometry.clusters(index);
        const std::uint32_t end = clusters.first_point_cluster + clusters.point_cluster_count;
        for (std::uint32_t first = clusters.first_point_cluster; first < end;
             first += kConeClusterSize) {
            // The clusters whose spheres come within the clip's circle, a block at a time.
            for (std::uint32_t reached =
                     clusters_near_axis(m_geometry.point_cluster_spheres(), first,
                                        std::min(end - first, kConeClusterSize), space.ray,
                                        clip_reach, l.t_min, l.t_max);
                 reached != 0; reached &= reached - 1) {
                const std::uint32_t c =
                    first + static_cast<std::uint32_t>(std::countr_zero(reached));
                const ConeCluster& cluster = m_geometry.point_cluster(c);
                const VertexInRayFrame centre = space.ray.frame_of(to_vec(cluster.centre));
                const float reach = voxels.gaussian.clip + cluster.radius * stretch;
                if (!((frame.inverse * centre.offset).squaredNorm() <= reach * reach)) {
                    continue;
                }
                if (skips_leaving &&
                    !may_face_start_from_beyond(m_geometry.point_cluster_plane(c),
                                                space.ray.direction) &&
                    cluster_leaves(m_geometry.point_cluster_plane(c), to_vec(cluster.centre),
                                   cluster.radius, space.ray.origin, leaving, leaving_start,
                                   leaving_near)) {
                    continue;
                }
                m_stats.points_tested += cluster.count;
                const ConeVoxelBlock& block = m_geometry.point_voxels(c);
                const std::uint32_t near =
                    voxels_within_clip(block, cluster.count, voxels.gaussian);
                if (near == 0) {
                    continue;
                }
                const std::uint32_t hits = weigh_points(block, near, in, lanes);
                m_stats.back_faces_culled +=
                    static_cast<std::uint64_t>(std::popcount(lanes.back_faces));
                for (std::uint32_t bits = hits; bits != 0; bits &= bits - 1) {
                    const auto k = static_cast<std::size_t>(std::countr_zero(bits));
                    point(space,
                          m_geometry.point_order(cluster.first + static_cast<std::uint32_t>(k)),
                          frame, lanes, k, h, weight, masks ? &*masks : nullptr);
                }
            }
        }
    }

    /// A node's voxel centres in ray coordinates and in the point weight's Gaussian ones, affine
    /// in the voxel's indices: a few multiply-adds per point instead of decoding its centre and
    /// projecting it.
    struct VoxelsInRayFrame {
        VertexInRayFrame first;                ///< The centre of voxel (0, 0, 0).
        std::array<VertexInRayFrame, 3> step;  ///< One voxel along x, y, z.
        VoxelGaussian gaussian;                ///< The same through G⁻¹, with the clip.

        VoxelsInRayFrame(const ConeRay& ray, const PointWeightFrame& frame, const Vec3f& origin,
                         float h, float offset_stretch) {
            first = ray.frame_of(origin + Vec3f::Constant(0.5f * h));
            gaussian.first = frame.inverse * first.offset;
            for (int a = 0; a < 3; ++a) {
                const std::size_t i = static_cast<std::size_t>(a);
                step[i] = {h * ray.direction[a], h * Vec2f(ray.cone.u[a], ray.cone.v[a])};
                gaussian.step[i] = frame.inverse * step[i].offset;
            }
            gaussian.clip = kClipRadius + kClipCullMargin;
            gaussian.offset_stretch = offset_stretch;
        }
    };

    /// Point i of a node of spacing h, lane k of `lanes` (weigh_points: it passed every test
    /// but its weight): weighed and inserted.
    void point(const ConeSpace& space, std::uint32_t i, const PointWeightFrame& frame,
               const PointLanes& lanes, std::size_t k, float h, float weight,
               const PointMaskFrame* masks) {
        const float along = lanes.along[k];
        const float coverage = decode_coverage8(m_view.core[i].coverage);
        const float hit_weight = point_weight_of_exponent(frame, lanes.q[k], along, coverage);
        if (!(hit_weight > 0.0f)) {
            return;
        }
        ++m_stats.points_hit;
        // Points of one surface agree on its depth at the axis (their tangent planes':
        // ConePointHit), up to the curvature across the footprint; half a voxel, more where the
        // surface is slanted, keeps a closed object's front and back (a few voxels apart at the
        // level its cone uses) in fragments of their own.
        const float tolerance =
            0.5f * h * (1.0f + 0.5f * grazing_tangent(along, kPointToleranceTangent));
        const float t = lanes.t[k];
        const Vec3f normal(lanes.nx[k], lanes.ny[k], lanes.nz[k]);
        // A cut-out's point: its disc and weight are the whole surface's, what stands of it
        // its opacity (PointOpacity), which the fragment averages (Fragment::standing_mask).
        const float opacity =
            m_view.opacity.empty() ? 1.0f : decode_unit8(m_view.opacity[i].opacity);
        const auto mask = [&](CoverageMask held) -> CoverageMask {
            return masks != nullptr ? point_mask(space, Vec2f(lanes.u[k], lanes.v[k]), normal,
                                                 along, coverage, h, held, *masks)
                                    : 0;
        };
        if constexpr (kShade) {
            ConeSurface surface = point_surface(space, i, normal);
            add_highlights(surface, t * space.world_per_t);
            m_buffer.insert(
                t * space.world_per_t, tolerance * space.world_per_t, weight * hit_weight,
                ConeSurface::Lazy{surface, [&] { return point_shape(space, i, normal, surface); }},
                mask, space.surface, opacity);
        } else {
            m_buffer.insert(t * space.world_per_t, tolerance * space.world_per_t,
                            weight * hit_weight, {}, mask, space.surface, opacity);
        }
    }

    /// The samples point i covers: the disc of the area it stands for (its coverage share of a
    /// voxel face, widened by up to kPointDiscScale so that a surface's discs leave no gaps
    /// between them, less where it covers less: kFullWideningCoverage), seen along the cone's axis,
    /// in the Gaussian's units of the node's footprint; or nothing where the fragment it joins
    /// holds (`held`) every sample it may cover. (The ellipse's own bounding box, tighter, skipped
    /// three in four exact masks on the field and cost more time than it saved: a division and two
    /// roots per point, where the circle's box is a multiplication.)
    CoverageMask point_mask(const ConeSpace& space, const Vec2f& offset, const Vec3f& normal,
                            float along, float coverage, float h, CoverageMask held,
                            const PointMaskFrame& masks) const {
        if ((masks.samples & ~held) == 0) {
            return 0;
        }
        const float widening =
            1.0f + (kPointDiscScale - 1.0f) * std::min(1.0f, coverage / kFullWideningCoverage);
        const float radius = widening * h * std::sqrt(coverage / std::numbers::pi_v<float>);
        const float cosine = std::abs(along);
        if (!(radius > 0.0f) || !(cosine > 0.0f)) {
            return 0;
        }
        // The disc seen along the axis: radius ρ across the direction m̂ of the normal's part m
        // in the u/v plane, ρ·|n·d| along it; its quadratic form there is
        // (I + (1/cos² − 1)·m̂·m̂ᵀ)/ρ² = (I + m·mᵀ/cos²)/ρ², as |m|² = 1 − cos² (a unit normal).
        // x = S⁻¹·y: in the Gaussian's units S⁻¹·form·S⁻¹ (S⁻¹ symmetric), with r = S⁻¹·m
        // (S⁻² + r·rᵀ/cos²)/ρ².
        // Most points land on samples their fragment holds: a box around the circle that holds
        // the disc (four table loads) tells, before the disc's form and its 64 tests.
        const Vec2f centre = masks.map.map(offset);
        const float reach = radius * masks.reach_per_radius;
        if ((masks.samples & ~held &
             m_boxes.of(centre.x() - reach, centre.x() + reach, centre.y() - reach,
                        centre.y() + reach)) == 0) {
            return 0;
        }
        const Vec2f r =
            masks.root * Vec2f(normal.dot(space.ray.cone.u), normal.dot(space.ray.cone.v));
        const Mat2f form =
            (masks.square + r * r.transpose() / (cosine * cosine)) / (radius * radius);
        return masks.samples & ellipse_mask(centre, form, m_buffer.sample_pattern());
    }

    /// The contribution's own highlights from the first lights (trace/cone/highlight_mixture.h)
    /// at world distance t along the axis.
    void add_highlights(ConeSurface& s, float t) const {
        if (m_highlights != nullptr && m_highlights->count() > 0 && (s.specular > 0.0f).any()) {
            s.highlights =
                m_highlights->at(m_world_origin + t * m_world_direction, m_world_direction,
                                 s.normal, s.phong_exponent, s.lobe_spread);
        }
    }

    ConeSurface point_surface(const ConeSpace& space, std::uint32_t i, const Vec3f& normal) const {
        ConeSurface s;
        // Shortened by the spread of the normals the point stands for: a fragment's average
        // normal is then as short as the spread of all its surface's normals, which is what
        // Toksvig's exponent (footprint_material) widens its highlight by.
        s.normal = decode_normal_length8(m_view.diffuse[i].normal_length) *
                   (space.normal_to_world() * normal).normalized();
        s.diffuse = decode_rgb8(m_view.diffuse[i].rgb);
        if (!m_view.specular.empty()) {
            s.specular = decode_rgb8(m_view.specular[i].rgb);
            s.phong_exponent = decode_phong8(m_view.specular[i].phong);
        }
        if (!m_view.refraction.empty()) {
            s.transparency = decode_unit8(m_view.refraction[i].transparency);
            s.ior = decode_ior8(m_view.refraction[i].ior);
        }
        if (!m_view.emission.empty()) {
            const PointEmission& e = m_view.emission[i];
            s.emission = Rgb(decode_half(e.rgb[0]), decode_half(e.rgb[1]), decode_half(e.rgb[2]));
        }
        if (!m_view.mirror.empty()) {
            const PointMirror& mirror = m_view.mirror[i];
            s.reflectivity = decode_unit8(mirror.reflectivity);
            s.roughness = decode_unit8(mirror.roughness);
        }
        return s;
    }

    /// The world-space shape operator of point i, whose attributes are `surface`: only a
    /// surface that reflects or refracts sends cones on that need it.
    Mat3f point_shape(const ConeSpace& space, std::uint32_t i, const Vec3f& normal,
                      const ConeSurface& surface) const {
        if (m_view.mirror.empty() ||
            !(surface.reflectivity > 0.0f || surface.transparency > 0.0f)) {
            return Mat3f::Zero();
        }
        const PointMirror& mirror = m_view.mirror[i];
        // The gradient's columns are ∂n/∂u, ∂n/∂v in the tangent frame (t_u, t_v).
        const Vec3f tu = decode_tangent(mirror.tangent_angle, normal);
        const Vec3f tv = normal.cross(tu);
        const Mat2f g = decode_gradient(mirror.gradient);
        Mat32f frame;
        frame.col(0) = tu;
        frame.col(1) = tv;
        const Mat3f shape = frame * g * frame.transpose();
        return shape_to_world(shape, normal, space);
    }

    void triangles(const ConeSpace& space, std::uint32_t index, const Look& l, float weight,
                   SampleRange samples) {
        const HierarchyNode& node = m_view.nodes[index];
        if (node.triangle_count == 0 || !(weight > 0.0f)) {
            return;
        }
        const float radius = std::sqrt(l.ellipse.major);
        // One frame for the node only where the footprint hardly changes across it: a large
        // node near a cone's apex (a floor's triangles kept high in the tree, seen by a cone
        // leaving that floor) would otherwise weigh its near triangles with the far footprint.
        const FootprintCone& cone = space.ray.cone;
        const float growth = cone.incr_dev.norm() + (cone.blurred ? cone.blur_incr.norm() : 0.0f);
        const bool varies =
            !(2.0f * l.sphere.radius * growth <= kNodeFootprintVariation * l.footprint.norm());
        // The node's one frame, or where the footprint varies across the node one per cluster
        // (below).
        const GaussianFrame frame = varies ? GaussianFrame{} : GaussianFrame::of_ellipse(l.ellipse);
        const bool per_vertex = !m_options.node_frames;
        // Where the weight can reach, in Gaussian units (cone_triangle.cpp's box test) times
        // the footprint's largest semi-axis; with per-vertex frames the largest over the
        // node's depths (the Frobenius norm bounds it, and it is convex in t).
        const float units = triangle_clip_radius(m_options.triangle_weight);
        float reach = (per_vertex ? kCullMargin : 1.0f) * units * radius;
        if (varies) {
            const float near = std::max(l.sphere.t - l.sphere.radius, l.t_min);
            const float far = std::min(l.sphere.t + l.sphere.radius, l.t_max);
            reach = units * std::sqrt(std::max(space.bounds.frobenius_squared(near),
                                               space.bounds.frobenius_squared(far)));
        }
        const ConeNodeClusters& clusters = m_geometry.clusters(index);
        const std::uint32_t end = clusters.first_triangle_cluster + clusters.triangle_cluster_count;
        // triangle()'s condition for its leaving test.
        const bool skips_leaving = (l.t_min > 0.0f || space.start == 0.0f) && space.may_be_left;
        std::array<ClusterCull, kConeClusterSize> batch;
        for (std::uint32_t first = clusters.first_triangle_cluster; first < end;
             first += kConeClusterSize) {
            // The clusters the cone may reach, a block at a time, and then their frames: the
            // decompositions of a block are independent, so their chains of square roots and
            // divisions overlap instead of each stalling the cull that reads it.
            std::size_t count = 0;
            for (std::uint32_t reached = clusters_near_axis(
                     m_geometry.triangle_cluster_spheres(), first,
                     std::min(end - first, kConeClusterSize), space.ray, reach, l.t_min, l.t_max);
                 reached != 0; reached &= reached - 1) {
                const std::uint32_t c =
                    first + static_cast<std::uint32_t>(std::countr_zero(reached));
                const ConeCluster& reached_cluster = m_geometry.triangle_cluster(c);
                // Every triangle of a cluster of the surface the cone leaves would be skipped
                // by triangle()'s own leaving test (its first clause, which holds whether or not
                // the cone enters a solid through it): skipped whole, before its frame. A shadow
                // cone from a floor met the floor's clusters around its start in every node
                // near it, each decomposed and each triangle gathered, placed and culled first.
                if (skips_leaving &&
                    triangle_cluster_leaves(m_geometry.triangle_cluster_plane(c),
                                            to_vec(reached_cluster.centre), reached_cluster.radius,
                                            space.ray.origin, kCoplanarTolerance)) {
                    continue;
                }
                const float t = space.ray.frame_of(to_vec(reached_cluster.centre)).t;
                batch[count++] = {c, std::clamp(t, l.t_min, l.t_max), frame, radius};
            }
            if (varies) {
                // Two thirds of these clusters (the default scene) have no triangle whose sphere
                // the cone reaches: those are found first with a reach no frame at their depth
                // can exceed (its largest semi-axis is at most the Frobenius norm of the
                // footprint and blur), so that only the rest pay for the footprint's root and
                // decomposition. Where the cone grows from its apex the frame is a scaling
                // (ApexEllipse), cheaper than the test.
                const bool bounded = space.bounds.circle().finite;
                std::size_t kept = 0;
                for (std::size_t i = 0; i < count; ++i) {
                    const ClusterCull& cull = batch[i];
                    if (bounded && !space.apex.covers(cull.t)) {
                        const float largest_reach = (per_vertex ? kCullMargin : 1.0f) * units *
                                                    space.bounds.largest_semi_axis(cull.t);
                        if (spheres_near_axis(m_geometry.triangle_bounds(cull.cluster),
                                              m_geometry.triangle_cluster(cull.cluster).count,
                                              space.ray, largest_reach, l.t_min, l.t_max) == 0) {
                            continue;
                        }
                    }
                    batch[kept++] = cull;
                }
                count = kept;
                // The node's one footprint would be wrong across it: one per cluster instead
                // (a cluster is a few triangles across).
                for (std::size_t i = 0; i < count; ++i) {
                    const Mat2f footprint = cone.at(batch[i].t);
                    SymmetricEigen2 ellipse = ellipse_at(space, batch[i].t, footprint);
                    FootprintCone::clamp_decomposed(footprint, m_options.max_anisotropy, ellipse);
                    batch[i].frame = GaussianFrame::of_ellipse(ellipse);
                    batch[i].radius = std::sqrt(ellipse.major);
                }
            }
            for (std::size_t i = 0; i < count; ++i) {
                const ClusterCull& cull = batch[i];
                const ConeCluster& cluster = m_geometry.triangle_cluster(cull.cluster);
                // The circle around the cull's ellipse (of the frame the triangle loop culls
                // with), and the per-vertex cull's square in that frame: half the triangles a
                // cluster let through were rejected by the square after their vertices had been
                // gathered and projected.
                const float triangle_reach =
                    (per_vertex ? kCullMargin : 1.0f) * units * cull.radius;
                const GaussianSquare square =
                    per_vertex && cull.frame.inverse_semi_axes.y() >
                                      kSquareAnisotropy * cull.frame.inverse_semi_axes.x()
                        ? cull.frame.square(kCullMargin * units)
                        : GaussianSquare{};
                const std::uint32_t near =
                    spheres_near_axis(m_geometry.triangle_bounds(cull.cluster), cluster.count,
                                      space.ray, triangle_reach, l.t_min, l.t_max, square);
                if (near == 0) {
                    continue;
                }
                m_stats.triangles_tested += static_cast<std::uint64_t>(std::popcount(near));
                // The cheap rejections of the triangles the spheres let through, all at once
                // from the cluster's own copy of their vertices; triangle() tests what is kept
                // again, one at a time.
                const TriangleCull vertex_cull{
                    l.t_min, l.t_max, cull.frame,
                    per_vertex ? kCullMargin * units : std::numeric_limits<float>::infinity()};
                const ConeTriangleBlock& vertices = m_geometry.triangle_vertices(cull.cluster);
                for (std::uint32_t kept =
                         triangles_within_cull(vertices, near, space.ray, vertex_cull);
                     kept != 0; kept &= kept - 1) {
                    const auto k = static_cast<std::uint32_t>(std::countr_zero(kept));
                    triangle(space, m_geometry.triangle_order(cluster.first + k),
                             vertices.vertices(k), l, per_vertex, vertex_cull, cull.radius, weight,
                             samples);
                }
            }
        }
    }

    /// A triangle cluster the cone may reach, with the frame its triangles are culled in.
    struct ClusterCull {
        std::uint32_t cluster = 0;
        float t = 0.0f;  ///< The depth of its centre, within the look's.
        GaussianFrame frame;
        float radius = 0.0f;  ///< The frame's largest semi-axis.
    };
    /// `p` are the triangle's vertices, `cull` its cheap rejections (triangles_within_cull's).
    void triangle(const ConeSpace& space, std::uint32_t triangle, const std::array<Vec3f, 3>& p,
                  const Look& l, bool per_vertex, const TriangleCull& cull, float radius,
                  float weight, SampleRange samples) {
        {
            const TriangleInRayFrame in_ray(space.ray, p);
            // The vertices in the cull's frame: culled with it (a margin wider than the
            // footprint changes across the node where each vertex is weighed with its own
            // frame, so that the triangles around a shared edge weigh exactly 1 together
            // wherever they are kept), and weighed with it where the vertices' own frames are
            // not used.
            const TriangleInRayFrame::Mapped mapped = in_ray.map(cull.frame);
            if (triangle_culled(in_ray, mapped, cull)) {
                return;
            }
            // The winding is formed only where it is read: by a closed surface's back-face test
            // and for what passes the cull.
            const auto winding_of = [&p] { return Vec3f((p[1] - p[0]).cross(p[2] - p[0])); };
            if (m_options.cull_closed_back_faces) {
                const ClosedSurface* closed = m_geometry.closed_surfaces().of_triangle(triangle);
                if (closed != nullptr && closed->seen_from_outside(space.ray.origin, space.start) &&
                    closed->back_facing(p[0], winding_of(), space.ray.origin, space.start)) {
                    ++m_stats.back_faces_culled;
                    return;
                }
            }
            const std::array<VertexInRayFrame, 3> vertices = in_ray.vertices();
            const Vec3f winding = winding_of();
            if ((l.t_min > 0.0f || space.start == 0.0f) && space.may_be_left) {
                // A cone leaving a surface starts on it: the flat surface it leaves (every
                // triangle of a floor, coplanar with the apex) cannot be met again, whatever
                // its footprint makes of the triangles around the start. A cone from a point
                // (a pinhole's) sees a plane through its apex edge-on from every ray: a
                // zero-area surface, which covers nothing (an eye at a floor's height drew it
                // as slabs over the sky, from hits at t ≈ 0 of no meaningful footprint).
                const Vec3f edge1 = p[1] - p[0];
                const Vec3f edge2 = p[2] - p[0];
                const Vec3f& normal = winding;
                const float length = normal.norm();
                const float size = std::sqrt(std::max(edge1.squaredNorm(), edge2.squaredNorm()));
                const float scale =
                    std::sqrt(std::max(size * size, (p[0] - space.ray.origin).squaredNorm()));
                // A cone entering a solid through the triangle has not left it: only the
                // exactly coplanar test applies (a cone from a floor towards a light shut in a
                // sphere standing on it meets the sphere's bottom within its start radius).
                const bool entering =
                    enters_solid(space, m_geometry.closed_surfaces().of_triangle(triangle),
                                 normal / length) ||
                    faces_start_from_beyond(normal.dot(space.ray.direction));
                if (length > 0.0f && leaves(space, p[0], normal / length,
                                            kCoplanarTolerance * scale, 2.0f * size, !entering)) {
                    return;
                }
            }
            std::array<GaussianFrame, 3> exact;
            if (per_vertex) {
                // A triangle reaching back towards the cone's apex (a floor running under the
                // camera) has no meaningful footprint at its near vertices: it keeps the
                // cull's frame.
                const float nearest = std::min({vertices[0].t, vertices[1].t, vertices[2].t});
                const float farthest = std::max({vertices[0].t, vertices[1].t, vertices[2].t});
                per_vertex = nearest > kApexRatio * farthest && nearest > l.t_min;
                const auto& tri = m_view.triangles[triangle];
                for (std::size_t i = 0; per_vertex && i < 3; ++i) {
                    exact[i] = vertex_frame(space, tri[i], vertices[i].t);
                }
            }
            const auto hit =
                per_vertex
                    ? intersect_cone_triangle(vertices, exact, m_options.triangle_weight, l.t_min)
                    : intersect_cone_triangle_mapped(vertices, mapped.points(),
                                                     m_options.triangle_weight, l.t_min);
            if (!hit || hit->t < l.t_min || hit->t > l.t_max) {
                return;
            }
            const Vec3f geometric = winding.normalized();
            // A cut-out stands for the share of the footprint its opacity, filtered over the
            // footprint as the colour is, leaves standing.
            const Material& material =
                m_geometry.scene().materials[m_view.triangle_materials[triangle]];
            std::optional<TriangleAtHit> at;
            float opacity = 1.0f;
            if (material.cut_out() && !m_view.vertex_uvs.empty()) {
                at = triangle_at(triangle, p, geometric, *hit);
                const SurfaceDifferential sd =
                    footprint_differential(space, *at, m_options.texture_footprint_scale);
                opacity = m_geometry.textures().opacity(material, at->uv, {sd.duv_dx, sd.duv_dy});
                if (!(opacity > 0.0f)) {
                    return;
                }
            }
            ++m_stats.triangles_hit;
            // In the Gaussian's units at each vertex's own depth, as the weight was computed:
            // the same sample is the same ray of the cone at every depth.
            const auto mask = [&](CoverageMask held) -> CoverageMask {
                const CoverageMask range = samples.mask();
                if (m_options.compositing != Compositing::Mask || (range & ~held) == 0) {
                    return 0;
                }
                const std::array<Vec2f, 3> y =
                    per_vertex ? std::array<Vec2f, 3>{exact[0].map(vertices[0].offset),
                                                      exact[1].map(vertices[1].offset),
                                                      exact[2].map(vertices[2].offset)}
                               : mapped.points();
                const CoverageMask box = m_boxes.of(std::min({y[0].x(), y[1].x(), y[2].x()}),
                                                    std::max({y[0].x(), y[1].x(), y[2].x()}),
                                                    std::min({y[0].y(), y[1].y(), y[2].y()}),
                                                    std::max({y[0].y(), y[1].y(), y[2].y()}));
                if ((range & box & ~held) == 0) {
                    return 0;
                }
                return range & triangle_mask(y[0], y[1], y[2], m_buffer.sample_pattern());
            };
            // The depths a flat surface spans across the footprint.
            const float tolerance =
                radius * (0.5f + grazing_tangent(geometric.dot(space.ray.direction),
                                                 kTriangleToleranceTangent));
            if constexpr (kShade) {
                if (!at) {
                    at = triangle_at(triangle, p, geometric, *hit);
                }
                ConeSurface surface = triangle_surface(space, triangle, *at);
                add_highlights(surface, hit->t * space.world_per_t);
                m_buffer.insert(hit->t * space.world_per_t, tolerance * space.world_per_t,
                                weight * hit->weight,
                                ConeSurface::Lazy{
                                    surface, [&] { return triangle_shape(space, triangle, *at); }},
                                mask, space.surface, opacity);
            } else {
                m_buffer.insert(hit->t * space.world_per_t, tolerance * space.world_per_t,
                                weight * hit->weight, {}, mask, space.surface, opacity);
            }
        }
    }

    /// What a triangle's attributes and shape operator are interpolated from at a hit.
    struct TriangleAtHit {
        std::array<Vec3f, 3> positions;
        std::array<Vec3f, 3> normals;  ///< The vertices' (decoded) normals.
        std::array<Vec2f, 3> uvs;      ///< Zero where the file has none.
        Vec3f geometric;               ///< Unit normal of the winding.
        Vec3f normal;                  ///< Interpolated unit normal (the geometric one if none).
        Vec2f uv;                      ///< Interpolated texture coordinates.
        float b1;
        float b2;
        float t;
    };

    TriangleAtHit triangle_at(std::uint32_t triangle, const std::array<Vec3f, 3>& p,
                              const Vec3f& geometric, const ConeTriangleHit& hit) const {
        const auto& tri = m_view.triangles[triangle];
        TriangleAtHit at;
        at.positions = p;
        at.geometric = geometric;
        at.b1 = hit.b1;
        at.b2 = hit.b2;
        at.t = hit.t;
        const float b[3] = {1.0f - hit.b1 - hit.b2, hit.b1, hit.b2};
        Vec3f normal = Vec3f::Zero();
        at.uv = Vec2f::Zero();
        for (std::size_t i = 0; i < 3; ++i) {
            at.normals[i] = decode_normal(m_view.vertex_normals[tri[i]]);
            normal += b[i] * at.normals[i];
            at.uvs[i] = Vec2f::Zero();
            if (!m_view.vertex_uvs.empty()) {
                const auto& t = m_view.vertex_uvs[tri[i]];
                at.uvs[i] = Vec2f(t[0], t[1]);
                at.uv += b[i] * at.uvs[i];
            }
        }
        const float length = normal.norm();
        at.normal = length > 0.0f ? Vec3f(normal / length) : geometric;
        return at;
    }

    /// The triangle's differentials across the cone's footprint at the hit, times `scale`,
    /// projected along the ray onto the triangle's plane (Igehy's transfer).
    static SurfaceDifferential footprint_differential(const ConeSpace& space,
                                                      const TriangleAtHit& at, float scale) {
        const Mat32f columns = space.ray.cone.basis() * (scale * space.ray.cone.at(at.t));
        RayDifferential footprint;
        footprint.dp_dx = columns.col(0);
        footprint.dp_dy = columns.col(1);
        const RayDifferential on_plane =
            footprint.transfer(space.ray.direction, 0.0f, at.geometric);
        return triangle_differential(at.positions.data(), at.normals.data(), at.uvs.data(), at.b1,
                                     at.b2, on_plane.dp_dx, on_plane.dp_dy, Facing::Front);
    }

    ConeSurface triangle_surface(const ConeSpace& space, std::uint32_t triangle,
                                 const TriangleAtHit& at) const {
        const Material& material =
            m_geometry.scene().materials[m_view.triangle_materials[triangle]];
        ConeSurface s;
        s.normal = (space.normal_to_world() * at.normal).normalized();
        const bool specular = (material.specular > 0.0f).any() && material.phong_exponent > 0.0f;
        s.specular = material.specular;
        s.phong_exponent = material.phong_exponent;
        s.reflectivity = material.reflectivity;
        s.transparency = material.transparency;
        s.roughness = material.roughness;
        s.ior = material.ior;
        s.emission = material.emission;
        if (material.texture >= 0) {
            // The footprint at the hit, projected along the ray onto the triangle's plane
            // (Igehy's transfer), gives the texture-space footprint of the lookup (§4).
            const SurfaceDifferential sd =
                footprint_differential(space, at, m_options.texture_footprint_scale);
            s.diffuse = m_geometry.textures().diffuse(material, at.uv, {sd.duv_dx, sd.duv_dy});
        } else {
            s.diffuse = material.diffuse;
        }
        if (specular) {
            // The turn of the interpolated normal across the footprint.
            const SurfaceDifferential sd = footprint_differential(space, at, 1.0f);
            s.lobe_spread = mirror_spread(sd.dn_dx, sd.dn_dy);
        }
        return s;
    }

    /// The world-space shape operator at a triangle's hit: only a surface that reflects or
    /// refracts sends cones on that need it.
    Mat3f triangle_shape(const ConeSpace& space, std::uint32_t triangle,
                         const TriangleAtHit& at) const {
        const Material& material =
            m_geometry.scene().materials[m_view.triangle_materials[triangle]];
        if (!(material.reflects() || material.refracts())) {
            return Mat3f::Zero();
        }
        Vec3f t1;
        Vec3f t2;
        orthonormal_basis(at.geometric, t1, t2);
        const SurfaceDifferential sd =
            triangle_differential(at.positions.data(), at.normals.data(), at.uvs.data(), at.b1,
                                  at.b2, t1, t2, Facing::Front);
        const Mat3f shape = sd.dn_dx * t1.transpose() + sd.dn_dy * t2.transpose();
        return shape_to_world(shape, at.normal, space);
    }

    const ConeGeometry& m_geometry;
    const HierarchyView& m_view;
    /// A cluster's points in lanes (Walk::points): scratch, kept here rather than formed anew
    /// for every node.
    PointLanes m_lanes;
    const ConeTraversalOptions& m_options;
    const std::atomic<bool>* m_stop;
    Buffer& m_buffer;
    const BoxMasks& m_boxes;  ///< Of the buffer's sample pattern.
    ConeTraversalStats& m_stats;
    float m_t_min;
    float m_t_max;
    /// The surface the cone leaves (ConeTraversal::trace), kAnySurface where not known.
    std::uint32_t m_leaving;
    float m_leaving_side;  ///< ConeTraversal::trace's leaving_side.
    /// The scene's lights where a shading cone mixes highlights; null otherwise (shadow cones,
    /// ConeTraversalOptions::highlight_mixture off).
    const HighlightLights* m_highlights;
    Vec3f m_world_origin;  ///< The cone's axis, world space (its highlights are world space).
    Vec3f m_world_direction;
    /// ConeTraversalOptions::highlight_level_scale for a cone with finer glints, else 1.
    float m_highlight_level_scale;
    std::uint32_t m_spaces = 0;  ///< Spaces entered so far (the world is 0).
    static constexpr std::size_t kFrameCacheSize = 64;
    struct FrameCacheEntry {
        std::uint32_t vertex = 0xffffffffu;
        std::uint32_t space = 0xffffffffu;
        GaussianFrame frame;
    };
    std::array<FrameCacheEntry, kFrameCacheSize> m_frame_cache{};
};

}  // namespace

std::optional<double> ConeTraversalStats::mean_point_level() const {
    return level_weight > 0.0 ? std::optional<double>(level_sum / level_weight) : std::nullopt;
}

std::ostream& operator<<(std::ostream& os, const ConeTraversalStats& s) {
    return print_fields(os, "ConeTraversalStats", s);
}

namespace {

/// Interleaves the low 10 bits of x, y, z.
std::uint32_t morton3(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    const auto spread = [](std::uint32_t v) {
        v &= 0x3ffu;
        v = (v | (v << 16)) & 0x030000ffu;
        v = (v | (v << 8)) & 0x0300f00fu;
        v = (v | (v << 4)) & 0x030c30c3u;
        v = (v | (v << 2)) & 0x09249249u;
        return v;
    };
    return spread(x) | (spread(y) << 1) | (spread(z) << 2);
}

/// Sorts `items` by Morton code of `position(item)` in the node's cube and appends clusters of
/// kConeClusterSize with bounding spheres (each item's extent `radius(item)` around its
/// position) to `clusters`, the sorted items to `order`.
template <class Position, class Radius>
void cluster(const HierarchyNode& node, std::vector<std::uint32_t> items, Position&& position,
             Radius&& radius, std::vector<ConeCluster>& clusters,
             std::vector<std::uint32_t>& order) {
    const Vec3f origin(node.origin[0], node.origin[1], node.origin[2]);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> keyed;
    keyed.reserve(items.size());
    for (const std::uint32_t item : items) {
        const Vec3f q =
            ((position(item) - origin) / node.side * 1023.0f).cwiseMax(0.0f).cwiseMin(1023.0f);
        keyed.emplace_back(
            morton3(static_cast<std::uint32_t>(q.x()), static_cast<std::uint32_t>(q.y()),
                    static_cast<std::uint32_t>(q.z())),
            item);
    }
    std::sort(keyed.begin(), keyed.end());
    for (std::size_t first = 0; first < keyed.size(); first += kConeClusterSize) {
        const std::size_t last = std::min(keyed.size(), first + kConeClusterSize);
        Eigen::AlignedBox3f box;
        for (std::size_t i = first; i < last; ++i) {
            box.extend(position(keyed[i].second));
        }
        const Vec3f centre = box.center();
        float r = 0.0f;
        for (std::size_t i = first; i < last; ++i) {
            r = std::max(r, (position(keyed[i].second) - centre).norm() + radius(keyed[i].second));
        }
        clusters.push_back({{centre.x(), centre.y(), centre.z()},
                            padded_bound(r),
                            static_cast<std::uint32_t>(order.size()),
                            static_cast<std::uint32_t>(last - first)});
        for (std::size_t i = first; i < last; ++i) {
            order.push_back(keyed[i].second);
        }
    }
}

/// Appends to `blocks` one block per cluster [first, first + count) of `clusters`, slot i of a
/// cluster's block filled by fill(block, i, member) with its i-th member in `order`.
template <class Block, class Fill>
void append_blocks(const std::vector<ConeCluster>& clusters, std::uint32_t first,
                   std::uint32_t count, const std::vector<std::uint32_t>& order,
                   std::vector<Block>& blocks, Fill&& fill) {
    for (std::uint32_t k = first; k < first + count; ++k) {
        const ConeCluster& run = clusters[k];
        Block& block = blocks.emplace_back();
        for (std::uint32_t i = 0; i < run.count; ++i) {
            fill(block, i, order[run.first + i]);
        }
    }
}

}  // namespace

ConeGeometry::ConeGeometry(const HierarchyView& view, const Scene& scene,
                           const TextureSampler& textures)
    : m_view(view),
      m_scene(scene),
      m_textures(textures),
      m_closed(m_view),
      m_meshes_below(m_view),
      m_glinting(m_view),
      m_area_lights(elliptical_lights(scene)),
      m_highlight_lights(scene, m_area_lights) {
    m_to_object.reserve(m_view.instances.size());
    m_turn.reserve(m_view.instances.size());
    m_normal_to_group.reserve(m_view.instances.size());
    for (const HierarchyInstance& instance : m_view.instances) {
        const Affine3f to_group = instance.affine();
        // In double: a scale of 1e13 has a determinant beyond float's range although its
        // inverse is representable (common/math/invertibility.h).
        m_to_object.push_back(inverse_in_double(to_group));
        m_normal_to_group.push_back(inverse_in_double(Mat3f(to_group.linear())).transpose());
        const HierarchyNode& root = m_view.nodes[m_view.objects[instance.object].first_node];
        m_instance_bounds.push_back(mrt::instance_bound(
            to_vec(root.sphere_centre), root.sphere_radius,
            kPointKernelRadius * root.side / static_cast<float>(m_view.grid), to_group));
        const float scale = m_instance_bounds.back().object_scale;
        m_turn.push_back(scale > 0.0f ? similarity_turn(m_to_object.back(), scale)
                                      : Mat3f::Identity());
    }
    m_node_clusters.resize(m_view.nodes.size());
    m_child_block.assign(m_view.nodes.size(), kNoChildren);
    for (std::size_t n = 0; n < m_view.nodes.size(); ++n) {
        const HierarchyNode& node = m_view.nodes[n];
        if (node.child_mask == 0) {
            continue;
        }
        m_child_block[n] = static_cast<std::uint32_t>(m_child_blocks.size());
        ConeChildBlock& block = m_child_blocks.emplace_back();
        const auto count = static_cast<std::uint32_t>(std::popcount(node.child_mask));
        for (std::uint32_t k = 0; k < count; ++k) {
            const HierarchyNode& child = m_view.nodes[node.first_child + k];
            block.x[k] = child.sphere_centre[0];
            block.y[k] = child.sphere_centre[1];
            block.z[k] = child.sphere_centre[2];
            block.radius[k] = child.sphere_radius;
            // As the node's own test widens it (Walk::look).
            block.widening[k] = kPointKernelRadius * (child.side / static_cast<float>(m_view.grid));
        }
    }
    m_point_order.reserve(m_view.core.size());
    m_triangle_order.reserve(m_view.node_triangles.size());
    std::vector<std::uint32_t> items;
    for (std::size_t n = 0; n < m_view.nodes.size(); ++n) {
        const HierarchyNode& node = m_view.nodes[n];
        ConeNodeClusters& c = m_node_clusters[n];
        items.clear();
        for (std::uint32_t i = 0; i < node.point_count; ++i) {
            items.push_back(node.first_point + i);
        }
        c.first_point_cluster = static_cast<std::uint32_t>(m_point_clusters.size());
        cluster(
            node, items,
            [&](std::uint32_t i) {
                return point_position(node, m_view.grid, m_view.core[i], m_view.offset[i]);
            },
            [](std::uint32_t) { return 0.0f; }, m_point_clusters, m_point_order);
        c.point_cluster_count =
            static_cast<std::uint32_t>(m_point_clusters.size()) - c.first_point_cluster;
        for (std::uint32_t k = c.first_point_cluster;
             k < c.first_point_cluster + c.point_cluster_count; ++k) {
            m_point_cluster_planes.push_back(cluster_plane(
                to_vec(m_point_clusters[k].centre), m_point_clusters[k].first,
                m_point_clusters[k].count, [&](std::uint32_t j) {
                    const std::uint32_t point = m_point_order[j];
                    return std::pair{
                        point_position(node, m_view.grid, m_view.core[point], m_view.offset[point]),
                        decode_normal(m_view.core[point].normal)};
                }));
        }
        append_blocks(m_point_clusters, c.first_point_cluster, c.point_cluster_count, m_point_order,
                      m_point_voxels,
                      [&](ConeVoxelBlock& block, std::uint32_t i, std::uint32_t point) {
                          block.x[i] = m_view.core[point].voxel[0];
                          block.y[i] = m_view.core[point].voxel[1];
                          block.z[i] = m_view.core[point].voxel[2];
                          block.offset[i] = m_view.offset[point].along_normal;
                          block.normal_u[i] = m_view.core[point].normal.u;
                          block.normal_v[i] = m_view.core[point].normal.v;
                      });
        items.clear();
        for (std::uint32_t k = 0; k < node.triangle_count; ++k) {
            items.push_back(m_view.node_triangles[node.first_triangle + k]);
        }
        const auto vertex = [&](std::uint32_t t, std::size_t i) {
            return to_vec(m_view.vertex_positions[m_view.triangles[t][i]]);
        };
        const auto centroid = [&](std::uint32_t t) {
            return Vec3f((vertex(t, 0) + vertex(t, 1) + vertex(t, 2)) / 3.0f);
        };
        const auto extent = [&](std::uint32_t t) {
            const Vec3f m = centroid(t);
            return std::max(
                {(vertex(t, 0) - m).norm(), (vertex(t, 1) - m).norm(), (vertex(t, 2) - m).norm()});
        };
        c.first_triangle_cluster = static_cast<std::uint32_t>(m_triangle_clusters.size());
        cluster(node, items, centroid, extent, m_triangle_clusters, m_triangle_order);
        c.triangle_cluster_count =
            static_cast<std::uint32_t>(m_triangle_clusters.size()) - c.first_triangle_cluster;
        for (std::uint32_t k = c.first_triangle_cluster;
             k < c.first_triangle_cluster + c.triangle_cluster_count; ++k) {
            const ConeCluster& tc = m_triangle_clusters[k];
            m_triangle_cluster_planes.push_back(mrt::triangle_cluster_plane(
                to_vec(tc.centre), tc.first, tc.count, [&](std::uint32_t j) {
                    const std::uint32_t t = m_triangle_order[j];
                    return std::array<Vec3f, 3>{vertex(t, 0), vertex(t, 1), vertex(t, 2)};
                }));
        }
        append_blocks(m_triangle_clusters, c.first_triangle_cluster, c.triangle_cluster_count,
                      m_triangle_order, m_triangle_bounds,
                      [&](ConeBoundBlock& block, std::uint32_t i, std::uint32_t t) {
                          const Vec3f m = centroid(t);
                          block.x[i] = m.x();
                          block.y[i] = m.y();
                          block.z[i] = m.z();
                          // Rounding of the centre and of the ray frame's offsets: a relative
                          // margin.
                          block.radius[i] = padded_bound(extent(t));
                      });
        append_blocks(m_triangle_clusters, c.first_triangle_cluster, c.triangle_cluster_count,
                      m_triangle_order, m_triangle_vertices,
                      [&](ConeTriangleBlock& block, std::uint32_t i, std::uint32_t t) {
                          block.set(i, {vertex(t, 0), vertex(t, 1), vertex(t, 2)});
                      });
    }
    m_point_cluster_spheres = ConeClusterSpheres(m_point_clusters);
    m_triangle_cluster_spheres = ConeClusterSpheres(m_triangle_clusters);
}

ConeTraversal::ConeTraversal(const ConeGeometry& geometry, const ConeTraversalOptions& options,
                             const std::atomic<bool>* stop)
    : m_geometry(geometry), m_options(options), m_stop(stop) {}

template <class Buffer>
void ConeTraversal::traverse(const ConeRay& ray, float t_min, float t_max, Buffer& buffer,
                             ConeTraversalStats& stats, std::uint32_t leaving, bool finer_glints,
                             float leaving_side) const {
    ++stats.rays;
    ConeSpace world;
    world.ray = ray;
    world.start = start_radius(ray.cone);
    world.bounds = ConeSphereTest(ray.cone, m_options.max_anisotropy);
    world.apex = ApexEllipse::of(ray.cone, m_options.max_anisotropy);
    const HighlightLights* highlights =
        std::is_same_v<typename Buffer::Attributes, ConeSurface> && m_options.highlight_mixture
            ? &m_geometry.highlight_lights()
            : nullptr;
    Walk<Buffer> walk(m_geometry, m_options, m_stop, buffer, stats, t_min, t_max, leaving,
                      leaving_side, highlights, ray,
                      finer_glints ? m_options.highlight_level_scale : 1.0f);
    walk.object(world, m_geometry.view().world_object, 1.0f, SampleRange{});
}

void ConeTraversal::trace(const ConeRay& ray, float t_min, float t_max,
                          ABuffer<ConeSurface>& buffer, ConeTraversalStats& stats,
                          std::uint32_t leaving, bool finer_glints, float leaving_side) const {
    traverse(ray, t_min, t_max, buffer, stats, leaving, finer_glints, leaving_side);
}

void ConeTraversal::trace(const ConeRay& ray, float t_min, float t_max,
                          ABuffer<ConeOpacity>& buffer, ConeTraversalStats& stats,
                          std::uint32_t leaving) const {
    traverse(ray, t_min, t_max, buffer, stats, leaving, false, 0.0f);
}

}  // namespace mrt
