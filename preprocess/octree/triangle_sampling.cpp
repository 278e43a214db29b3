#include "preprocess/octree/triangle_sampling.h"

#include "common/math/random.h"

#include <cmath>

namespace mrt {

namespace {

// The R2 sequence (Roberts 2018): frac(i·α) with α = (1/φ₂, 1/φ₂²), φ₂ the plastic number,
// the 2D Kronecker sequence with the best known separation of its points.
constexpr double kAlpha1 = 0.7548776662466927;
constexpr double kAlpha2 = 0.5698402909980532;

double fraction(double x) {
    return x - std::floor(x);
}

}  // namespace

std::uint64_t triangle_sample_key(std::uint64_t seed, std::uint32_t triangle, int level) {
    return mix64(seed ^ mix64(static_cast<std::uint64_t>(triangle) + 1) ^
                 mix64(0x9e3779b97f4a7c15ULL * (static_cast<std::uint64_t>(level) + 1)));
}

Vec2f triangle_sample(std::uint32_t index, std::uint64_t key, TriangleSampling scheme) {
    double u = 0.0;
    double v = 0.0;
    if (scheme == TriangleSampling::Random) {
        // A stream per (key, index): sample i does not depend on how many were drawn before.
        SampleRng rng(key, 0, 0, index);
        u = rng.uniform();
        v = rng.uniform();
    } else {
        const double shift_u = static_cast<double>(key >> 40) * 0x1.0p-24;
        const double shift_v = static_cast<double>((key >> 16) & 0xffffff) * 0x1.0p-24;
        u = fraction(shift_u + kAlpha1 * index);
        v = fraction(shift_v + kAlpha2 * index);
    }
    // Square to triangle, area-preserving: b1 + b2 ≤ 1 with density constant in area. Both
    // schemes share it, so they differ only in how the square is filled.
    const double s = std::sqrt(u);
    return {static_cast<float>(s * (1.0 - v)), static_cast<float>(s * v)};
}

}  // namespace mrt
