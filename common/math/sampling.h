#pragma once
// Warps of uniform [0,1)² samples onto the domains the tracers sample (lens, area lights).

#include "common/math/math.h"

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

/// Sample `index` of a stratified batch of `count` in [0,1)² for pixel (x, y): a jittered grid
/// when count is a square, otherwise jittered N-rooks (every x and every y stratum of width
/// 1/count used once, y strata permuted per pixel); a uniform random point for count 1.
/// Deterministic in (seed, x, y, index) and O(1) per sample.
Vec2f stratified_sample(std::uint64_t seed, int x, int y, int index, int count);

/// Position in [0,1)² of sample `index` of `count` in pixel (x, y): the pixel centre for one
/// sample (what a conventional ray tracer shoots), otherwise stratified_sample.
Vec2f pixel_sample(std::uint64_t seed, int x, int y, int index, int count);

/// The random numbers of sample `index` of a stratified batch of `count` samples in pixel
/// (x, y), drawn as 2D pairs: the first pair is the position in the pixel, later pairs serve
/// lens, lights and glossy directions as the ray tree asks for them. Every pair is stratified
/// over the batch on its own, and the batch order is permuted per pair so that pairs are
/// uncorrelated (Cook 1986's decorrelated stratified dimensions). A batch of one sample is
/// plain uniform random numbers.
class StratifiedSampler {
  public:
    StratifiedSampler(std::uint64_t seed, int x, int y, int index, int count);

    Vec2f next_2d();

  private:
    std::uint64_t m_seed;
    int m_x;
    int m_y;
    int m_index;
    int m_count;
    std::uint64_t m_pair = 0;
};

}  // namespace mrt
