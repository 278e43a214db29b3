#pragma once
// The cone–bounding-sphere test of Wand & Straßer §4.6, conservative and elliptical: the
// traversal may skip a node only when no part of its bounding sphere can lie inside the cone's
// clip ellipse (weight ≥ 2 %, common/footprint/point_weight.h) at any depth the sphere spans. A
// circular approximation of the ellipse would make highly anisotropic cones (grazing views, the
// anisotropy clamp's 8:1) visit every node along their major axis; the test works in the
// ellipse's principal axes instead, as the paper does.
//
// Why it is conservative. Project the sphere orthogonally onto the plane of the ray's u and v
// axes: a disc of the sphere's radius r around the centre's offset x, whose points have depths
// in [t − r, t + r]. The points are weighed with the footprint F(t') = start_dev + t'·incr_dev
// clamped to the anisotropy limit A and widened by the points' kernel w (common/
// point_weight.h); that ellipse lies inside the one of F·Fᵀ + (‖F‖²/A² + w²)·I, the clamp
// raising the minor axis to ‖F‖/A at most (‖F‖ the spectral norm, bounded here by the
// Frobenius norm). Along a unit direction e of the plane the clip ellipse (ρ² = ln 50) then
// reaches at most ρ·√(|F(t')ᵀe|² + ‖F(t')‖_F²/A² + w²): the norm of a vector of affine
// functions of t', convex in t', so its largest value over the sphere's depths is at one end. For
// any orthonormal pair eᵢ the cone's cross-sections over those depths lie in the rectangle
// |x·eᵢ| ≤ hᵢ, and the disc misses it when |x·eᵢ| > hᵢ + r for an axis i (the paper's square
// around the projected sphere); the footprint's principal axes make it hug the ellipse.

#include "common/footprint/footprint.h"
#include "common/math/math.h"
#include "trace/cone/cone_ray.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mrt {

/// What the sphere tests need from one cone, prepared once per cone (and per instance space it
/// enters) instead of at every test: whether its inputs are finite, and ‖F(t)‖_F² + ‖B(t)‖_F²
/// (pixel footprint and blur) as a quadratic in t. The traversal tests a cone against tens to
/// thousands of spheres; re-checking the cone's eight matrices for every test was 40 % of a
/// test's instructions.
class ConeSphereTest {
  public:
    /// The cone's footprints are clamped to `max_anisotropy` (≥ 1) before points are weighed.
    ConeSphereTest(const FootprintCone& cone, float max_anisotropy);
    /// The test of `parent`'s cone seen through a similarity that scales lengths by `scale`
    /// (map_cone_similar: `cone`'s footprints are the parent's times scale at scale times its
    /// depths), its coefficients scaled instead of recomputed from the matrices.
    ConeSphereTest(const ConeSphereTest& parent, const FootprintCone& cone, float scale);
    /// No cone yet: every test answers true (as for damaged input) until one is assigned.
    ConeSphereTest() = default;

    /// Whether the sphere may touch the part t ∈ [t_min, t_max] of the cone, whose footprints
    /// are widened by `widening` (the radius of the points' kernel, common/footprint/
    /// point_weight.h; 0 for none) before points are weighed: false only when it cannot.
    /// Non-finite input is answered true, so a damaged value never hides geometry.
    bool may_touch(const SphereInRayFrame& sphere, float widening, float t_min, float t_max) const;

    /// The two steps of may_touch, for a caller that decomposes the footprint at one of the
    /// sphere's depths anyway (the traversal, once per node): a circle around the ellipse,
    /// which needs no decomposition, then the rectangle along `axis` (unit; the footprint's
    /// major axis at some depth) and its perpendicular. The sphere may touch the cone when both
    /// say so.
    bool circle_may_touch(const SphereInRayFrame& sphere, float widening, float t_min,
                          float t_max) const;
    bool rectangle_may_touch(const SphereInRayFrame& sphere, float widening, float t_min,
                             float t_max, const Vec2f& axis) const;

    /// Relative to the magnitude of the quadratic's terms, what the evaluation and the
    /// coefficients' own rounding can lose: a few ulps of each of half a dozen operations.
    static constexpr float kQuadraticRounding = 16.0f * std::numeric_limits<float>::epsilon();

    /// An upper bound on ‖F(t)‖_F² + ‖B(t)‖_F², from the quadratic with a margin for its
    /// rounding (the quadratic cancels where a focusing cone narrows to a point).
    float frobenius_squared(float t) const {
        const float value = m_constant + t * (m_linear + t * m_quadratic);
        const float magnitude =
            m_constant + std::abs(t) * (std::abs(m_linear) + std::abs(t) * m_quadratic);
        return std::max(0.0f, value) + kQuadraticRounding * magnitude;
    }

    /// At least the largest semi-axis √λ_max of the footprint's ellipse at depth t,
    /// FootprintCone::ellipse_of(cone.at(t)) (the pixel footprint convolved with the blur), as
    /// its decomposition rounds it; the anisotropy clamp does not change it. λ_max is at most the
    /// ellipse's trace, ‖F(t)‖_F² + ‖B(t)‖_F²: what a frame at that depth can reach, known
    /// without the footprint's root or decomposition. Meaningless unless circle().finite.
    float largest_semi_axis(float t) const {
        return std::sqrt(frobenius_squared(t)) * (1.0f + kSemiAxisRounding);
    }
    /// Relative room between the bound and the decomposition's own rounding of λ_max.
    static constexpr float kSemiAxisRounding = 1e-4f;

    /// All that circle_may_touch reads of the cone: what a kernel testing several spheres at
    /// once (children_near_cone, trace/cone/cone_block_simd.cpp) needs to answer exactly as it
    /// does, evaluating frobenius_squared and the circle in the same order.
    struct CircleCoefficients {
        /// False when the cone's input was damaged: then every sphere may touch.
        bool finite = false;
        /// frobenius_squared's quadratic in t: ‖S‖_F² + ‖B₀‖_F², 2·(⟨S, I⟩ + ⟨B₀, B₁⟩),
        /// ‖I‖_F² + ‖B₁‖_F².
        float constant = 0.0f;
        float linear = 0.0f;
        float quadratic = 0.0f;
        /// 1/A², A the anisotropy clamp.
        float inverse_anisotropy_squared = 0.0f;
    };
    CircleCoefficients circle() const {
        return {m_finite, m_constant, m_linear, m_quadratic, m_inverse_anisotropy_squared};
    }

  private:
    /// The sphere's depths within [t_min, t_max], or false when the input is not finite (then
    /// the tests answer true).
    bool depths(const SphereInRayFrame& sphere, float widening, float t_min, float t_max,
                float& near, float& far) const;
    /// F·Fᵀ + B·Bᵀ at depth t (footprint and blur) as (a, b, c) of [[a, b], [b, c]].
    Vec3f second_moments(float t) const;

    FootprintCone m_cone;
    bool m_finite = false;
    float m_inverse_anisotropy_squared = 0.0f;
    float m_constant = 0.0f;   ///< ‖S‖_F² + ‖B₀‖_F²
    float m_linear = 0.0f;     ///< 2·(⟨S, I⟩ + ⟨B₀, B₁⟩)
    float m_quadratic = 0.0f;  ///< ‖I‖_F² + ‖B₁‖_F²
};

/// ConeSphereTest(cone, max_anisotropy).may_touch(sphere, widening, t_min, t_max): for one test.
bool cone_may_touch_sphere(const SphereInRayFrame& sphere, const FootprintCone& cone,
                           float max_anisotropy, float widening, float t_min, float t_max);

}  // namespace mrt
