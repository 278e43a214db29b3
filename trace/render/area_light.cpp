#include "trace/render/area_light.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace mrt {

namespace {

using Vec3d = Eigen::Vector3d;

constexpr double kTwoPi = 2.0 * 3.14159265358979323846;

/// The light's rim relative to the receiver: x(φ) = c + cos φ·u + sin φ·v.
struct Rim {
    Vec3d c;
    Vec3d u;
    Vec3d v;

    Vec3d at(double phi) const { return at(std::cos(phi), std::sin(phi)); }
    Vec3d at(double cs, double sn) const { return c + cs * u + sn * v; }
    /// n·(x × dx/dφ)/|x|² at the point (cos φ, sin φ): the integrand of Lambert's contour
    /// form, along n.
    double integrand(const Vec3d& n, double cs, double sn) const {
        const Vec3d x = at(cs, sn);
        const Vec3d dx = cs * v - sn * u;
        const double r2 = x.squaredNorm();
        return r2 > 0.0 ? n.dot(x.cross(dx)) / r2 : 0.0;
    }
    double integrand(const Vec3d& n, double phi) const {
        return integrand(n, std::cos(phi), std::sin(phi));
    }
};

/// Largest number of integrand evaluations: reached only within about 1e-3 of the light's size
/// of its rim, where the integrand peaks over an angle narrower than that.
constexpr int kMaxPoints = 16384;
constexpr double kTolerance = 1e-7;

/// Whether N points on [0, length] resolve the integrand's peak: its width is about the rim's
/// distance from p over the rim's speed, which must span a few sample spacings.
bool resolves(double nearest, double speed, double length, int points) {
    return nearest >= 4.0 * speed * length / points;
}

/// ∮ integrand dφ over the whole rim: the trapezoidal rule, spectrally accurate for a smooth
/// periodic integrand, doubled (reusing its points) until two estimates agree and the samples
/// resolve the peak nearest the rim.
double full_contour(const Rim& rim, const Vec3d& n) {
    // Every level's angles are multiples of 2π/kMaxPoints: their cosines and sines are
    // tabulated once, and a doubling only adds the odd multiples of the next level.
    struct Table {
        std::array<double, kMaxPoints> cos{};
        std::array<double, kMaxPoints> sin{};
        Table() {
            for (int k = 0; k < kMaxPoints; ++k) {
                cos[static_cast<std::size_t>(k)] = std::cos(kTwoPi * k / kMaxPoints);
                sin[static_cast<std::size_t>(k)] = std::sin(kTwoPi * k / kMaxPoints);
            }
        }
    };
    static const Table table;
    const double speed = rim.u.norm() + rim.v.norm();
    double sum = 0.0;
    double nearest = std::numeric_limits<double>::infinity();
    const auto add = [&](int index) {
        const auto i = static_cast<std::size_t>(index);
        sum += rim.integrand(n, table.cos[i], table.sin[i]);
        nearest = std::min(nearest, rim.at(table.cos[i], table.sin[i]).norm());
    };
    int points = 8;
    for (int k = 0; k < points; ++k) {
        add(k * (kMaxPoints / points));
    }
    double estimate = sum * kTwoPi / points;
    while (points < kMaxPoints) {
        const int stride = kMaxPoints / points;
        for (int k = 0; k < points; ++k) {
            add(k * stride + stride / 2);
        }
        points *= 2;
        const double refined = sum * kTwoPi / points;
        const bool agree = std::abs(refined - estimate) <= kTolerance * std::abs(refined);
        estimate = refined;
        if (agree && resolves(nearest, speed, kTwoPi, points)) {
            break;
        }
    }
    return estimate;
}

/// ∫ integrand dφ over [a, b] by 8-point Gauss–Legendre panels, doubled until two estimates
/// agree and the panels resolve the peak nearest the rim.
double arc_contour(const Rim& rim, const Vec3d& n, double a, double b) {
    static constexpr std::array<double, 4> kNodes = {0.1834346424956498, 0.5255324099163290,
                                                     0.7966664774136267, 0.9602898564975363};
    static constexpr std::array<double, 4> kWeights = {0.3626837833783620, 0.3137066458778873,
                                                       0.2223810344533745, 0.1012285362903763};
    const double speed = rim.u.norm() + rim.v.norm();
    const auto panels = [&](int count, double& nearest) {
        const double h = (b - a) / count;
        double sum = 0.0;
        for (int i = 0; i < count; ++i) {
            const double mid = a + (i + 0.5) * h;
            for (std::size_t k = 0; k < kNodes.size(); ++k) {
                const double offset = 0.5 * h * kNodes[k];
                sum +=
                    kWeights[k] * (rim.integrand(n, mid - offset) + rim.integrand(n, mid + offset));
            }
            nearest = std::min(nearest, rim.at(mid).norm());
        }
        return 0.5 * h * sum;
    };
    double nearest = std::numeric_limits<double>::infinity();
    int count = 2;
    double estimate = panels(count, nearest);
    while (count * 8 < kMaxPoints) {
        count *= 2;
        const double refined = panels(count, nearest);
        const bool agree = std::abs(refined - estimate) <= kTolerance * std::abs(refined);
        estimate = refined;
        if (agree && resolves(nearest, speed, b - a, count * 8)) {
            break;
        }
    }
    return estimate;
}

/// Lambert's term Θ·(n·Γ) of the straight edge from a to b (relative to p).
double edge_term(const Vec3d& n, const Vec3d& a, const Vec3d& b) {
    const Vec3d normal = a.cross(b);
    const double length = normal.norm();
    if (!(length > 0.0)) {
        return 0.0;
    }
    return std::atan2(length, a.dot(b)) * n.dot(normal) / length;
}

Vec3d to_double(const Vec3f& v) {
    return v.cast<double>();
}

/// The golden angle: consecutive points of a spiral turned by it never line up.
constexpr double kGoldenAngle = 2.39996322972865332;
constexpr int kAreaPoints = 32;
constexpr int kLobePoints = 32;
/// The lobe's value, relative to its peak, below which a light contributes no highlight.
constexpr float kNegligibleLobe = 1e-5f;

/// cos and sin of the golden-angle spiral's k-th turn, shared by both point sets: computed once
/// instead of twice per point on every shaded fragment.
struct Spiral {
    std::array<float, std::max(kAreaPoints, kLobePoints)> cos{};
    std::array<float, std::max(kAreaPoints, kLobePoints)> sin{};
    Spiral() {
        for (std::size_t k = 0; k < cos.size(); ++k) {
            const double phi = kGoldenAngle * static_cast<double>(k);
            cos[k] = static_cast<float>(std::cos(phi));
            sin[k] = static_cast<float>(std::sin(phi));
        }
    }
};
const Spiral kSpiral;

}  // namespace

