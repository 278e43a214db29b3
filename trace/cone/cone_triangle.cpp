#include "trace/cone/cone_triangle.h"

#include "common/footprint/point_weight.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <ostream>
#include <vector>

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

/// Below this x, (1 − e^(−x))/x is taken as its series 1 − x/2, which at x = 0 is not 0/0: the
/// series' next term, x²/6, is below double's rounding of 1 there, so the switch is seamless.
constexpr double kSeriesBelow = 1e-8;

/// A vanishing minor axis (an unclamped, degenerate footprint) is floored to this fraction of the
/// major one, far below any anisotropy clamp (8² = 64 by default), so the Gaussian's map stays
/// finite: its minor semi-axis is then a millionth of the major.
constexpr float kMinimumMinorRatio = 1e-12f;

/// A triangle's plane is edge-on to the cone's axis where the cosine between its normal and the
/// axis, in ray coordinates, is below this (87° from the normal): there the depth where the axis
/// meets the plane runs away, and the hit keeps a depth within the triangle's own.
constexpr double kEdgeOnCosine = 0.05;

/// (1 − e^(−x))/x, entire: 1 at x = 0.
double one_minus_exp_over(double x) {
    return x < kSeriesBelow ? 1.0 - 0.5 * x : -std::expm1(-x) / x;
}

/// The Gaussian mass exp(−|y|²)/π of the right triangle with corners at the origin, at the
/// foot (h, 0) of the perpendicular to an edge's line, and at (h, s) on that line:
/// M(h, s) = (h/2π)·∫₀ˢ (1 − e^(−(h²+σ²)))/(h²+σ²) dσ, odd in s. A triangle's mass is the
/// signed sum over its edges of M at their endpoints, so the triangles around a shared edge add
/// up exactly, whatever the accuracy of M. M is tabulated once, bilinear in h and in
/// w = |s|/(c + |s|) with c = √(1 + h²) (which maps s ∈ [0, ∞) onto [0, 1] and follows the
/// function's scale in s both where h is small and where M turns into the sector's
/// atan(s/h)/2π): within 6e-6 of the integral everywhere (measured), where 8-point
/// Gauss–Legendre panels over the edge's angle cost some 50 exponentials and cosines per
/// edge, the cone tracer's hottest kernel.
class WedgeMass {
  public:
    /// Beyond this distance of the line, e^(−h²) < 2e-9: M is the sector's share.
    static constexpr double kMaxHeight = 4.5;

    WedgeMass() : m_table(static_cast<std::size_t>((kRows + 1) * (kColumns + 1))) {
        for (int i = 0; i <= kRows; ++i) {
            const double h = kMaxHeight * i / kRows;
            const double c = std::sqrt(1.0 + h * h);
            float* row = &m_table[static_cast<std::size_t>(i * (kColumns + 1))];
            // Cumulative along s, each step by 8-point Gauss–Legendre (the integrand is smooth
            // on the scale of c, and the steps grow with s as the integrand flattens).
            double sum = 0.0;
            double previous = 0.0;
            row[0] = 0.0f;
            for (int j = 1; j < kColumns; ++j) {
                const double w = static_cast<double>(j) / kColumns;
                const double s = c * w / (1.0 - w);
                const double mid = 0.5 * (previous + s), half = 0.5 * (s - previous);
                for (std::size_t k = 0; k < kNodes.size(); ++k) {
                    for (const double sign : {-1.0, 1.0}) {
                        const double sigma = mid + sign * half * kNodes[k];
                        sum += kWeights[k] * half * one_minus_exp_over(h * h + sigma * sigma);
                    }
                }
                row[j] = static_cast<float>(h / (2.0 * std::numbers::pi) * sum);
                previous = s;
            }
            // s → ∞: the strip 0 ≤ x ≤ h, y ≥ 0.
            row[kColumns] = static_cast<float>(0.25 * std::erf(h));
        }
    }

    /// M(h, s) for h ≥ 0.
    float operator()(double h, double s) const {
        if (h >= kMaxHeight) {
            return static_cast<float>(std::atan2(s, h) / (2.0 * std::numbers::pi));
        }
        const double a = std::abs(s);
        const double w = a / (std::sqrt(1.0 + h * h) + a);
        const double x = h * (kRows / kMaxHeight);
        const double y = w * kColumns;
        const int i = std::min(static_cast<int>(x), kRows - 1);
        const int j = std::min(static_cast<int>(y), kColumns - 1);
        const auto fx = static_cast<float>(x - i);
        const auto fy = static_cast<float>(y - j);
        const float* low = &m_table[static_cast<std::size_t>(i * (kColumns + 1) + j)];
        const float* high = low + (kColumns + 1);
        const float m = (1.0f - fx) * ((1.0f - fy) * low[0] + fy * low[1]) +
                        fx * ((1.0f - fy) * high[0] + fy * high[1]);
        return s < 0.0 ? -m : m;
    }

