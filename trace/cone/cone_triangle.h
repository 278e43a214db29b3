#pragma once
// Ray cone – triangle intersection (Wand & Straßer §4.5): the triangle's vertices in ray
// coordinates, each mapped into the coordinates of the cone's unit Gaussian at its own depth
// ("through the eigenspace, for stability", §5.2), then the weight of the 2D triangle around
// the origin. Triangle hits enter the A-buffer like points, so blurred edges and anti-aliased
// silhouettes come from the weight.
//
// Two weights:
// - `Paper`: §4.5's exp(−(d − ½)²) from the distance d of the triangle's closest point to the
//   origin (1 for d ≤ ½, clipped below 2 %). It keeps full weight until half a Gaussian unit
//   outside the edge, so silhouettes come out fat — the paper's own open problem (§6).
// - `Coverage` (default): the Gaussian's mass over the triangle, exactly: with the origin
//   inside, 1 minus what the three edges cut off; outside, what the edges facing it enclose.
//   Each edge's share is (1/2π)∫exp(−h²/cos²α)dα over the angle it subtends (h its distance
//   from the origin), a smooth integrand over less than π, integrated with 16-point
//   Gauss–Legendre. ½ on a straight edge, ¼ at a right-angled corner, and a triangle much
//   smaller than the footprint weighs its area times the Gaussian's height, as points do.
//
// Mapping. For a footprint F the Gaussian is exp(−|F⁻¹x|²). With F·Fᵀ = U·Λ·Uᵀ, the map
// y = U·Λ^(−1/2)·Uᵀ·x = (F·Fᵀ)^(−1/2)·x differs from F⁻¹x by a rotation, so it gives the same
// Gaussian, and it is computed from the stable closed-form eigen-decomposition
// (common/footprint/footprint.h) instead of an inverse that loses everything when F's columns are
// nearly collinear; the anisotropy clamp bounds Λ's condition. The rotation back by U makes the map
// unique and continuous in F, which mapping each vertex with the footprint at its own depth
// (the exact version of §5.2) needs: Λ^(−1/2)·Uᵀ alone would turn with the axes of an almost
// round footprint. The tracer (trace/cone/cone_traversal.h) passes three frames at the vertices'
// depths, or three copies of one (the paper's faster version: one decomposition per box).

#include "common/footprint/footprint.h"
#include "common/footprint/point_weight.h"
#include "common/math/math.h"
#include "common/system/enum_names.h"
#include "trace/cone/cone_bound_block.h"
#include "trace/cone/cone_ray.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iosfwd>
#include <optional>

namespace mrt {

enum class TriangleWeight { Paper, Coverage };

/// mrt-trace --triangle-weight's names.
inline constexpr EnumNames<TriangleWeight, 2> kTriangleWeightNames{{{
    {TriangleWeight::Coverage, "coverage"},
    {TriangleWeight::Paper, "paper"},
}}};

/// How the cone is seen at a depth: the map into its unit Gaussian's coordinates.
struct GaussianFrame {
    Vec2f axis = Vec2f::UnitX();              ///< Major axis of the footprint ellipse (ray u/v).
    Vec2f inverse_semi_axes = Vec2f::Zero();  ///< 1/√λ along the major and the minor axis.

    /// The frame of footprint F (already anisotropy-clamped); a zero or non-finite F gives
    /// zero inverse semi-axes (nothing maps anywhere but the origin).
    static GaussianFrame of(const Mat2f& footprint);
    /// The same from the footprint's ellipse (FootprintCone::ellipse_of), already known.
    static GaussianFrame of_ellipse(const SymmetricEigen2& ellipse);
    /// of(FootprintCone::clamp_anisotropy(footprint, max_anisotropy)), the same bit for bit,
    /// from one decomposition where the clamp leaves the footprint as it is (the clamp's own
    /// decomposition is then the frame's) instead of two: the per-vertex frames of the triangle
    /// loop.
    static GaussianFrame of_clamped(const Mat2f& footprint, float max_anisotropy);
    /// An offset in the ray's u/v plane in the Gaussian's units. Inline: the triangle loop maps
    /// each vertex it tests (millions per image), and a call costs as much as the map.
    Vec2f map(const Vec2f& offset) const {
        // (F·Fᵀ)^(−1/2)·x = U·Λ^(−1/2)·Uᵀ·x: scaled along the ellipse's axes and rotated back,
        // so the map is the same for every decomposition of the same F and changes continuously
        // with F. Frames at different depths (per vertex) then agree on the plane's orientation
        // even where an almost round footprint's axes turn by 90° from one depth to the next.
        const Vec2f minor_axis(-axis.y(), axis.x());
        return offset.dot(axis) * inverse_semi_axes.x() * axis +
               offset.dot(minor_axis) * inverse_semi_axes.y() * minor_axis;
    }
    /// The square |y_x|, |y_y| ≤ reach of this frame's units as a block of bounding spheres
    /// tests it (spheres_near_axis): the map's matrix and its norm.
    GaussianSquare square(float reach) const {
        const float s0 = inverse_semi_axes.x();
        const float s1 = inverse_semi_axes.y();
        const float xx = axis.x() * axis.x();
        const float xy = axis.x() * axis.y();
        const float yy = axis.y() * axis.y();
        return {s0 * xx + s1 * yy, (s0 - s1) * xy, s0 * yy + s1 * xx, reach, std::max(s0, s1)};
    }
};

struct ConeTriangleHit {
    /// Depth of the hit: where the axis meets the triangle's plane, within the triangle's
    /// depths (the closest point's depth where the plane is edge-on).
    float t = 0.0f;
    float weight = 0.0f;  ///< In (0, 1/0.98] for `Coverage`; the A-buffer's weight.
    float b1 = 0.0f;      ///< Barycentric coordinates of the closest point (vertex 1, 2).
    float b2 = 0.0f;
};

/// A triangle's vertices in a cone's ray coordinates, one vertex per lane (the fourth lane is
/// zero), and their offsets in a Gaussian frame's units: the triangle loop's cheap rejections
/// for all three vertices at once in SIMD registers, every lane bit for bit what
/// ConeRay::frame_of and GaussianFrame::map give (the same operations in the same order; Eigen
/// sums a 3-vector's dot product as x + (y + z)). Every triangle a cone's clusters let through
/// is projected (millions per image), and Eigen's 3-vectors are not vectorised.
struct TriangleInRayFrame {
    Eigen::Array4f t;  ///< Depths along the ray's direction.
    Eigen::Array4f u;  ///< Offsets along the cone's u.
    Eigen::Array4f v;  ///< Offsets along the cone's v.

