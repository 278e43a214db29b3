#include "trace/render/mesh_light.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace mrt {

namespace {

constexpr double kPiD = 3.14159265358979323846;

Vec3d to_double(const Vec3f& v) {
    return v.cast<double>();
}

/// Barycentric weights of the triangle point that (u, v) ∈ [0,1)² maps to, uniform by area:
/// Heitz's (2019) low-distortion map, as pbrt-v4's SampleUniformTriangle. It folds the square
/// onto the triangle along its diagonal instead of squeezing it to a corner (the square-root
/// map), so neighbouring samples stay neighbours and stratification survives.
std::array<float, 3> uniform_triangle(float u, float v) {
    float b0 = 0.0f;
    float b1 = 0.0f;
    if (u < v) {
        b0 = 0.5f * u;
        b1 = v - b0;
    } else {
        b1 = 0.5f * v;
        b0 = u - b1;
    }
    return {b0, b1, 1.0f - b0 - b1};
}

/// The point of `light` that (u, v) ∈ [0,1)² maps to, uniform by area.
Vec3f point_on_light(const MeshAreaLight& light, float u, float v) {
    float rescaled = u;
    const MeshAreaLight::Triangle& t = light.triangles()[light.pick_triangle(rescaled)];
    const std::array<float, 3> b = uniform_triangle(rescaled, v);
    return b[0] * t[0] + b[1] * t[1] + b[2] * t[2];
}

/// What the emitting point `point` of `light` delivers to p (see LightSample).
LightSample emitter_point(const MeshAreaLight& light, const Vec3f& point, const Vec3f& p) {
    return flat_emitter_point(point, light.normal(), false, light.radiance() * light.area(), p);
}

/// Lambert's term Θ·(n·Γ) of the straight edge from a to b (both relative to the receiver):
/// the angle the edge subtends times the cosine of its plane's normal with n.
double edge_term(const Vec3d& n, const Vec3d& a, const Vec3d& b) {
    const Vec3d normal = a.cross(b);
    const double length = normal.norm();
    if (!(length > 0.0)) {
        return 0.0;
    }
    // atan2 of the sine and cosine: accurate for edges seen under tiny and near-π angles alike,
    // where acos of the normalised dot product loses half its digits.
    return std::atan2(length, a.dot(b)) * n.dot(normal) / length;
}

/// A triangle clipped by up to two planes (a convex polygon gains at most one vertex per
/// plane): at most five vertices, in the triangle's winding order.
struct Polygon {
    std::array<Vec3d, 5> vertices;
    /// Which of the triangle's edges (0: t[0]→t[1], 1: t[1]→t[2], 2: t[2]→t[0]) the edge from
    /// vertex i to the next lies on; kClipEdge for an edge in a clipping plane.
    std::array<int, 5> edges{};
    std::size_t count = 0;

    static constexpr int kClipEdge = -1;

