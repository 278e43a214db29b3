#pragma once
// Warps of uniform [0,1)² samples onto the domains the tracers sample (lens, area lights).

#include "common/math.h"

#include <cstdint>

namespace mrt {

/// Concentric mapping of [0,1)² onto the unit disc (Shirley & Chiu 1997): area-preserving and
/// low distortion, so stratified samples stay stratified.
Vec2f concentric_disc(float u, float v);

/// Two independent standard normal variates from (u, v) ∈ [0,1)² (Box–Muller). u = 0 is
/// mapped to the open interval so the logarithm stays finite.
Vec2f standard_normal_pair(float u, float v);

/// Direction around the unit `axis` whose offset in the plane at distance 1 along the axis
/// (tan θ · (cos φ, sin φ) in any orthonormal frame of the axis) is an isotropic 2D Gaussian of
/// standard deviation `sigma`. This is how material roughness spreads reflected and refracted
/// rays, the same Gaussian the ray cones widen by, so stochastic and cone tracers agree.
Vec3f gaussian_spread_direction(const Vec3f& axis, float sigma, float u, float v);

/// Position in [0,1)² of sample `index` of `count` in pixel (x, y): the pixel centre for one
/// sample, a jittered grid when count is a square, otherwise jittered N-rooks (every x and every
/// y stratum of width 1/count used once, y strata permuted per pixel). Deterministic in
/// (seed, x, y, index) and O(1) per sample.
Vec2f pixel_sample(std::uint64_t seed, int x, int y, int index, int count);

}  // namespace mrt
