#pragma once
// A ray cone in one space (the world, or an instance's object space) and the cone–point
// intersection of Wand & Straßer §4.3: a surfel expressed in ray coordinates — its depth t along
// the unit direction and its offset along the footprint's u and v axes — and weighed with the
// footprint at the node's depth (common/footprint/point_weight.h). The ray-coordinate types here
// are what the cone kernels (trace/cone/cone_bounds.h, trace/cone/cone_triangle.h) take.

#include "common/footprint/footprint.h"
#include "common/footprint/point_weight.h"
#include "common/math/math.h"

#include <iosfwd>
#include <optional>

namespace mrt {

/// A vertex in the coordinates of a ray cone: `t` along the unit direction, `offset` along the
/// cone's u and v axes.
struct VertexInRayFrame {
    float t = 0.0f;
    Vec2f offset = Vec2f::Zero();
};

/// A bounding sphere in the coordinates of a ray cone: `t` along the unit direction from the
/// ray's origin, `offset` along the ray's u and v axes (FootprintCone::u, v), radius in the same
/// units.
struct SphereInRayFrame {
    float t = 0.0f;
    Vec2f offset = Vec2f::Zero();
    float radius = 0.0f;
};

std::ostream& operator<<(std::ostream& os, const SphereInRayFrame& s);

struct ConeRay {
    Vec3f origin = Vec3f::Zero();      ///< Apex of the ray's axis (this space).
    Vec3f direction = Vec3f::UnitZ();  ///< Unit direction of the axis.
    /// The footprint F(t) = start_dev + t·incr_dev on the orthonormal u, v of the plane
    /// orthogonal to `direction`.
    FootprintCone cone;

    /// p in ray coordinates: depth along the direction, offset along u and v. Differences from
    /// the origin first, so a ray far from the space's origin loses nothing more than p's own
    /// rounding.
    VertexInRayFrame frame_of(const Vec3f& p) const {
        const Vec3f d = p - origin;
        return {d.dot(direction), Vec2f(d.dot(cone.u), d.dot(cone.v))};
    }

