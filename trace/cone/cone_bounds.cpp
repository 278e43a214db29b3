#include "trace/cone/cone_bounds.h"

#include "common/footprint/point_weight.h"

#include <algorithm>
#include <cmath>

namespace mrt {

namespace {

/// The bound on the clip ellipse's reach along e at depth t (see the header), over ρ. ‖F‖₂²
/// is bounded by the Frobenius norm ‖F‖_F² (at most twice it): still conservative, and no
/// eigen-decomposition per end — the test runs for every node a cone visits.
float reach_along(const FootprintCone& cone, float t, const Vec2f& e,
                  float inverse_anisotropy_squared, float widening_squared) {
    // A blurred cone's G·Gᵀ = F·Fᵀ + B·Bᵀ: both parts are affine in t, so the bound stays
    // the norm of a vector of affine functions of t (convex), without the square root of G.
    const Mat2f f = cone.pixel_at(t);
    float along = (f.transpose() * e).squaredNorm();
    float frobenius = f.squaredNorm();
    if (cone.blurred) {
        const Mat2f b = cone.blur_start + t * cone.blur_incr;
        along += (b.transpose() * e).squaredNorm();
        frobenius += b.squaredNorm();
    }
    return std::sqrt(along + frobenius * inverse_anisotropy_squared + widening_squared);
}

}  // namespace

namespace {

/// The sphere's depths within [t_min, t_max], or false when the input is not finite (then the
/// tests answer true).
bool finite_input(const SphereInRayFrame& sphere, const FootprintCone& cone, float max_anisotropy,
                  float widening, float t_min, float t_max, float& near, float& far) {
    near = std::max(sphere.t - sphere.radius, t_min);
    far = std::min(sphere.t + sphere.radius, t_max);
    return std::isfinite(near) && std::isfinite(far) && sphere.offset.allFinite() &&
           cone.start_dev.allFinite() && cone.incr_dev.allFinite() && cone.blur_start.allFinite() &&
           cone.blur_incr.allFinite() && std::isfinite(widening) && max_anisotropy >= 1.0f;
}

}  // namespace

bool cone_circle_may_touch_sphere(const SphereInRayFrame& sphere, const FootprintCone& cone,
                                  float max_anisotropy, float widening, float t_min, float t_max) {
    float near = 0.0f;
    float far = 0.0f;
    if (!finite_input(sphere, cone, max_anisotropy, widening, t_min, t_max, near, far)) {
        return true;
    }
    if (near > far) {
        return false;  // wholly before t_min or after t_max
    }
    const float rho = std::sqrt(kPointWeightClipExponent);
    const float inverse_anisotropy_squared = 1.0f / (max_anisotropy * max_anisotropy);
    const float widening_squared = widening * widening;
    // |Fᵀe| ≤ ‖F‖_F along every e, so the ellipse's reach is at most
    // ρ·√(‖F‖_F²·(1 + 1/A²) + w²). Most spheres a cone is tested against are its node's
    // siblings well off the axis; they fall here without a decomposition.
    const auto circle = [&](float t) {
        const Mat2f f = cone.pixel_at(t);
        float frobenius = f.squaredNorm();
        if (cone.blurred) {
            frobenius += (cone.blur_start + t * cone.blur_incr).squaredNorm();
        }
        return frobenius * (1.0f + inverse_anisotropy_squared) + widening_squared;
    };
    const float circle_reach = rho * std::sqrt(std::max(circle(near), circle(far))) + sphere.radius;
    return !(sphere.offset.squaredNorm() > circle_reach * circle_reach);
}

bool cone_rectangle_may_touch_sphere(const SphereInRayFrame& sphere, const FootprintCone& cone,
                                     float max_anisotropy, float widening, float t_min, float t_max,
                                     const Vec2f& axis) {
    float near = 0.0f;
    float far = 0.0f;
    if (!finite_input(sphere, cone, max_anisotropy, widening, t_min, t_max, near, far) ||
        !axis.allFinite()) {
        return true;
    }
    if (near > far) {
        return false;
    }
    const float rho = std::sqrt(kPointWeightClipExponent);
    const float inverse_anisotropy_squared = 1.0f / (max_anisotropy * max_anisotropy);
    const float widening_squared = widening * widening;
    const Vec2f perpendicular(-axis.y(), axis.x());
    for (const Vec2f& e : {axis, perpendicular}) {
        const float reach =
            rho * std::max(reach_along(cone, near, e, inverse_anisotropy_squared, widening_squared),
                           reach_along(cone, far, e, inverse_anisotropy_squared, widening_squared));
        if (std::abs(sphere.offset.dot(e)) > reach + sphere.radius) {
            return false;
        }
    }
    return true;
}

bool cone_may_touch_sphere(const SphereInRayFrame& sphere, const FootprintCone& cone,
                           float max_anisotropy, float widening, float t_min, float t_max) {
    if (!cone_circle_may_touch_sphere(sphere, cone, max_anisotropy, widening, t_min, t_max)) {
        return false;
    }
    // Principal axes of the far footprint: any orthonormal pair would be conservative, these
    // make the rectangle hug an anisotropic ellipse.
    const float far = std::min(sphere.t + sphere.radius, t_max);
    return cone_rectangle_may_touch_sphere(sphere, cone, max_anisotropy, widening, t_min, t_max,
                                           cone.ellipse(far).major_axis);
}

}  // namespace mrt
