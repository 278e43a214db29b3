#include "common/sampling.h"

#include "common/random.h"

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

Vec2f pixel_sample(std::uint64_t seed, int x, int y, int index, int count) {
    if (count <= 1) {
        return {0.5f, 0.5f};
    }
    SampleRng rng(seed, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y),
                  static_cast<std::uint32_t>(index));
    const float jitter_x = rng.uniform();
    const float jitter_y = rng.uniform();
    const int side = static_cast<int>(std::lround(std::sqrt(static_cast<double>(count))));
    if (side * side == count) {
        return {(static_cast<float>(index % side) + jitter_x) / static_cast<float>(side),
                (static_cast<float>(index / side) + jitter_y) / static_cast<float>(side)};
    }
    const auto pixel_key = static_cast<std::uint32_t>(
        mix64(seed ^ mix64((static_cast<std::uint64_t>(static_cast<std::uint32_t>(x)) << 32) ^
                           static_cast<std::uint32_t>(y))));
    const std::uint32_t y_stratum = permute_index(static_cast<std::uint32_t>(index),
                                                  static_cast<std::uint32_t>(count), pixel_key);
    const float n = static_cast<float>(count);
    return {(static_cast<float>(index) + jitter_x) / n,
            (static_cast<float>(y_stratum) + jitter_y) / n};
}

}  // namespace mrt