double area_light_projected_solid_angle(const EllipticalAreaLight& light, const Vec3f& p,
                                        const Vec3f& n) {
    const Rim rim{to_double(light.center) - to_double(p), to_double(light.semi_axis_u),
                  to_double(light.semi_axis_v)};
    const Vec3d face = rim.u.cross(rim.v);
    // Which face p sees: the light emits along u × v (and against it when two-sided).
    const double side = -rim.c.dot(face);
    if (!(face.squaredNorm() > 0.0) || side == 0.0 || (!light.two_sided && side < 0.0)) {
        return 0.0;
    }
    const Vec3d normal = to_double(n).normalized();
    // Height of the rim over the tangent plane: A·cos φ + B·sin φ + C.
    const double a = normal.dot(rim.u);
    const double b = normal.dot(rim.v);
    const double c = normal.dot(rim.c);
    const double amplitude = std::hypot(a, b);
    double contour = 0.0;
    if (c >= amplitude) {
        contour = full_contour(rim, normal);
    } else if (c <= -amplitude) {
        return 0.0;
    } else {
        // The arc above the plane, φ* ± δ, closed by the chord in the plane.
        const double centre = std::atan2(b, a);
        const double half = std::acos(std::clamp(-c / amplitude, -1.0, 1.0));
        contour = arc_contour(rim, normal, centre - half, centre + half) +
                  edge_term(normal, rim.at(centre + half), rim.at(centre - half));
    }
    return std::clamp(0.5 * std::abs(contour), 0.0, kTwoPi / 2.0);
}

