#include "trace/cone_triangle.h"

#include "common/point_weight.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <ostream>

namespace mrt {

namespace {

using Vec2d = Eigen::Vector2d;

double cross(const Vec2d& a, const Vec2d& b) {
    return a.x() * b.y() - a.y() * b.x();
}

/// 8-point Gauss–Legendre nodes and weights on [−1, 1] (the positive half; symmetric).
constexpr std::array<double, 4> kNodes{0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                       0.9602898564975363};
constexpr std::array<double, 4> kWeights{0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                         0.1012285362903763};

/// ∫ exp(−h²/cos²α) dα over [a, b] by 8-point Gauss–Legendre.
double panel(double h2, double a, double b) {
    const double mid = 0.5 * (a + b), half = 0.5 * (b - a);
    double sum = 0.0;
    // The integrand in float: a weight needs no more than float's 1e-7, and float's cos and
    // exp cost a fraction of double's in the cone tracer's hottest kernel.
    const auto h2f = static_cast<float>(h2);
    for (std::size_t i = 0; i < kNodes.size(); ++i) {
        for (const double sign : {-1.0, 1.0}) {
            const float c = std::cos(static_cast<float>(mid + sign * half * kNodes[i]));
            sum += kWeights[i] * static_cast<double>(std::exp(-h2f / (c * c)));
        }
    }
    return sum * half;
}

/// ∫ exp(−h²/cos²α) dα over [a, b] ⊂ (−π/2, π/2), on panels that split the interval at α = 0
/// (where the integrand peaks, about 1/h wide) and ever closer towards ±π/2 (where it drops
/// to 0 as steeply as h is small): below 1e-6 of the edge's share for any h.
double edge_integral(double h2, double a, double b) {
    constexpr std::array<double, 11> kBreaks{
        -1.5217089415825558, -1.4726215563702154, -1.3744467859455345,
        -1.1780972450961724, -0.7853981633974483, 0.0,
        0.7853981633974483,  1.1780972450961724,  1.3744467859455345,
        1.4726215563702154,  1.5217089415825558};  // ±π/2·(1 − 2^−k)
    double sum = 0.0;
    double from = a;
    for (const double at : kBreaks) {
        if (at > from && at < b) {
            sum += panel(h2, from, at);
            from = at;
        }
    }
    return sum + panel(h2, from, b);
}

/// Closest point of triangle (a, b, c) to the origin, as barycentric (b1, b2) of b and c
/// (Ericson, Real-Time Collision Detection §5.1.5, with p = 0).
Vec2d closest_to_origin(const Vec2d& a, const Vec2d& b, const Vec2d& c) {
    const Vec2d ab = b - a, ac = c - a, ap = -a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0.0 && d2 <= 0.0) {
        return {0.0, 0.0};
    }
    const Vec2d bp = -b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0.0 && d4 <= d3) {
        return {1.0, 0.0};
    }
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        return {d1 / (d1 - d3), 0.0};
    }
    const Vec2d cp = -c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0.0 && d5 <= d6) {
        return {0.0, 1.0};
    }
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        return {0.0, d2 / (d2 - d6)};
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
        const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return {1.0 - w, w};
    }
    const double denominator = va + vb + vc;
    if (!(std::abs(denominator) > 0.0)) {
        return {0.0, 0.0};  // degenerate: vertex a
    }
    return {vb / denominator, vc / denominator};
}

}  // namespace

float triangle_clip_radius(TriangleWeight weight) {
    // exp(−(d − ½)²) = 2 % at d = ½ + √ln 50; the Gaussian exp(−d²) at d = √ln 50.
    return weight == TriangleWeight::Paper ? 0.5f + std::sqrt(kPointWeightClipExponent)
                                           : std::sqrt(kPointWeightClipExponent);
}

GaussianFrame GaussianFrame::of(const Mat2f& footprint) {
    GaussianFrame frame;
    if (!footprint.allFinite()) {
        return frame;
    }
    return of_ellipse(FootprintCone::ellipse_of(footprint));
}

