#include "common/sampling.h"

#include <cmath>

namespace mrt {

Vec2f concentric_disc(float u, float v) {
    const float a = 2.0f * u - 1.0f;
    const float b = 2.0f * v - 1.0f;
    if (a == 0.0f && b == 0.0f) {
        return Vec2f::Zero();
    }
    float r;
    float phi;
    if (std::abs(a) > std::abs(b)) {
        r = a;
        phi = (kPi / 4.0f) * (b / a);
    } else {
        r = b;
        phi = (kPi / 2.0f) - (kPi / 4.0f) * (a / b);
    }
    return {r * std::cos(phi), r * std::sin(phi)};
}

Vec2f standard_normal_pair(float u, float v) {
    // 1 − u lies in (0, 1], so the logarithm is finite and the radius real.
    const float radius = std::sqrt(-2.0f * std::log(1.0f - u));
    const float angle = 2.0f * kPi * v;
    return {radius * std::cos(angle), radius * std::sin(angle)};
}

Vec3f gaussian_spread_direction(const Vec3f& axis, float sigma, float u, float v) {
    if (!(sigma > 0.0f)) {
        return axis;
    }
    Vec3f t;
    Vec3f b;
    orthonormal_basis(axis, t, b);
    const Vec2f g = sigma * standard_normal_pair(u, v);
    return (axis + g.x() * t + g.y() * b).normalized();
}

}  // namespace mrt
