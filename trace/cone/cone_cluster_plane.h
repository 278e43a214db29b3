#pragma once
// How flat a cluster of points is, and the test that a cone leaving a surface uses it for: the
// cone skips the points whose tangent planes pass within a tolerance of its apex (the surface it
// starts on), and a cluster whose every point is such is skipped without its points. On the
// complex scene half the points that passed the cone's centre tests were of the surface the cone
// was leaving (secondary cones off glass and mirrors, shadow cones off the ground).

#include "common/math/math.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

namespace mrt {

/// A point cluster's members' positions p and unit normals n_p against the plane through the
/// cluster's centre c with their mean normal n_c.
struct ConeClusterPlane {
    std::array<float, 3> normal{};  ///< Unit mean normal n_c.
    float thickness = 0.0f;         ///< max |n_c·(p − c)|.
    /// max |n_p − n_c|; infinite where the normals cancel (no plane).
    float spread = 0.0f;
};
static_assert(sizeof(ConeClusterPlane) == 20);

/// The plane of the members j in [first, first + count) around `centre`, whose position and
/// unit normal surface(j) gives as a pair.
template <class Surface>
ConeClusterPlane cluster_plane(const Vec3f& centre, std::uint32_t first, std::uint32_t count,
                               Surface&& surface) {
    Vec3f sum = Vec3f::Zero();
    for (std::uint32_t j = first; j < first + count; ++j) {
        sum += surface(j).second;
    }
    ConeClusterPlane plane;
    const float length = sum.norm();
    if (!(length > 0.0f)) {
        plane.spread = std::numeric_limits<float>::infinity();
        return plane;
    }
    const Vec3f normal = sum / length;
    for (std::uint32_t j = first; j < first + count; ++j) {
        const auto [position, n] = surface(j);
        plane.thickness = std::max(plane.thickness, std::abs(normal.dot(position - centre)));
        plane.spread = std::max(plane.spread, (n - normal).norm());
    }
    plane.normal = {normal.x(), normal.y(), normal.z()};
    return plane;
}

/// Whether every member of a cluster (centre c, bounding radius r) has its tangent plane within
/// `tolerance` of `apex`: |n_p·(p − a)| ≤ |n_c·(c − a)| + thickness + spread·(|c − a| + r).
/// Or, the traversal's second clause for the surface a cone leaves (a curved surface's points
/// around the apex, below the start's resolution): within `start` of the apex while every member
/// lies within `near` of it, |c − a| + r ≤ near. Sufficient, not necessary: false says nothing
/// about the members.
/// The bound on every member's |n_p·(p − a)| for a cluster whose centre lies `apart` from the
/// apex, at `distance` = |apart|.
inline float cluster_plane_distance(const ConeClusterPlane& plane, const Vec3f& apart,
                                    float distance, float radius) {
    const Vec3f normal(plane.normal[0], plane.normal[1], plane.normal[2]);
    return std::abs(normal.dot(apart)) + plane.thickness + plane.spread * (distance + radius);
}

inline bool cluster_leaves(const ConeClusterPlane& plane, const Vec3f& centre, float radius,
                           const Vec3f& apex, float tolerance, float start = 0.0f,
                           float near = 0.0f) {
    const Vec3f apart = centre - apex;
    const float distance = apart.norm();
    const float bound = cluster_plane_distance(plane, apart, distance, radius);
    return bound <= tolerance || (bound <= start && distance + radius <= near);
}

/// A triangle cluster's plane (cluster_plane of each triangle's first vertex and unit winding
/// normal; infinite spread where a member has no normal) and its members' smallest size (the
/// longer of the two edges from the first vertex).
struct ConeTriangleClusterPlane {
    ConeClusterPlane plane;
    float min_size = 0.0f;
};

/// The leaving plane of the triangles j in [first, first + count) around `centre`, whose three
/// vertices vertices(j) gives, formed as the traversal's test of one triangle forms them.
template <class Vertices>
ConeTriangleClusterPlane triangle_cluster_plane(const Vec3f& centre, std::uint32_t first,
                                                std::uint32_t count, Vertices&& vertices) {
    ConeTriangleClusterPlane cluster;
    cluster.min_size = std::numeric_limits<float>::infinity();
    bool has_normals = true;
    cluster.plane = cluster_plane(centre, first, count, [&](std::uint32_t j) {
        const std::array<Vec3f, 3> p = vertices(j);
        const Vec3f edge1 = p[1] - p[0];
        const Vec3f edge2 = p[2] - p[0];
        const Vec3f winding = edge1.cross(edge2);
        const float length = winding.norm();
        cluster.min_size = std::min(cluster.min_size,
                                    std::sqrt(std::max(edge1.squaredNorm(), edge2.squaredNorm())));
        has_normals = has_normals && length > 0.0f;
        return std::pair{p[0], length > 0.0f ? Vec3f(winding / length) : Vec3f::Zero()};
    });
    if (!has_normals || !std::isfinite(cluster.min_size)) {
        // A member without a normal is never skipped by its own test.
        cluster.plane.spread = std::numeric_limits<float>::infinity();
    }
    return cluster;
}

/// Whether every triangle of a cluster would be taken for the surface a cone leaves by the
/// traversal's own test of one triangle, |n_t·(a − p_0)| ≤ coplanar·max(size, |p_0 − a|): the
/// cluster's bound on each member's plane distance within half the smallest tolerance any member
/// can have (the half is room for the members' own rounding). Sufficient, not necessary.
inline bool triangle_cluster_leaves(const ConeTriangleClusterPlane& cluster, const Vec3f& centre,
                                    float radius, const Vec3f& apex, float coplanar) {
    const Vec3f apart = centre - apex;
    const float distance = apart.norm();
    return cluster_plane_distance(cluster.plane, apart, distance, radius) <=
           0.5f * coplanar * std::max(cluster.min_size, distance - radius);
}

}  // namespace mrt