    const Vec3d& operator[](std::size_t i) const { return vertices[i]; }
    /// Vertex i's successor, wrapping around.
    const Vec3d& next(std::size_t i) const { return vertices[i + 1 == count ? 0 : i + 1]; }
    void add(const Vec3d& vertex, int edge) {
        vertices[count] = vertex;
        edges[count] = edge;
        ++count;
    }
};

/// A light's triangle relative to the receiver, in double (the formulas below lose nothing to
/// the distances of a scene far from its origin).
std::array<Vec3d, 3> relative_to(const MeshAreaLight::Triangle& t, const Vec3d& origin) {
    return {to_double(t[0]) - origin, to_double(t[1]) - origin, to_double(t[2]) - origin};
}

Polygon triangle_polygon(const std::array<Vec3d, 3>& triangle) {
    Polygon polygon;
    for (std::size_t i = 0; i < 3; ++i) {
        polygon.add(triangle[i], static_cast<int>(i));
    }
    return polygon;
}

/// The part of a convex polygon of at most four vertices (relative to the receiver) where
/// n·x ≥ 0 (Sutherland–Hodgman against one plane through the receiver). A crossing point is
/// interpolated from the two heights, which have opposite signs, so its weight lies in [0, 1]
/// and the point on the edge whatever the rounding.
Polygon clip_above(const Polygon& polygon, const Vec3d& n) {
    Polygon clipped;
    std::array<double, 5> height{};
    for (std::size_t i = 0; i < polygon.count; ++i) {
        height[i] = n.dot(polygon[i]);
    }
    for (std::size_t i = 0; i < polygon.count; ++i) {
        const std::size_t j = i + 1 == polygon.count ? 0 : i + 1;
        const bool inside_i = height[i] >= 0.0;
        const bool inside_j = height[j] >= 0.0;
        if (inside_i) {
            clipped.add(polygon[i], polygon.edges[i]);
        }
        if (inside_i != inside_j) {
            const double t = height[i] / (height[i] - height[j]);
            // Leaving, the polygon runs on along the plane; entering, along edge i again.
            clipped.add(polygon[i] + t * (polygon[j] - polygon[i]),
                        inside_i ? Polygon::kClipEdge : polygon.edges[i]);
        }
    }
    return clipped;
}

/// Whether the edge `edge` of triangle `index` of the light is also an edge of the triangle
/// before or after it in the list, run the other way and wound the same way about the light's
/// normal (the two halves of a quad, as loaders split them): an inner edge of the light, whose
/// two integrals cancel. Only the neighbours are looked at, to keep the cost linear; an inner
/// edge missed is integrated twice, to the same result.
bool inner_edge(const MeshAreaLight& light, std::size_t index, int edge) {
    const std::vector<MeshAreaLight::Triangle>& triangles = light.triangles();
    const MeshAreaLight::Triangle& t = triangles[index];
    const auto e = static_cast<std::size_t>(edge);
    const Vec3f& from = t[e];
    const Vec3f& to = t[(e + 1) % 3];
    const auto winding = [&](const MeshAreaLight::Triangle& u) {
        return light.normal().dot((u[1] - u[0]).cross(u[2] - u[0]));
    };
    const float own = winding(t);
    for (const std::size_t other : {index - 1, index + 1}) {
        if (other >= triangles.size()) {  // index − 1 wraps to a huge number for index 0
            continue;
        }
        const MeshAreaLight::Triangle& u = triangles[other];
        const float theirs = winding(u);
        if (!((own > 0.0f && theirs > 0.0f) || (own < 0.0f && theirs < 0.0f))) {
            continue;
        }
        for (std::size_t k = 0; k < 3; ++k) {
            if (u[k] == to && u[(k + 1) % 3] == from) {
                return true;
            }
        }
    }
    return false;
}

/// The lobe's value, relative to its peak, below which a light contributes no highlight.
constexpr float kNegligibleLobe = 1e-5f;

/// 8-point Gauss–Legendre rule on [−1, 1]: its positive nodes and their weights.
constexpr std::array<double, 4> kGaussNodes = {0.1834346424956498, 0.5255324099163290,
                                               0.7966664774136267, 0.9602898564975363};
constexpr std::array<double, 4> kGaussWeights = {0.3626837833783620, 0.3137066458778873,
                                                 0.2223810344533745, 0.1012285362903763};

/// The two edge integrals of the highlight along one great arc, per unit (see
/// mesh_light_phong_highlight): ∫ K_e(z) ds and ∫ z^e ds, with z = r·ω the lobe's cosine along
/// the arc and K_e(z) = −(1 − z^e)/(1 − z²).
struct EdgeIntegrals {
    double k = 0.0;
    double power = 0.0;
};

/// K_e and z^e at the point of the arc whose lobe cosine is z = 1 − u (u ∈ [0, 1]). Both from
/// log1p(−u): near the lobe's axis 1 − z^e and 1 − z² cancel to rounding if formed from z, while
/// u is accurate there (the caller forms it from sin², not from 1 − cos) and expm1 keeps the
/// ratio's digits; K_e's removable singularity at u = 0 is its limit −e/2.
void lobe_terms(double e, double u, double& k, double& power) {
    const double log_z = std::log1p(-std::clamp(u, 0.0, 1.0));
    const double e_log_z = e * log_z;
    power = std::exp(e_log_z);
    k = u > 0.0 ? std::expm1(e_log_z) / (u * (2.0 - u)) : -0.5 * e;
}

/// Where an arc ends on the plane r·ω = 0 (where the clip against it cut the light), a
/// fractional exponent below this makes z^e there as rough as a root of the distance: panels
/// shrink geometrically into that end too, from this fraction of the arc.
constexpr double kRoughExponent = 2.0;
constexpr double kEndPanel = 1e-3;

/// ∫₀^Θ over the arc z(s) = c·cos(s − φ) of K_e(z) and z^e (e > 0): 8-point Gauss–Legendre
/// panels growing geometrically away from the arc's point nearest the lobe's axis, where both
/// integrands peak over a width about 1/√e (K_e also over √(2(1 − c)) when the arc passes
/// beside the axis): the first panel spans that width, each next one twice the last, so about
/// log₂(Θ√e) panels resolve any exponent.
EdgeIntegrals arc_integrals(double c, double phi, double theta, double e) {
    if (!std::isfinite(c) || !std::isfinite(phi) || !(theta > 0.0 && theta <= kPiD)) {
        return {};
    }
    // The arc's point of largest z: the great circle's top φ if on the arc, else an end.
    const auto z_at = [&](double s) { return c * std::cos(s - phi); };
    double peak = 0.0;
    if (phi >= 0.0 && phi <= theta) {
        peak = phi;
    } else if (z_at(theta) > z_at(0.0)) {
        peak = theta;
    }
    // z^e's peak is about 1/√e wide; where it is negligible on the whole arc, K_e's is wider.
    const double gap = 1.0 - c * std::cos(peak - phi);
    const bool bump = e * std::log1p(-std::min(gap, 1.0)) > -40.0;
    const double width = std::max(1e-6, bump ? 1.0 / std::sqrt(e) : std::sqrt(2.0 * gap + 1.0 / e));
    const bool rough = e < kRoughExponent && e != std::floor(e);
    EdgeIntegrals sum;
    const auto panel = [&](double a, double b) {
        const double mid = 0.5 * (a + b);
        const double half = 0.5 * (b - a);
        for (std::size_t i = 0; i < kGaussNodes.size(); ++i) {
            for (const double s : {mid - half * kGaussNodes[i], mid + half * kGaussNodes[i]}) {
                // 1 − c·cos Δ = (1 − c) + 2c·sin²(Δ/2): no cancellation near the axis.
                const double sine = std::sin(0.5 * (s - phi));
                double k = 0.0;
                double power = 0.0;
                lobe_terms(e, (1.0 - c) + 2.0 * c * sine * sine, k, power);
                sum.k += half * kGaussWeights[i] * k;
                sum.power += half * kGaussWeights[i] * power;
            }
        }
    };
    // Panels from `from` towards `to`, the first `first` wide, each next twice the last.
    const auto graded = [&](double from, double to, double first) {
        double step = first;
        while (from != to) {
            const double next = to > from ? std::min(to, from + step) : std::max(to, from - step);
            panel(std::min(from, next), std::max(from, next));
            from = next;
            step *= 2.0;
        }
    };
    for (const double end : {theta, 0.0}) {
        if (rough && z_at(end) <= 1e-9 && end != peak) {
            const double middle = 0.5 * (peak + end);
            graded(peak, middle, width);
            graded(end, middle, kEndPanel * std::abs(end - peak));
        } else {
            graded(peak, end, width);
        }
    }
    return sum;
}

/// The two eigenvalues (largest first) of the symmetric 2×2 matrix [[xx, xy], [xy, yy]] and
/// the angle of the first one's eigenvector. The smaller eigenvalue is the determinant over
/// the larger, not mean − radius: for a thin light that difference cancels to rounding noise
/// (or a negative number), the quotient keeps its relative precision.
struct Eigen2 {
    double major = 0.0;
    double minor = 0.0;
    double angle = 0.0;
};
Eigen2 symmetric_eigen(double xx, double xy, double yy) {
    Eigen2 e;
    const double mean = 0.5 * (xx + yy);
    const double radius = std::hypot(0.5 * (xx - yy), xy);
    e.major = std::max(0.0, mean + radius);
    e.minor = e.major > 0.0 ? std::max(0.0, (xx * yy - xy * xy) / e.major) : 0.0;
    e.angle = 0.5 * std::atan2(2.0 * xy, xx - yy);
    return e;
}

}  // namespace

