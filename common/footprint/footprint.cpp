#include "common/footprint/footprint.h"

#include <algorithm>
#include <cmath>

namespace mrt {

namespace {

/// Scales a runaway differential back to the largest length kept.
Vec3f bounded(const Vec3f& v) {
    if (!all_finite(v)) {
        return Vec3f::Zero();
    }
    const float squared = v.squaredNorm();
    if (squared > RayDifferential::kMaxSquaredLength) {
        return v * std::sqrt(RayDifferential::kMaxSquaredLength / squared);
    }
    return v;
}

/// x moved away from zero to at least `magnitude`, keeping its sign (zero counts positive).
float away_from_zero(float x, float magnitude) {
    if (std::abs(x) >= magnitude) {
        return x;
    }
    return x < 0.0f ? -magnitude : magnitude;
}

}  // namespace

Vec3f RayDifferential::unit_derivative(const Vec3f& d, const Vec3f& dv) {
    const float dd = d.squaredNorm();
    if (!(dd > 0.0f)) {
        return Vec3f::Zero();
    }
    return bounded((dv * dd - d * d.dot(dv)) / (dd * std::sqrt(dd)));
}

RayDifferential RayDifferential::pinhole(const Vec3f& unnormalised_direction, const Vec3f& step_x,
                                         const Vec3f& step_y) {
    RayDifferential r;
    r.dd_dx = unit_derivative(unnormalised_direction, step_x);
    r.dd_dy = unit_derivative(unnormalised_direction, step_y);
    return r;
}

RayDifferential RayDifferential::thin_lens(const Vec3f& lens_to_focus, const Vec3f& step_x,
                                           const Vec3f& step_y, float focal_distance) {
    RayDifferential r;
    r.dd_dx = unit_derivative(lens_to_focus, focal_distance * step_x);
    r.dd_dy = unit_derivative(lens_to_focus, focal_distance * step_y);
    return r;
}

RayDifferential RayDifferential::transfer(const Vec3f& d, float t, const Vec3f& n) const {
    // A ray grazing the plane has no finite derivative of t; the clamp keeps it large and
    // finite, and bounded() caps what follows.
    const float dn = away_from_zero(d.dot(n), 1e-12f);
    const auto one = [&](const Vec3f& dp, const Vec3f& dd) {
        const Vec3f moved = dp + t * dd;
        const float dt = -moved.dot(n) / dn;  // eq. 12
        return bounded(moved + dt * d);       // eq. 10
    };
    RayDifferential r;
    r.dp_dx = one(dp_dx, dd_dx);
    r.dp_dy = one(dp_dy, dd_dy);
    r.dd_dx = dd_dx;
    r.dd_dy = dd_dy;
    return r;
}

RayDifferential RayDifferential::redirected(const Vec3f& d, const Vec3f& n, const Vec3f& dn_dx,
                                            const Vec3f& dn_dy, float eta, float mu,
                                            float dmu_factor) const {
    const auto one = [&](const Vec3f& dd, const Vec3f& dn) {
        const float dmu = dmu_factor * (dd.dot(n) + d.dot(dn));  // dμ from d(D·N), eqs. 15, 19
        return bounded(eta * dd - (mu * dn + dmu * n));          // eqs. 14, 18
    };
    RayDifferential r;
    r.dp_dx = dp_dx;
    r.dp_dy = dp_dy;
    r.dd_dx = one(dd_dx, dn_dx);
    r.dd_dy = one(dd_dy, dn_dy);
    return r;
}

RayDifferential RayDifferential::reflect(const Vec3f& d, const Vec3f& n, const Vec3f& dn_dx,
                                         const Vec3f& dn_dy) const {
    // R = D − 2(D·N)N: η = 1, μ = 2·D·N, dμ = 2·d(D·N).
    return redirected(d, n, dn_dx, dn_dy, 1.0f, 2.0f * d.dot(n), 2.0f);
}

RayDifferential RayDifferential::refract(const Vec3f& d, const Vec3f& n, const Vec3f& dn_dx,
                                         const Vec3f& dn_dy, float eta) const {
    const float d_dot_n = d.dot(n);
    const float k = 1.0f - eta * eta * (1.0f - d_dot_n * d_dot_n);
    // D'·N of the refracted direction (negative: it leaves through the surface); at the
    // critical angle it tends to 0 and dμ to infinity, so its magnitude is bounded below.
    const float t_dot_n = -std::sqrt(std::max(k, 0.0f));
    const float mu = eta * d_dot_n - t_dot_n;                                        // eq. 16
    const float dmu_factor = eta - eta * eta * d_dot_n / std::min(t_dot_n, -1e-6f);  // eq. 19
    return redirected(d, n, dn_dx, dn_dy, eta, mu, dmu_factor);
}

RayDifferential RayDifferential::transformed(const Mat3f& linear, const Vec3f& d) const {
    const Vec3f mapped = linear * d;
    RayDifferential r;
    r.dp_dx = bounded(linear * dp_dx);
    r.dp_dy = bounded(linear * dp_dy);
    r.dd_dx = unit_derivative(mapped, linear * dd_dx);
    r.dd_dy = unit_derivative(mapped, linear * dd_dy);
    return r;
}

bool RayDifferential::finite() const {
    return all_finite(dp_dx) && all_finite(dp_dy) && all_finite(dd_dx) && all_finite(dd_dy);
}

SurfaceDifferential triangle_differential(const Vec3f p[3], const Vec3f n[3], const Vec2f uv[3],
                                          float b1, float b2, const Vec3f& dp_dx,
                                          const Vec3f& dp_dy, Facing facing) {
    SurfaceDifferential s;
    const Vec3f e1 = p[1] - p[0];
    const Vec3f e2 = p[2] - p[0];
    const Vec3f g = e1.cross(e2);
    const float g2 = g.squaredNorm();
    if (!(g2 > 0.0f) || !std::isfinite(g2)) {
        return s;
    }
    // Gradients of the barycentric coordinates b1, b2 as functions of position in the plane.
    const Vec3f grad1 = e2.cross(g) / g2;
    const Vec3f grad2 = g.cross(e1) / g2;
    const float b0 = 1.0f - b1 - b2;
    const Vec3f normal = b0 * n[0] + b1 * n[1] + b2 * n[2];
    const float sign = facing == Facing::Back ? -1.0f : 1.0f;
    const auto one = [&](const Vec3f& dp, Vec3f& dn_out, Vec2f& duv_out) {
        const float db1 = grad1.dot(dp);
        const float db2 = grad2.dot(dp);
        const float db0 = -db1 - db2;
        const Vec3f dn = db0 * n[0] + db1 * n[1] + db2 * n[2];
        dn_out = sign * normalised_derivative(normal, dn);
        duv_out = db0 * uv[0] + db1 * uv[1] + db2 * uv[2];
        if (!all_finite(duv_out)) {
            duv_out = Vec2f::Zero();
        }
    };
    const float uv_area = std::abs((uv[1] - uv[0]).x() * (uv[2] - uv[0]).y() -
                                   (uv[1] - uv[0]).y() * (uv[2] - uv[0]).x());
    s.uv_per_length = std::sqrt(uv_area / std::sqrt(g2));
    if (!std::isfinite(s.uv_per_length)) {
        s.uv_per_length = 0.0f;
    }
    one(dp_dx, s.dn_dx, s.duv_dx);
    one(dp_dy, s.dn_dy, s.duv_dy);
    return s;
}

float largest_singular_value(const Mat2f& m) {
    const float a = m.col(0).squaredNorm();
    const float c = m.col(1).squaredNorm();
    const float b = m.col(0).dot(m.col(1));
    const float half_difference = 0.5f * (a - c);
    return std::sqrt(0.5f * (a + c) + std::hypot(half_difference, b));
}

SymmetricEigen2 symmetric_eigen2(float a, float b, float c) {
    SymmetricEigen2 e;
    if (!std::isfinite(a) || !std::isfinite(b) || !std::isfinite(c)) {
        return e;
    }
    const double mean = 0.5 * (static_cast<double>(a) + c);
    const double half_difference = 0.5 * (static_cast<double>(a) - c);
    // Squares of floats cannot overflow a double: no need for hypot's scaling.
    const double radius = std::sqrt(half_difference * half_difference + static_cast<double>(b) * b);
    const double major = mean + radius;
    // The smaller root from the determinant: mean − radius cancels catastrophically for thin
    // ellipses.
    const double det = static_cast<double>(a) * c - static_cast<double>(b) * b;
    const double minor = major > 0.0 ? det / major : mean - radius;
    e.major = static_cast<float>(major);
    e.minor = static_cast<float>(std::max(0.0, std::min(minor, major)));
    // The major axis from (A − λ·I)·x = 0, written with whichever of its two rows does not
    // cancel: (half_difference + radius, b) when a ≥ c, (b, radius − half_difference) when not.
    // No trigonometry (this runs for every node a cone visits); equal eigenvalues give x.
    const Vec2d axis = half_difference >= 0.0
                           ? Vec2d(half_difference + radius, static_cast<double>(b))
                           : Vec2d(static_cast<double>(b), radius - half_difference);
    const double length = axis.norm();
    e.major_axis = length > 0.0 ? Vec2f((axis / length).cast<float>()) : Vec2f(1.0f, 0.0f);
    e.minor_axis = Vec2f(-e.major_axis.y(), e.major_axis.x());
    return e;
}

FootprintCone FootprintCone::from_differential(const Vec3f& d, const RayDifferential& rd) {
    FootprintCone cone;
    orthonormal_basis(d, cone.u, cone.v);
    cone.start_dev = cone.project(rd.dp_dx, rd.dp_dy);
    cone.incr_dev = cone.project(rd.dd_dx, rd.dd_dy);
    return cone;
}

SymmetricEigen2 FootprintCone::ellipse_of(const Mat2f& footprint) {
    const Mat2f c = footprint * footprint.transpose();
    return symmetric_eigen2(c(0, 0), 0.5f * (c(0, 1) + c(1, 0)), c(1, 1));
}

SymmetricEigen2 FootprintCone::ellipse(float t) const {
    return ellipse_of(at(t));
}

float FootprintCone::max_diameter(float t) const {
    return 2.0f * std::sqrt(ellipse(t).major);
}

float FootprintCone::min_diameter(float t) const {
    return 2.0f * std::sqrt(ellipse(t).minor);
}

Mat2f FootprintCone::clamp_anisotropy(const Mat2f& footprint, float max_anisotropy) {
    SymmetricEigen2 e;
    return clamp_anisotropy(footprint, max_anisotropy, e);
}

Mat2f FootprintCone::clamp_anisotropy(const Mat2f& footprint, float max_anisotropy,
                                      SymmetricEigen2& clamped_ellipse) {
    clamped_ellipse = ellipse_of(footprint);
    return clamp_decomposed(footprint, max_anisotropy, clamped_ellipse);
}

Mat2f FootprintCone::clamp_decomposed(const Mat2f& footprint, float max_anisotropy,
                                      SymmetricEigen2& ellipse) {
    SymmetricEigen2& e = ellipse;
    const float floor = e.major / (max_anisotropy * max_anisotropy);
    if (e.minor >= floor) {
        return footprint;
    }
    e.minor = floor;
    // Same ellipse axes, minor widened: columns along the axes (the ellipse is F·Fᵀ, so the
    // pixel-axis pairing of the columns does not matter to any consumer).
    Mat2f clamped;
    clamped.col(0) = std::sqrt(e.major) * e.major_axis;
    clamped.col(1) = std::sqrt(floor) * e.minor_axis;
    return clamped;
}

namespace {

/// The parts of the square root of the symmetric positive semi-definite C = [[a, b], [b, c]]:
/// it is (C + s·I)/τ with s = √det C and τ = √(tr C + 2s) (Cayley–Hamilton): no
/// eigen-decomposition, and every term is a sum of non-negative numbers except det C, taken
/// without cancellation. Scaled to the larger diagonal entry m first (an, bn, cn = C/m, and s, τ
/// of that): det C is a product of two entries, which in float underflows below entries of 1e-19
/// (footprints of 1e-11) and overflows above 1e19. The root is √m·(C/m + s·I)/τ.
struct RootParts {
    float m = 0.0f;                         ///< The larger diagonal entry of C.
    float an = 0.0f, bn = 0.0f, cn = 0.0f;  ///< The entries of C/m.
    float s = 0.0f;                         ///< √det(C/m).
    float tau = 0.0f;                       ///< √(tr(C/m) + 2s).
    bool valid = false;  ///< False for a zero or non-finite C: its root is taken as zero.
};

RootParts root_parts(float a, float b, float c) {
    RootParts r;
    r.m = std::max(a, c);
    if (!(r.m > 0.0f) || !std::isfinite(r.m) || !std::isfinite(b)) {
        return r;
    }
    r.an = a / r.m;
    r.bn = b / r.m;
    r.cn = c / r.m;
    r.s = std::sqrt(std::max(difference_of_products(r.an, r.cn, r.bn, r.bn), 0.0f));
    r.tau = std::sqrt(r.an + r.cn + 2.0f * r.s);
    r.valid = r.tau > 0.0f && std::isfinite(r.tau);
    return r;
}

/// The square root of the symmetric positive semi-definite matrix whose parts `r` are.
Mat2f symmetric_root(const RootParts& r) {
    if (!r.valid) {
        return Mat2f::Zero();
    }
    const float scale = std::sqrt(r.m) / r.tau;
    Mat2f root;
    root << (r.an + r.s) * scale, r.bn * scale, r.bn * scale, (r.cn + r.s) * scale;
    return root;
}

/// The square root of the symmetric positive semi-definite [[a, b], [b, c]].
Mat2f symmetric_root(float a, float b, float c) {
    return symmetric_root(root_parts(a, b, c));
}

/// The derivative of the root of the matrix whose parts `r` are, along the symmetric direction (da,
/// db, dc): with C/m, s and τ as there, dR = √m·(dC/m + ds·I − (C/m + s·I)·dτ/τ)/τ, ds =
/// d(det)/(2s), dτ = (tr dC/m + 2·ds)/(2τ). Where C is singular (a footprint collapsed to a
/// segment) det C ≥ 0 is at its minimum and ds is taken as 0: √det has no derivative there, and 0
/// is the mean of its one-sided ones.
Mat2f symmetric_root_derivative(const RootParts& r, float da, float db, float dc) {
    if (!r.valid) {
        return Mat2f::Zero();
    }
    const float dan = da / r.m;
    const float dbn = db / r.m;
    const float dcn = dc / r.m;
    float ds = 0.0f;
    if (r.s > 0.0f) {
        ds = (r.an * dcn + r.cn * dan - 2.0f * r.bn * dbn) / (2.0f * r.s);
        if (!std::isfinite(ds)) {
            ds = 0.0f;
        }
    }
    const float dtau_over_tau = (dan + dcn + 2.0f * ds) / (2.0f * r.tau * r.tau);
    const float scale = std::sqrt(r.m) / r.tau;
    const float off_diagonal = (dbn - r.bn * dtau_over_tau) * scale;
    Mat2f derivative;
    derivative << (dan + ds - (r.an + r.s) * dtau_over_tau) * scale, off_diagonal, off_diagonal,
        (dcn + ds - (r.cn + r.s) * dtau_over_tau) * scale;
    return derivative;
}

}  // namespace

FootprintCone::Local FootprintCone::local_at(float t) const {
    if (!blurred) {
        return {pixel_at(t), incr_dev};
    }
    // C(t) = F·Fᵀ + B·Bᵀ with F and B linear in t: dC = F·dFᵀ + dF·Fᵀ + B·dBᵀ + dB·Bᵀ. The root
    // and its derivative share one set of parts.
    const Mat2f f = pixel_at(t);
    const Mat2f b = blur_start + t * blur_incr;
    const Mat2f sum = f * f.transpose() + b * b.transpose();
    const RootParts parts = root_parts(sum(0, 0), 0.5f * (sum(0, 1) + sum(1, 0)), sum(1, 1));
    const Mat2f half_derivative = f * incr_dev.transpose() + b * blur_incr.transpose();
    const Mat2f derivative = half_derivative + half_derivative.transpose();
    return {
        symmetric_root(parts),
        symmetric_root_derivative(parts, derivative(0, 0),
                                  0.5f * (derivative(0, 1) + derivative(1, 0)), derivative(1, 1))};
}

Mat2f FootprintCone::growth_at(float t) const {
    return local_at(t).growth;
}

Mat2f FootprintCone::widened(const Mat2f& footprint, float radius) {
    const Mat2f f = footprint * footprint.transpose();
    return symmetric_root(f(0, 0) + radius * radius, 0.5f * (f(0, 1) + f(1, 0)),
                          f(1, 1) + radius * radius);
}

Mat2f FootprintCone::convolved(const Mat2f& f, const Mat2f& b) {
    const Mat2f sum = f * f.transpose() + b * b.transpose();
    return symmetric_root(sum(0, 0), 0.5f * (sum(0, 1) + sum(1, 0)), sum(1, 1));
}

void FootprintCone::add_blur(const Mat2f& start, const Mat2f& incr) {
    if (!blurred) {
        blur_start = start;
        blur_incr = incr;
        blurred = true;
        return;
    }
    // Two linear blurs do not sum to one linear blur: combined this way the sum of squares is
    // exact at t = 0 and as t → ∞, approximate in between. No tracer path adds a second one.
    blur_start = convolved(blur_start, start);
    blur_incr = convolved(blur_incr, incr);
}

FootprintInverse FootprintCone::inverse(const Mat2f& footprint) {
    const float det =
        difference_of_products(footprint(0, 0), footprint(1, 1), footprint(0, 1), footprint(1, 0));
    FootprintInverse result;
    const float inverse_det = 1.0f / det;
    if (!std::isfinite(inverse_det) || !std::isfinite(det) || det == 0.0f) {
        return result;
    }
    Mat2f inverse;
    inverse << footprint(1, 1), -footprint(0, 1), -footprint(1, 0), footprint(0, 0);
    inverse *= inverse_det;
    if (!all_finite(inverse)) {
        return result;
    }
    result.inverse = inverse;
    result.abs_det = std::abs(det);
    return result;
}

}  // namespace mrt
