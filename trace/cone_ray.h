#pragma once
// A ray cone in one space (the world, or an instance's object space) and the cone–point
// intersection of Wand & Straßer §4.3: a surfel expressed in ray coordinates — its depth t along
// the unit direction and its offset along the footprint's u and v axes — and weighed with the
// footprint at the node's depth (common/point_weight.h). The ray-coordinate types here are what
// the cone kernels (trace/cone_bounds.h, trace/cone_triangle.h) take.

#include "common/footprint.h"
#include "common/math.h"
#include "common/point_weight.h"

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

struct ConePointHit {
    float t = 0.0f;       ///< Depth of the point along the ray.
    float weight = 0.0f;  ///< point_weight: the A-buffer's weight.
};

/// The surfel at `position` (on the surface: common/hierarchy_file.h point_position) with unit
/// `normal` and decoded `coverage`, weighed with `frame` (point_weight_frame of the footprint
/// at the node's depth and its spacing); nothing when it lies before t_min or outside the clip.
inline std::optional<ConePointHit> intersect_cone_point(const ConeRay& ray,
                                                        const PointWeightFrame& frame,
                                                        const Vec3f& position, const Vec3f& normal,
                                                        float coverage, float t_min) {
    const VertexInRayFrame p = ray.frame_of(position);
    if (!(p.t >= t_min)) {
        return std::nullopt;
    }
    const float weight = point_weight(frame, p.offset, normal.dot(ray.direction), coverage);
    if (!(weight > 0.0f)) {
        return std::nullopt;
    }
    return ConePointHit{p.t, weight};
}

}  // namespace mrt