  private:
    static constexpr int kRows = 512;
    static constexpr int kColumns = 128;
    std::vector<float> m_table;
};

const WedgeMass& wedge_mass() {
    static const WedgeMass table;
    return table;
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

GaussianFrame GaussianFrame::of(const Mat2f& footprint) {
    GaussianFrame frame;
    if (!footprint.allFinite()) {
        return frame;
    }
    return of_ellipse(FootprintCone::ellipse_of(footprint));
}

GaussianFrame GaussianFrame::of_clamped(const Mat2f& footprint, float max_anisotropy) {
    SymmetricEigen2 ellipse = FootprintCone::ellipse_of(footprint);
    const float minor = ellipse.minor;
    const Mat2f clamped = FootprintCone::clamp_decomposed(footprint, max_anisotropy, ellipse);
    // clamp_decomposed raises the minor axis where it clamps (and where it is NaN, which no
    // comparison equals) and returns the footprint itself, and its ellipse, where it does not.
    // There of() would decompose the same matrix again: a non-finite F has a non-finite F·Fᵀ,
    // whose ellipse is the zero one of_ellipse maps to the same empty frame as of()'s own test.
    if (ellipse.minor == minor) {
        return of_ellipse(ellipse);
    }
    return of(clamped);
}

GaussianFrame GaussianFrame::of_ellipse(const SymmetricEigen2& e) {
    GaussianFrame frame;
    if (!(e.major > 0.0f) || !std::isfinite(e.major)) {
        return frame;
    }
    // A vanishing minor axis (an unclamped, degenerate footprint) is floored far below any
    // clamp, so the map stays finite.
    const float minor = std::max(e.minor, kMinimumMinorRatio * e.major);
    frame.axis = e.major_axis;
    frame.inverse_semi_axes = {1.0f / std::sqrt(e.major), 1.0f / std::sqrt(minor)};
    return frame;
}

float gaussian_triangle_mass(const Vec2f& a, const Vec2f& b, const Vec2f& c) {
    std::array<Vec2d, 3> p{a.cast<double>(), b.cast<double>(), c.cast<double>()};
    if (!p[0].allFinite() || !p[1].allFinite() || !p[2].allFinite()) {
        return 0.0f;
    }
    // The mass over a triangle is the signed sum over its edges of the masses of the triangles
    // (origin, p, q), each the difference of WedgeMass at p and q along the edge's line.
    const WedgeMass& wedge = wedge_mass();
    double mass = 0.0;
    bool near = false;
    for (int e = 0; e < 3; ++e) {
        const Vec2d& from = p[static_cast<std::size_t>(e)];
        const Vec2d& to = p[static_cast<std::size_t>((e + 1) % 3)];
        const Vec2d edge = to - from;
        const double length = edge.norm();
        const double orientation = cross(from, to);
        if (!(length > 0.0) || orientation == 0.0) {
            // The origin on the edge's line: a sliver of no area, but the Gaussian is there.
            near = near || length > 0.0;
            continue;
        }
        const Vec2d along = edge / length;
        const double h = std::abs(orientation) / length;
        near = near || h < WedgeMass::kMaxHeight;
        const double share = static_cast<double>(wedge(h, to.dot(along))) -
                             static_cast<double>(wedge(h, from.dot(along)));
        mass += orientation > 0.0 ? share : -share;
    }
    if (!near) {
        // Every edge beyond the Gaussian's reach: the triangle holds all of it or none (the
        // sectors' shares add up to the winding number, up to the table's rounding).
        return std::abs(mass) > 0.5 ? 1.0f : 0.0f;
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
    }
    return intersect_cone_triangle_mapped(vertices, y, weight, t_min);
}

std::optional<ConeTriangleHit> intersect_cone_triangle_mapped(
    const std::array<VertexInRayFrame, 3>& vertices, const std::array<Vec2f, 3>& y,
    TriangleWeight weight, float t_min) {
    if (std::max({vertices[0].t, vertices[1].t, vertices[2].t}) < t_min) {
        return std::nullopt;
    }
    if (!y[0].allFinite() || !y[1].allFinite() || !y[2].allFinite()) {
        return std::nullopt;
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
            // (|n·d| below kEdgeOnCosine), where that depth runs away: kept within the triangle's
            // own.
            plane_t = (1.0 - b1 - b2) * vertices[0].t + b1 * vertices[1].t + b2 * vertices[2].t;
            const double dt1 = static_cast<double>(vertices[1].t) - vertices[0].t;
            const double dt2 = static_cast<double>(vertices[2].t) - vertices[0].t;
            // The plane's normal in ray coordinates (u, v, t): (e1, dt1) × (e2, dt2).
            const Eigen::Vector3d normal(e1.y() * dt2 - dt1 * e2.y(), dt1 * e2.x() - e1.x() * dt2,
                                         det);
            edge_on = std::abs(det) < kEdgeOnCosine * normal.norm();
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
