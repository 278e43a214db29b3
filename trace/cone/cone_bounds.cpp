#include "trace/cone/cone_bounds.h"

#include "common/footprint/point_weight.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace mrt {

namespace {

/// ⟨A, B⟩_F, the Frobenius inner product.
float frobenius_dot(const Mat2f& a, const Mat2f& b) {
    return a.cwiseProduct(b).sum();
}

}  // namespace

ConeSphereTest::ConeSphereTest(const FootprintCone& cone, float max_anisotropy) : m_cone(cone) {
    m_finite = cone.start_dev.allFinite() && cone.incr_dev.allFinite() &&
               cone.blur_start.allFinite() && cone.blur_incr.allFinite() && max_anisotropy >= 1.0f;
    if (!m_finite) {
        return;
    }
    m_inverse_anisotropy_squared = 1.0f / (max_anisotropy * max_anisotropy);
    // ‖S + t·I‖_F² = ‖S‖² + 2t⟨S, I⟩ + t²‖I‖², and the blur's likewise: G·Gᵀ = F·Fᵀ + B·Bᵀ
    // has trace ‖F‖_F² + ‖B‖_F².
    m_constant = cone.start_dev.squaredNorm();
    m_linear = 2.0f * frobenius_dot(cone.start_dev, cone.incr_dev);
    m_quadratic = cone.incr_dev.squaredNorm();
    if (cone.blurred) {
        m_constant += cone.blur_start.squaredNorm();
        m_linear += 2.0f * frobenius_dot(cone.blur_start, cone.blur_incr);
        m_quadratic += cone.blur_incr.squaredNorm();
    }
    // Coefficients that overflowed (a footprint near float's limit squared) would make the
    // bound infinite, which is conservative; only NaN must not reach the comparisons.
    m_finite = !std::isnan(m_constant) && !std::isnan(m_linear) && !std::isnan(m_quadratic);
}

ConeSphereTest::ConeSphereTest(const ConeSphereTest& parent, const FootprintCone& cone, float scale)
    : m_cone(cone),
      m_finite(parent.m_finite),
      m_inverse_anisotropy_squared(parent.m_inverse_anisotropy_squared) {
    // G'(t') = scale·G(t'/scale): ‖G'(t')‖² = scale²·(c + l·t'/scale + q·t'²/scale²). Each
    // coefficient gains one rounding, well inside kQuadraticRounding's margin.
    m_constant = parent.m_constant * (scale * scale);
    m_linear = parent.m_linear * scale;
    m_quadratic = parent.m_quadratic;
    m_finite = m_finite && std::isfinite(scale) && !std::isnan(m_constant) && !std::isnan(m_linear);
}

bool ConeSphereTest::depths(const SphereInRayFrame& sphere, float widening, float t_min,
                            float t_max, float& near, float& far) const {
    near = std::max(sphere.t - sphere.radius, t_min);
    far = std::min(sphere.t + sphere.radius, t_max);
    return m_finite && std::isfinite(near) && std::isfinite(far) && sphere.offset.allFinite() &&
           std::isfinite(widening);
}

Vec3f ConeSphereTest::second_moments(float t) const {
    // G·Gᵀ = F·Fᵀ + B·Bᵀ as (a, b, c) of [[a, b], [b, c]]: |Gᵀe|² = eᵀ·G·Gᵀ·e along any unit e,
    // the quadratic form of one symmetric matrix per depth instead of two products per axis.
    const Mat2f f = m_cone.pixel_at(t);
    Vec3f m(f.row(0).squaredNorm(), f.row(0).dot(f.row(1)), f.row(1).squaredNorm());
    if (m_cone.blurred) {
        const Mat2f b = m_cone.blur_start + t * m_cone.blur_incr;
        m += Vec3f(b.row(0).squaredNorm(), b.row(0).dot(b.row(1)), b.row(1).squaredNorm());
    }
    return m;
}