GaussianFrame GaussianFrame::of_ellipse(const SymmetricEigen2& e) {
    GaussianFrame frame;
    if (!(e.major > 0.0f) || !std::isfinite(e.major)) {
        return frame;
    }
    // A vanishing minor axis (an unclamped, degenerate footprint) is floored far below any
    // clamp, so the map stays finite.
    const float minor = std::max(e.minor, 1e-12f * e.major);
    frame.axis = e.major_axis;
    frame.inverse_semi_axes = {1.0f / std::sqrt(e.major), 1.0f / std::sqrt(minor)};
    return frame;
}

Vec2f GaussianFrame::map(const Vec2f& offset) const {
    // (F·Fᵀ)^(−1/2)·x = U·Λ^(−1/2)·Uᵀ·x: scaled along the ellipse's axes and rotated back, so
    // the map is the same for every decomposition of the same F and changes continuously with
    // F. Frames at different depths (per vertex) then agree on the plane's orientation even
    // where an almost round footprint's axes turn by 90° from one depth to the next.
    const Vec2f minor_axis(-axis.y(), axis.x());
    return offset.dot(axis) * inverse_semi_axes.x() * axis +
           offset.dot(minor_axis) * inverse_semi_axes.y() * minor_axis;
}

float gaussian_triangle_mass(const Vec2f& a, const Vec2f& b, const Vec2f& c) {
    std::array<Vec2d, 3> p{a.cast<double>(), b.cast<double>(), c.cast<double>()};
    if (!p[0].allFinite() || !p[1].allFinite() || !p[2].allFinite()) {
        return 0.0f;
    }
    // The mass over a triangle is the signed sum over its edges of the masses of the triangles
    // (origin, p, q); each of those is (1/2π)∫(1 − exp(−r(θ)²))dθ over the angle it subtends,
    // r(θ) = h/cos(θ − φ) the distance to the edge's line. The 1s add up to 1 with the origin
    // inside and 0 outside; the rest is the edge integrals.
    double mass = 0.0;
    for (int e = 0; e < 3; ++e) {
        const Vec2d& from = p[static_cast<std::size_t>(e)];
        const Vec2d& to = p[static_cast<std::size_t>((e + 1) % 3)];
        const Vec2d edge = to - from;
        const double length = edge.norm();
        const double orientation = cross(from, to);
        if (!(length > 0.0) || orientation == 0.0) {
            continue;  // the origin on the edge's line: a sliver of no area
        }
        const Vec2d along = edge / length;
        const double h = std::abs(orientation) / length;
        const double alpha_from = std::atan2(from.dot(along), h);
        const double alpha_to = std::atan2(to.dot(along), h);
        const double sweep = alpha_to - alpha_from;
        // Beyond h = 4 the Gaussian below the edge, ∫exp(−h²/cos²α)dα ≤ √π·exp(−h²)/h, is
        // under 1e-7 of it: the edge only closes the sweep (a large triangle around a cone).
        // Endpoints beyond 4 units likewise: the Gaussian there is below 1e-7, so the edge
        // either takes the whole line's integral, π·erfc(h) (Craig's formula), when its foot
        // lies between them, or nothing. Triangles large beside the footprint end here.
        double below = 0.0;
        if (h * h <= 16.0) {
            if (from.squaredNorm() > 16.0 && to.squaredNorm() > 16.0) {
                below = alpha_from < 0.0 && alpha_to > 0.0 ? kPi * std::erfc(h) : 0.0;
            } else {
                below = edge_integral(h * h, alpha_from, alpha_to);
            }
        }
        const double share = sweep - below;
        mass += (orientation > 0.0 ? share : -share) / (2.0 * kPi);
    }
    return static_cast<float>(std::clamp(std::abs(mass), 0.0, 1.0));
}