    SphereInRayFrame sphere_of(const Vec3f& centre, float radius) const {
        const VertexInRayFrame c = frame_of(centre);
        return {c.t, c.offset, radius};
    }
};

std::ostream& operator<<(std::ostream& os, const ConeRay& ray);

/// A cone seen from another space (an instance's object space, entered from its group's).
struct MappedCone {
    ConeRay ray;
    float scale = 1.0f;  ///< The new space's t per unit of the old one's, along the axis.
};

/// The cone `ray` through the affine map `to_object`. Offsets in the ray's u/v plane map by the
/// linear part; to first order the new cross-section is their projection onto the plane
/// orthogonal to the new axis. For a similarity (rotation, reflection, uniform scale) that is
/// the mapped cone itself, scaled.
MappedCone map_cone(const ConeRay& ray, const Affine3f& to_object);

/// map_cone for a similarity `to_object` of scale `scale` (its linear part is scale times an
/// orthogonal matrix Q): the cone's frame turns with the map (u, v → Q·u, Q·v) and its
/// footprints scale, with no new basis and no 2×2 products. The frame differs from map_cone's
/// by a turn about the axis, which no consumer of a footprint's ellipse sees. `turn` is Q,
/// similarity_turn(to_object, scale): an instance's is the same for every cone entering it.
MappedCone map_cone_similar(const ConeRay& ray, const Affine3f& to_object, const Mat3f& turn,
                            float scale);
/// The orthogonal part Q of a similarity `to_object` of scale `scale`: its linear part / scale.
Mat3f similarity_turn(const Affine3f& to_object, float scale);

struct ConePointHit {
    /// Depth along the ray of the surface the point stands for: where the axis meets the
    /// point's tangent plane (Zwicker et al.'s ray–splat intersection), blended towards the
    /// point's own depth, its projection onto the axis (§4.3), as the plane turns edge-on
    /// (|n·d| from 0.3 down to 0.1). The points of one surface then agree on its depth at the
    /// axis, so a fragment's mean depth lies on the surface, not off it by a footprint's slope.
    float t = 0.0f;
    float weight = 0.0f;  ///< point_weight: the A-buffer's weight.
};

/// A point's depth is where the cone's axis meets its tangent plane only where the plane faces the
/// axis by a cosine above kPlaneDepthCosine: below, the offset over the cosine (×10 and more)
/// carries the depth off along a grazing plane, and the point's own depth is kept. Over the next
/// kPlaneDepthBlend of cosine the two are blended by a smoothstep, so that a fragment's depth does
/// not jump where a curved surface's points cross the threshold.
inline constexpr float kPlaneDepthCosine = 0.1f;
inline constexpr float kPlaneDepthBlend = 0.2f;

/// A unit normal in the coordinates of a ray cone: its component along the unit direction (n·d)
/// and along the cone's u and v axes.
struct NormalInRayFrame {
    float along = 0.0f;
    Vec2f across = Vec2f::Zero();
};

/// The depth a surfel at `p` with unit normal `n` (in ray coordinates) gives a cone's fragment:
/// where its tangent plane n·(x − p) = 0 meets the axis, t = p.t + (n_uv·offset)/(n·d), blended
/// in from the point's own depth over the grazing cosines (kPlaneDepthCosine).
inline float point_depth(const VertexInRayFrame& p, const NormalInRayFrame& n) {
    const float c = std::abs(n.along);
    if (!(c > kPlaneDepthCosine)) {
        return p.t;
    }
    const float plane = p.t + n.across.dot(p.offset) / n.along;
    const float s = std::min(1.0f, (c - kPlaneDepthCosine) / kPlaneDepthBlend);
    return p.t + s * s * (3.0f - 2.0f * s) * (plane - p.t);
}

/// Whether a primitive is the surface a cone leaving it starts on: its plane passes within
/// `tolerance` of the apex (`plane_distance` from it), or within the cone's starting radius
/// `start` while the primitive lies within `near` of the apex (`squared_distance`, squared).
inline bool is_surface_left(float plane_distance, float squared_distance, float tolerance,
                            float start, float near) {
    return plane_distance <= tolerance ||
           (plane_distance <= start && squared_distance <= near * near);
}

/// The surfel at `p` (its position on the surface, common/hierarchy/hierarchy_file.h
/// point_position, in ray coordinates) with unit normal `n` and decoded `coverage`, weighed with
/// `frame` (point_weight_frame of the footprint at the node's depth and its spacing); nothing
/// when it lies before t_min or outside the clip. The traversal's form: it has the point in ray
/// coordinates already.
inline std::optional<ConePointHit> intersect_cone_point(const PointWeightFrame& frame,
                                                        const VertexInRayFrame& p,
                                                        const NormalInRayFrame& n, float coverage,
                                                        float t_min) {
    if (!(p.t >= t_min)) {
        return std::nullopt;
    }
    const float weight = point_weight(frame, p.offset, n.along, coverage);
    if (!(weight > 0.0f)) {
        return std::nullopt;
    }
    const float t = point_depth(p, n);
    if (!(t >= t_min)) {
        return std::nullopt;
    }
    return ConePointHit{t, weight};
}

/// The same for a surfel at `position` with unit `normal`, both in the ray's space.
inline std::optional<ConePointHit> intersect_cone_point(const ConeRay& ray,
                                                        const PointWeightFrame& frame,
                                                        const Vec3f& position, const Vec3f& normal,
                                                        float coverage, float t_min) {
    return intersect_cone_point(
        frame, ray.frame_of(position),
        {normal.dot(ray.direction), Vec2f(normal.dot(ray.cone.u), normal.dot(ray.cone.v))},
        coverage, t_min);
}

}  // namespace mrt