bool ConeSphereTest::circle_may_touch(const SphereInRayFrame& sphere, float widening, float t_min,
                                      float t_max) const {
    float near = 0.0f;
    float far = 0.0f;
    if (!depths(sphere, widening, t_min, t_max, near, far)) {
        return true;
    }
    if (near > far) {
        return false;  // wholly before t_min or after t_max
    }
    // The axis within the sphere's disc: the reach below is at least the radius.
    const float offset_squared = sphere.offset.squaredNorm();
    if (offset_squared <= sphere.radius * sphere.radius) {
        return true;
    }
    // |Fᵀe| ≤ ‖F‖_F along every e, so the ellipse's reach is at most
    // ρ·√(‖F‖_F²·(1 + 1/A²) + w²), convex in t: largest at one end. Most spheres a cone is
    // tested against are its node's siblings well off the axis; they fall here without a
    // decomposition.
    const float frobenius = std::max(frobenius_squared(near), frobenius_squared(far));
    const float circle_reach =
        std::sqrt(kPointWeightClipExponent *
                  (frobenius * (1.0f + m_inverse_anisotropy_squared) + widening * widening)) +
        sphere.radius;
    return !(offset_squared > circle_reach * circle_reach);
}

bool ConeSphereTest::rectangle_may_touch(const SphereInRayFrame& sphere, float widening,
                                         float t_min, float t_max, const Vec2f& axis) const {
    float near = 0.0f;
    float far = 0.0f;
    if (!depths(sphere, widening, t_min, t_max, near, far) || !axis.allFinite()) {
        return true;
    }
    if (near > far) {
        return false;
    }
    // Along a unit e the clip ellipse reaches at most ρ·√(|Gᵀe|² + ‖G‖_F²/A² + w²) (the file
    // comment), convex in t: its square is compared, so no root is taken. The sphere misses
    // when |x·e| − r exceeds it at both ends. Where the disc holds the axis's projection on
    // both axes (the sphere around the cone's axis, most of the nodes a cone visits) nothing
    // can miss, and the footprint's moments are not formed.
    const std::array<Vec2f, 2> axes{axis, Vec2f(-axis.y(), axis.x())};
    const std::array<float, 2> beyond{std::abs(sphere.offset.dot(axes[0])) - sphere.radius,
                                      std::abs(sphere.offset.dot(axes[1])) - sphere.radius};
    if (!(beyond[0] > 0.0f) && !(beyond[1] > 0.0f)) {
        return true;
    }
    const float isotropic_near =
        frobenius_squared(near) * m_inverse_anisotropy_squared + widening * widening;
    const float isotropic_far =
        frobenius_squared(far) * m_inverse_anisotropy_squared + widening * widening;
    const Vec3f m_near = second_moments(near);
    const Vec3f m_far = second_moments(far);
    for (std::size_t i = 0; i < axes.size(); ++i) {
        if (!(beyond[i] > 0.0f)) {
            continue;
        }
        const Vec2f& e = axes[i];
        const float ee = e.x() * e.x();
        const float ef = 2.0f * e.x() * e.y();
        const float ff = e.y() * e.y();
        const float along_near = ee * m_near.x() + ef * m_near.y() + ff * m_near.z();
        const float along_far = ee * m_far.x() + ef * m_far.y() + ff * m_far.z();
        const float reach_squared = kPointWeightClipExponent * std::max(along_near + isotropic_near,
                                                                        along_far + isotropic_far);
        if (beyond[i] * beyond[i] > reach_squared) {
            return false;
        }
    }
    return true;
}

bool ConeSphereTest::may_touch(const SphereInRayFrame& sphere, float widening, float t_min,
                               float t_max) const {
    if (!circle_may_touch(sphere, widening, t_min, t_max)) {
        return false;
    }
    // Principal axes of the far footprint: any orthonormal pair would be conservative, these
    // make the rectangle hug an anisotropic ellipse.
    const float far = std::min(sphere.t + sphere.radius, t_max);
    return rectangle_may_touch(sphere, widening, t_min, t_max, m_cone.ellipse(far).major_axis);
}

bool cone_may_touch_sphere(const SphereInRayFrame& sphere, const FootprintCone& cone,
                           float max_anisotropy, float widening, float t_min, float t_max) {
    return ConeSphereTest(cone, max_anisotropy).may_touch(sphere, widening, t_min, t_max);
}

}  // namespace mrt