    TriangleInRayFrame(const ConeRay& ray, const std::array<Vec3f, 3>& p) {
        const Vec3f& o = ray.origin;
        const Eigen::Array4f dx(p[0].x() - o.x(), p[1].x() - o.x(), p[2].x() - o.x(), 0.0f);
        const Eigen::Array4f dy(p[0].y() - o.y(), p[1].y() - o.y(), p[2].y() - o.y(), 0.0f);
        const Eigen::Array4f dz(p[0].z() - o.z(), p[1].z() - o.z(), p[2].z() - o.z(), 0.0f);
        const auto dot = [&](const Vec3f& axis) -> Eigen::Array4f {
            return dx * axis.x() + (dy * axis.y() + dz * axis.z());
        };
        t = dot(ray.direction);
        u = dot(ray.cone.u);
        v = dot(ray.cone.v);
    }

    VertexInRayFrame vertex(Eigen::Index i) const { return {t[i], Vec2f(u[i], v[i])}; }
    std::array<VertexInRayFrame, 3> vertices() const { return {vertex(0), vertex(1), vertex(2)}; }

    /// The offsets in `frame`'s units (GaussianFrame::map of each): x and y, one vertex a lane.
    struct Mapped {
        Eigen::Array4f x;
        Eigen::Array4f y;
        std::array<Vec2f, 3> points() const {
            return {Vec2f(x[0], y[0]), Vec2f(x[1], y[1]), Vec2f(x[2], y[2])};
        }
    };
    Mapped map(const GaussianFrame& frame) const {
        // GaussianFrame::map's operations in its order; the minor axis is (−a_y, a_x).
        const float ax = frame.axis.x(), ay = frame.axis.y();
        const Eigen::Array4f along = (u * ax + v * ay) * frame.inverse_semi_axes.x();
        const Eigen::Array4f across = (u * -ay + v * ax) * frame.inverse_semi_axes.y();
        return {along * ax + across * -ay, along * ay + across * ax};
    }
};

/// How far from the axis, in the Gaussian's units, a triangle's closest point may lie and still
/// be weighed: where the Gaussian (Coverage) or the paper's weight falls below the 2 % clip.
/// Inline, so that it folds to a constant in the triangle loop.
inline float triangle_clip_radius(TriangleWeight weight) {
    // exp(−(d − ½)²) = 2 % at d = ½ + √ln 50; the Gaussian exp(−d²) at d = √ln 50.
    return weight == TriangleWeight::Paper ? 0.5f + std::sqrt(kPointWeightClipExponent)
                                           : std::sqrt(kPointWeightClipExponent);
}

/// Whether the triangle with vertices `y` (in the Gaussian's units) lies wholly beyond the
/// square |y_x|, |y_y| ≤ reach around the origin on one side: then it cannot come within
/// reach. The cheap rejection of the many triangles far from a cone.
inline bool misses_square(const std::array<Vec2f, 3>& y, float reach) {
    for (int axis = 0; axis < 2; ++axis) {
        const float lo = std::min({y[0][axis], y[1][axis], y[2][axis]});
        const float hi = std::max({y[0][axis], y[1][axis], y[2][axis]});
        if (lo > reach || hi < -reach) {
            return true;
        }
    }
    return false;
}

/// The hit of the cone with the triangle, or nothing when its closest point lies beyond the
/// 2 % clip (triangle_clip_radius) or no vertex lies in front of t_min. The Coverage weight is
/// the Gaussian's mass over the triangle over 0.98, the mass inside the clip circle: the
/// triangles of a surface around the cone add up to at least 1. `frames` are the Gaussian frames at
/// the vertices (PerVertex) or three copies of one (PerNode).
std::optional<ConeTriangleHit> intersect_cone_triangle(
    const std::array<VertexInRayFrame, 3>& vertices, const std::array<GaussianFrame, 3>& frames,
    TriangleWeight weight, float t_min);
/// The same with the vertices already in the Gaussian's units, `y[i]` = frames[i].map(vertices[i]
/// .offset): the tracer's triangle loop maps them for its cull, and where it weighs with the
/// cull's frames it does not map them again.
std::optional<ConeTriangleHit> intersect_cone_triangle_mapped(
    const std::array<VertexInRayFrame, 3>& vertices, const std::array<Vec2f, 3>& y,
    TriangleWeight weight, float t_min);

/// The Gaussian mass exp(−|y|²)/π over the 2D triangle (a, b, c), in [0, 1]: the `Coverage`
/// weight, exposed for tests.
float gaussian_triangle_mass(const Vec2f& a, const Vec2f& b, const Vec2f& c);

std::ostream& operator<<(std::ostream& os, const ConeTriangleHit& hit);

}  // namespace mrt