std::optional<ConeTriangleHit> intersect_cone_triangle(
    const std::array<VertexInRayFrame, 3>& vertices, const std::array<GaussianFrame, 3>& frames,
    TriangleWeight weight, float t_min) {
    if (std::max({vertices[0].t, vertices[1].t, vertices[2].t}) < t_min) {
        return std::nullopt;
    }
    std::array<Vec2f, 3> y;
    for (std::size_t i = 0; i < 3; ++i) {
        y[i] = frames[i].map(vertices[i].offset);
        if (!y[i].allFinite()) {
            return std::nullopt;
        }
    }
    // A triangle whose bounding box misses the square around the clip circle weighs nothing
    // (below), and most triangles a node keeps are far from the cone: this saves the exact
    // weight for them.
    const float reach = triangle_clip_radius(weight);
    if (misses_square(y, reach)) {
        return std::nullopt;
    }
    const Vec2d closest =
        closest_to_origin(y[0].cast<double>(), y[1].cast<double>(), y[2].cast<double>());
    ConeTriangleHit hit;
    hit.b1 = static_cast<float>(closest.x());
    hit.b2 = static_cast<float>(closest.y());
    const float distance = ((1.0f - hit.b1 - hit.b2) * y[0] + hit.b1 * y[1] + hit.b2 * y[2]).norm();
    if (!(distance <= reach)) {
        return std::nullopt;
    }
    // Where the axis itself passes through the triangle, the hit is that point: its
    // barycentric coordinates solve b0·o0 + b1·o1 + b2·o2 = 0 in the (linear) ray-frame
    // offsets. Per-vertex frames map the triangle non-linearly, so the closest point found in
    // their coordinates is only near it, and a depth off the surface's plane would start
    // shadow and secondary cones below the surface.
    double plane_t = std::numeric_limits<double>::quiet_NaN();
    bool edge_on = true;
    {
        const Vec2d o0 = vertices[0].offset.cast<double>();
        const Vec2d e1 = vertices[1].offset.cast<double>() - o0;
        const Vec2d e2 = vertices[2].offset.cast<double>() - o0;
        const double det = cross(e1, e2);
        if (std::abs(det) > 0.0) {
            const double b1 = cross(-o0, e2) / det;
            const double b2 = cross(e1, -o0) / det;
            if (b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0) {
                hit.b1 = static_cast<float>(b1);
                hit.b2 = static_cast<float>(b2);
            }
            // The depth is where the axis meets the triangle's plane even when it passes
            // beside the triangle, so that the triangles of one surface (and its points)
            // agree on the depth at the axis — unless the plane is nearly edge-on to the axis
            // (|n·d| below 0.05), where that depth runs away: kept within the triangle's own.
            plane_t = (1.0 - b1 - b2) * vertices[0].t + b1 * vertices[1].t + b2 * vertices[2].t;
            const double dt1 = static_cast<double>(vertices[1].t) - vertices[0].t;
            const double dt2 = static_cast<double>(vertices[2].t) - vertices[0].t;
            // The plane's normal in ray coordinates (u, v, t): (e1, dt1) × (e2, dt2).
            const Eigen::Vector3d normal(e1.y() * dt2 - dt1 * e2.y(), dt1 * e2.x() - e1.x() * dt2,
                                         det);
            edge_on = std::abs(det) < 0.05 * normal.norm();
        }
    }
    const float b0 = 1.0f - hit.b1 - hit.b2;
    hit.t = b0 * vertices[0].t + hit.b1 * vertices[1].t + hit.b2 * vertices[2].t;
    if (std::isfinite(plane_t) && !edge_on) {
        hit.t = static_cast<float>(plane_t);
    } else if (std::isfinite(plane_t)) {
        hit.t = static_cast<float>(std::clamp(
            plane_t, static_cast<double>(std::min({vertices[0].t, vertices[1].t, vertices[2].t})),
            static_cast<double>(std::max({vertices[0].t, vertices[1].t, vertices[2].t}))));
    }
    if (weight == TriangleWeight::Paper) {
        const float d = distance;
        hit.weight = d <= 0.5f ? 1.0f : std::exp(-(d - 0.5f) * (d - 0.5f));
    } else {
        // The clip is on where the Gaussian is below 2 % (as for points), not on the mass: a
        // footprint over many small triangles would lose every one of them below 2 % of mass
        // (measured: 7–10 % of a surface's weight). Outside the clip circle lies exactly 2 %
        // of the mass, put back as for points, so the triangles of a surface add up to 1.
        hit.weight = gaussian_triangle_mass(y[0], y[1], y[2]) / (1.0f - kPointWeightClip);
    }
    if (!(hit.weight > 0.0f)) {
        return std::nullopt;
    }
    return hit;
}

std::ostream& operator<<(std::ostream& os, const ConeTriangleHit& hit) {
    return os << "ConeTriangleHit{t " << hit.t << ", weight " << hit.weight << ", b " << hit.b1
              << ", " << hit.b2 << "}";
}

}  // namespace mrt