LightSample sample_mesh_light(const MeshAreaLight& light, const Vec3f& p, float u, float v) {
    return emitter_point(light, point_on_light(light, u, v), p);
}

LightSample sample_mesh_light_centre(const MeshAreaLight& light, const Vec3f& p) {
    return emitter_point(light, light.centroid(), p);
}

double mesh_light_projected_solid_angle(const MeshAreaLight& light, const Vec3f& p,
                                        const Vec3f& n) {
    const Vec3d origin = to_double(p);
    const Vec3d facing = to_double(light.normal()).normalized();
    // p must see the emitting face: strictly on the side the normal points to.
    if (!(facing.dot(origin - to_double(light.centroid())) > 0.0)) {
        return 0.0;
    }
    const Vec3d normal = to_double(n).normalized();
    double sum = 0.0;
    for (const MeshAreaLight::Triangle& t : light.triangles()) {
        const std::array<Vec3d, 3> relative = relative_to(t, origin);
        // Lambert's sum is signed by the winding as seen from p: a triangle wound about the
        // light's normal and seen from its emitting side gives −2× its projected solid angle.
        const double winding =
            facing.dot((relative[1] - relative[0]).cross(relative[2] - relative[0]));
        if (winding == 0.0) {
            continue;
        }
        const Polygon clipped = clip_above(triangle_polygon(relative), normal);
        double contour = 0.0;
        for (std::size_t i = 0; i < clipped.count; ++i) {
            contour += edge_term(normal, clipped[i], clipped.next(i));
        }
        sum += winding > 0.0 ? -0.5 * contour : 0.5 * contour;
    }
    return std::clamp(sum, 0.0, kPiD);
}

