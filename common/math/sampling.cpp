#include "common/math/sampling.h"

#include "common/math/random.h"

#include <algorithm>
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

Vec2f stratified_sample(std::uint64_t seed, int x, int y, int index, int count) {
    SampleRng rng(seed, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y),
                  static_cast<std::uint32_t>(index));
    const float jitter_x = rng.uniform();
    const float jitter_y = rng.uniform();
    if (count <= 1) {
        return {jitter_x, jitter_y};
    }
    // The largest float below 1: (count − 1 + jitter)/count may round up to 1 in float.
    constexpr float kBelowOne = 0x1.fffffep-1f;
    const int side = static_cast<int>(std::lround(std::sqrt(static_cast<double>(count))));
    if (side * side == count) {
        const auto s = static_cast<float>(side);
        return {std::min((static_cast<float>(index % side) + jitter_x) / s, kBelowOne),
                std::min((static_cast<float>(index / side) + jitter_y) / s, kBelowOne)};
    }
    const auto pixel_key = static_cast<std::uint32_t>(
        mix64(seed ^ mix64((static_cast<std::uint64_t>(static_cast<std::uint32_t>(x)) << 32) ^
                           static_cast<std::uint32_t>(y))));
    const std::uint32_t y_stratum = permute_index(static_cast<std::uint32_t>(index),
                                                  static_cast<std::uint32_t>(count), pixel_key);
    const float n = static_cast<float>(count);
    return {std::min((static_cast<float>(index) + jitter_x) / n, kBelowOne),
            std::min((static_cast<float>(y_stratum) + jitter_y) / n, kBelowOne)};
}

Vec2f pixel_sample(std::uint64_t seed, int x, int y, int index, int count) {
    if (count <= 1) {
        return {0.5f, 0.5f};
    }
    return stratified_sample(seed, x, y, index, count);
}

StratifiedSampler::StratifiedSampler(std::uint64_t seed, int x, int y, int index, int count)
    : m_seed(seed), m_x(x), m_y(y), m_index(index), m_count(std::max(1, count)) {}

Vec2f StratifiedSampler::next_2d() {
    const std::uint64_t pair = m_pair++;
    if (pair == 0) {
        return stratified_sample(m_seed, m_x, m_y, m_index, m_count);
    }
    // Each later pair reorders the batch by its own permutation, so that the strata of
    // different pairs are uncorrelated (a sample in the left of the pixel is not always in the
    // left of the lens as well).
    const std::uint64_t pair_seed = mix64(m_seed + 0x9e3779b97f4a7c15ULL * pair);
    const auto key = static_cast<std::uint32_t>(
        mix64(pair_seed ^
              mix64((static_cast<std::uint64_t>(static_cast<std::uint32_t>(m_x)) << 32) ^
                    static_cast<std::uint32_t>(m_y))) >>
        32);
    const std::uint32_t permuted = permute_index(static_cast<std::uint32_t>(m_index),
                                                 static_cast<std::uint32_t>(m_count), key);
    return stratified_sample(pair_seed, m_x, m_y, static_cast<int>(permuted), m_count);
}

}  // namespace mrt