float area_light_phong_highlight(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                                 const Vec3f& wo, float exponent) {
    const float e = std::max(0.0f, exponent);
    const Vec3f face = light.semi_axis_u.cross(light.semi_axis_v);
    const float area = kPi * face.norm();
    if (!(area > 0.0f)) {
        return 0.0f;
    }
    const Vec3f facing = face / face.norm();
    const Vec3f r = 2.0f * wo.dot(n) * n - wo;
    // Nothing to integrate where the lobe is below 1e-5 of its peak over the whole light (most
    // points of a scene): the light lies within asin(R/d) of its centre's direction, R ≥ the
    // ellipse's largest radius by Cauchy–Schwarz.
    const Vec3f to_centre = light.center - p;
    const float centre_distance = to_centre.norm();
    const float extent =
        std::sqrt(light.semi_axis_u.squaredNorm() + light.semi_axis_v.squaredNorm());
    if (centre_distance > extent) {
        const float apart = std::acos(std::clamp(r.dot(to_centre) / centre_distance, -1.0f, 1.0f)) -
                            std::asin(extent / centre_distance);
        if (apart >= 0.5f * kPi ||
            (apart > 0.0f && std::pow(std::cos(apart), e) < kNegligibleLobe)) {
            return 0.0f;
        }
    }
    const float lobe_norm = (e + 2.0f) / (2.0f * kPi);
    const float lobe_pdf_norm = (e + 1.0f) / (2.0f * kPi);
    const auto lobe = [&](float cosine) { return cosine > 0.0f ? std::pow(cosine, e) : 0.0f; };
    // Solid-angle density of the area points at ω meeting the light at distance d:
    // d² / (A·|cos θ_light|); the balance heuristic weighs both sets by their counts.
    const auto contribution = [&](const Vec3f& w, float distance, float cos_light) {
        const float emitted = light.two_sided ? std::abs(cos_light) : cos_light;
        const float cos_n = n.dot(w);
        if (!(emitted > 0.0f) || !(cos_n > 0.0f)) {
            return 0.0f;
        }
        const float power = lobe(r.dot(w));
        if (!(power > 0.0f)) {
            return 0.0f;
        }
        const float area_pdf = distance * distance / (area * emitted);
        const float density = kAreaPoints * area_pdf + kLobePoints * lobe_pdf_norm * power;
        return density > 0.0f && std::isfinite(density) ? lobe_norm * power * cos_n / density
                                                        : 0.0f;
    };
    float sum = 0.0f;
    for (int k = 0; k < kAreaPoints; ++k) {
        const float radius = std::sqrt((static_cast<float>(k) + 0.5f) / kAreaPoints);
        const auto i = static_cast<std::size_t>(k);
        const Vec3f q = light.center + radius * (kSpiral.cos[i] * light.semi_axis_u +
                                                 kSpiral.sin[i] * light.semi_axis_v);
        const Vec3f to = q - p;
        const float distance = to.norm();
        if (!(distance > 0.0f)) {
            continue;
        }
        const Vec3f w = to / distance;
        sum += contribution(w, distance, -w.dot(facing));
    }
    // Directions distributed as the lobe: cos α = u^(1/(e+1)) around r.
    Vec3f t1;
    Vec3f t2;
    orthonormal_basis(r, t1, t2);
    // The light's plane: q = c + a·u + b·v, solved through the Gram matrix (the axes need not
    // be orthogonal).
    const float uu = light.semi_axis_u.squaredNorm();
    const float uv = light.semi_axis_u.dot(light.semi_axis_v);
    const float vv = light.semi_axis_v.squaredNorm();
    const float gram = uu * vv - uv * uv;
    const float height = (light.center - p).dot(facing);
    for (int k = 0; k < kLobePoints; ++k) {
        const float cos_alpha =
            std::pow((static_cast<float>(k) + 0.5f) / kLobePoints, 1.0f / (e + 1.0f));
        const float sin_alpha = std::sqrt(std::max(0.0f, 1.0f - cos_alpha * cos_alpha));
        const auto i = static_cast<std::size_t>(k);
        const Vec3f w = cos_alpha * r + sin_alpha * (kSpiral.cos[i] * t1 + kSpiral.sin[i] * t2);
        const float along = w.dot(facing);
        if (along == 0.0f) {
            continue;
        }
        const float t = height / along;
        if (!(t > 0.0f) || !std::isfinite(t)) {
            continue;
        }
        const Vec3f offset = p + t * w - light.center;
        const float ou = offset.dot(light.semi_axis_u);
        const float ov = offset.dot(light.semi_axis_v);
        const float a = (vv * ou - uv * ov) / gram;
        const float b = (uu * ov - uv * ou) / gram;
        if (!(a * a + b * b <= 1.0f)) {
            continue;
        }
        sum += contribution(w, t, -along);
    }
    return sum;
}

AreaLightTerms area_light_terms(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                                const Vec3f& wo, const Material& material) {
    AreaLightTerms terms;
    terms.diffuse = static_cast<float>(area_light_projected_solid_angle(light, p, n) / kPi);
    terms.highlight = (material.specular > 0.0f).any()
                          ? area_light_phong_highlight(light, p, n, wo, material.phong_exponent)
                          : 0.0f;
    return terms;
}

Rgb area_light_unoccluded(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                          const Vec3f& wo, const Material& material, const Rgb& albedo) {
    const AreaLightTerms terms = area_light_terms(light, p, n, wo, material);
    if (!(terms.diffuse > 0.0f) && !(terms.highlight > 0.0f)) {
        return Rgb::Zero();
    }
    return terms.reflected(light, material, albedo);
}

}  // namespace mrt