float mesh_light_phong_highlight(const MeshAreaLight& light, const Vec3f& p, const Vec3f& n,
                                 const Vec3f& wo, float exponent) {
    const double e = std::max(0.0f, exponent);
    const Vec3f& facing = light.normal();
    // Only the emitting side sees anything.
    if (!(light.area() > 0.0f) || !((p - light.centroid()).dot(facing) > 0.0f)) {
        return 0.0f;
    }
    const Vec3f r = 2.0f * wo.dot(n) * n - wo;
    // Nothing to integrate where the lobe is below 1e-5 of its peak over the whole light (most
    // points of a scene): the light lies within asin(R/d) of its centroid's direction, R its
    // farthest vertex from the centroid.
    float extent2 = 0.0f;
    for (const MeshAreaLight::Triangle& t : light.triangles()) {
        for (const Vec3f& vertex : t) {
            extent2 = std::max(extent2, (vertex - light.centroid()).squaredNorm());
        }
    }
    const Vec3f to_centre = light.centroid() - p;
    const float centre_distance = to_centre.norm();
    const float extent = std::sqrt(extent2);
    if (centre_distance > extent) {
        const float apart = std::acos(std::clamp(r.dot(to_centre) / centre_distance, -1.0f, 1.0f)) -
                            std::asin(extent / centre_distance);
        if (apart >= 0.5f * kPi ||
            (apart > 0.0f && std::pow(std::cos(apart), static_cast<float>(e)) < kNegligibleLobe)) {
            return 0.0f;
        }
    }
    const Vec3d origin = to_double(p);
    const Vec3d normal = to_double(n).normalized();
    const Vec3d axis = to_double(r).normalized();
    const Vec3d face = to_double(facing);
    const double axis_normal = axis.dot(normal);
    double sum = 0.0;
    for (std::size_t index = 0; index < light.triangles().size(); ++index) {
        const MeshAreaLight::Triangle& t = light.triangles()[index];
        const std::array<Vec3d, 3> relative = relative_to(t, origin);
        const double winding =
            face.dot((relative[1] - relative[0]).cross(relative[2] - relative[0]));
        if (winding == 0.0) {
            continue;
        }
        // Both max(0, ·) of the integrand become the polygon's edges: above the tangent plane
        // and in front of the plane normal to r.
        const Polygon polygon = clip_above(clip_above(triangle_polygon(relative), normal), axis);
        for (std::size_t i = 0; i < polygon.count; ++i) {
            // An inner edge's piece is the same in both triangles (the same segment cut by the
            // same planes), run both ways: skipped in both.
            if (polygon.edges[i] != Polygon::kClipEdge &&
                inner_edge(light, index, polygon.edges[i])) {
                continue;
            }
            const Vec3d a = polygon[i].normalized();
            const Vec3d b = polygon.next(i).normalized();
            const Vec3d cross = a.cross(b);
            const double length = cross.norm();
            if (!(length > 0.0)) {
                continue;
            }
            const double theta = std::atan2(length, a.dot(b));
            // The great circle's unit normal, and its outward co-normal: a triangle wound about
            // the light's normal runs clockwise seen from its emitting side.
            const Vec3d circle = cross / length;
            const Vec3d outward = winding > 0.0 ? circle : Vec3d(-circle);
            // Along the arc ω(s) = a·cos s + (circle × a)·sin s, s ∈ [0, Θ]: r·ω = c·cos(s − φ).
            const double along_a = axis.dot(a);
            const double along_t = axis.dot(circle.cross(a));
            double k = 0.0;
            double power = 0.0;
            if (e > 0.0) {
                const EdgeIntegrals arc = arc_integrals(std::hypot(along_a, along_t),
                                                        std::atan2(along_t, along_a), theta, e);
                k = arc.k;
                power = arc.power;
            } else {
                power = theta;
            }
            sum += axis_normal * axis.dot(outward) * k - normal.dot(outward) * power;
        }
    }
    return static_cast<float>(std::max(0.0, sum / (2.0 * kPiD)));
}

AreaLightTerms mesh_light_terms(const MeshAreaLight& light, const Vec3f& p, const Vec3f& n,
                                const Vec3f& wo, const Material& material) {
    AreaLightTerms terms;
    terms.diffuse = static_cast<float>(mesh_light_projected_solid_angle(light, p, n) / kPiD);
    terms.highlight = (material.specular > 0.0f).any()
                          ? mesh_light_phong_highlight(light, p, n, wo, material.phong_exponent)
                          : 0.0f;
    return terms;
}

Rgb mesh_light_unoccluded(const MeshAreaLight& light, const Vec3f& p, const Vec3f& n,
                          const Vec3f& wo, const Material& material, const Rgb& albedo) {
    // Zero terms reflect zero: no early return needed.
    return mesh_light_terms(light, p, n, wo, material)
        .reflected(light.radiance(), material, albedo);
}

EllipticalAreaLight equivalent_ellipse(const MeshAreaLight& light) {
    const Vec3d centroid = to_double(light.centroid());
    Vec3d facing = to_double(light.normal());
    facing =
        facing.squaredNorm() > 0.0 && facing.allFinite() ? facing.normalized() : Vec3d::UnitZ();
    // An orthonormal in-plane basis (Duff et al. 2017, as orthonormal_basis) with
    // t1 × t2 = facing.
    const double sign = std::copysign(1.0, facing.z());
    const double a = -1.0 / (sign + facing.z());
    const double b = facing.x() * facing.y() * a;
    const Vec3d t1(1.0 + sign * facing.x() * facing.x() * a, sign * b, -sign * facing.x());
    const Vec3d t2(b, sign + facing.y() * facing.y() * a, -facing.y());

    // In-plane second moments about the centroid. A uniform triangle of vertices vᵢ (relative to
    // the centroid) has E[x xᵀ] = (Σ vᵢvᵢᵀ + s sᵀ)/12 with s = Σ vᵢ; the light's covariance is
    // their area-weighted mean. A light of zero area falls back to its vertices' spread, which
    // only orients the (tiny) ellipse.
    double xx = 0.0;
    double xy = 0.0;
    double yy = 0.0;
    double weight = 0.0;
    double vertex_xx = 0.0;
    double vertex_xy = 0.0;
    double vertex_yy = 0.0;
    for (const MeshAreaLight::Triangle& t : light.triangles()) {
        std::array<Vec2d, 3> v;
        for (std::size_t i = 0; i < 3; ++i) {
            const Vec3d offset = to_double(t[i]) - centroid;
            v[i] = Vec2d(offset.dot(t1), offset.dot(t2));
            vertex_xx += v[i].x() * v[i].x();
            vertex_xy += v[i].x() * v[i].y();
            vertex_yy += v[i].y() * v[i].y();
        }
        const Vec2d s = v[0] + v[1] + v[2];
        const double triangle_area = 0.5 * std::abs((v[1] - v[0]).x() * (v[2] - v[0]).y() -
                                                    (v[1] - v[0]).y() * (v[2] - v[0]).x());
        double txx = s.x() * s.x();
        double txy = s.x() * s.y();
        double tyy = s.y() * s.y();
        for (const Vec2d& vi : v) {
            txx += vi.x() * vi.x();
            txy += vi.x() * vi.y();
            tyy += vi.y() * vi.y();
        }
        xx += triangle_area * txx / 12.0;
        xy += triangle_area * txy / 12.0;
        yy += triangle_area * tyy / 12.0;
        weight += triangle_area;
    }
    const Eigen2 eigen = weight > 0.0 ? symmetric_eigen(xx / weight, xy / weight, yy / weight)
                                      : symmetric_eigen(vertex_xx, vertex_xy, vertex_yy);
    const double floor_major = 1e-6 * std::max(1.0, centroid.norm());
    const double major = std::max(weight > 0.0 ? 2.0 * std::sqrt(eigen.major) : 0.0, floor_major);
    const double minor = std::max(weight > 0.0 ? 2.0 * std::sqrt(eigen.minor) : 0.0, 1e-4 * major);
    const Vec3d u_dir = std::cos(eigen.angle) * t1 + std::sin(eigen.angle) * t2;
    // facing × u_dir: then u × v = u × (facing × u) = facing for a unit u in the plane.
    const Vec3d v_dir = facing.cross(u_dir);

    EllipticalAreaLight ellipse;
    ellipse.center = light.centroid();
    ellipse.semi_axis_u = (major * u_dir).cast<float>();
    ellipse.semi_axis_v = (minor * v_dir).cast<float>();
    ellipse.two_sided = false;
    const double ellipse_area = kPiD * major * minor;
    ellipse.radiance = light.radiance() * static_cast<float>(light.area() / ellipse_area);
    return ellipse;
}

std::vector<EllipticalAreaLight> elliptical_lights(const Scene& scene) {
    std::vector<EllipticalAreaLight> lights = scene.area_lights;
    lights.reserve(lights.size() + scene.mesh_lights.size());
    for (const MeshAreaLight& light : scene.mesh_lights) {
        lights.push_back(equivalent_ellipse(light));
    }
    return lights;
}

}  // namespace mrt
