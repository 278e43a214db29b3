#pragma once
// The differential surface properties of a representative point (Wand & Straßer 2003, §3.2,
// their Figure 2): the average normal of the surface samples around it and the derivative of the
// normal along two orthogonal tangent directions, fitted by weighted least squares to the
// samples' normal deviations. The tracer uses the gradient to widen or focus reflected and
// refracted ray cones (their §4.2, "incrDev").
//
// Conventions. Positions and normals are in one (object) space. The frame (t_u, t_v, n̄) is
// right-handed and orthonormal. A sample's normal deviation is measured, as in the paper, on the
// plane parallel to the tangent plane at distance one along n̄: d = n/(n·n̄) − n̄, which has no
// n̄ component and is stored as (d·t_u, d·t_v). The gradient G maps a tangent-plane offset
// (u, v) (length units) to the change of d (dimensionless), so its entries are in 1/length:
// column 0 is ∂d/∂u, column 1 is ∂d/∂v. For a convex surface (curving away from its normal) G is
// positive: a sphere of radius r with outward normals has G = I/r, since there dn = dp/r.

#include "common/math/math.h"

#include <cmath>
#include <iosfwd>
#include <span>

namespace mrt {

/// One surface sample near a representative point.
struct NormalSample {
    Vec3f position = Vec3f::Zero();  ///< Object space.
    Vec3f normal = Vec3f::UnitZ();   ///< Unit shading normal, object space.
    float weight = 1.0f;             ///< ≥ 0; non-positive or non-finite weights drop the sample.
};

/// Wand & Straßer's prefilter weight of a sample at `distance` from the representative point:
/// a Gaussian with standard deviation `sigma` (they use one voxel side), 1 at distance 0.
inline float gaussian_sample_weight(float distance, float sigma) {
    const float x = distance / sigma;
    return std::exp(-0.5f * x * x);
}

/// The result of fit_normal_gradient().
struct NormalGradientFit {
    /// n̄, object space, unit: the weighted average normal, quantized (encode_normal, then
    /// decode_normal) so that the frame below is bit for bit the one the tracer rebuilds from the
    /// hierarchy file; the quantization moves it by at most kNormalMaxAngularError (4.35e-5 rad).
    Vec3f normal = Vec3f::UnitZ();
    /// t_u = canonical_tangent(n̄), object space, unit. The frame is always the canonical one,
    /// so the stored orientation angle (encode_tangent_angle) is always 0: a rotated frame
    /// would not make the fit better conditioned, because G transforms as Q·G·Qᵀ under a
    /// rotation Q of the frame and keeps its singular values.
    Vec3f tangent_u = Vec3f::UnitX();
    /// t_v = n̄ × t_u, object space, unit.
    Vec3f tangent_v = Vec3f::UnitY();
    /// G, 1/length units, in (t_u, t_v) components: columns ∂d/∂u and ∂d/∂v. Zero unless fitted.
    Mat2f gradient = Mat2f::Zero();
    /// False when the samples did not determine a gradient (no usable sample, zero total
    /// weight, or the used samples' tangent-plane positions do not span two dimensions); then
    /// gradient and offset are zero.
    bool fitted = false;
    /// d0, dimensionless, in (t_u, t_v) components: the fitted deviation at (u, v) = 0, the
    /// representative point itself. Zero unless fitted.
    Vec2f offset = Vec2f::Zero();
};

/// Samples whose normal makes an angle of more than arccos(this) ≈ 89.4° with n̄ face away and
/// are left out of the gradient fit: their deviation tan θ > 100 would dominate it.
inline constexpr float kMinNormalCosine = 1e-2f;

/// Used tangent-plane positions whose weighted covariance has a smaller eigenvalue below this
/// fraction of the larger one (a spread ratio below 10⁻³) count as collinear: no fit.
inline constexpr double kMinPositionSpreadRatioSquared = 1e-6;

/// Fits the normal gradient at the representative point `representative` (object space) from
/// `samples` (Wand & Straßer §3.2):
///  1. n̄ = the weight-averaged sample normal (unweighted if every weight is zero; +z if the
///     normals cancel), quantized as documented on NormalGradientFit::normal;
///  2. the canonical frame (t_u, t_v) of n̄;
///  3. per sample with n·n̄ > min_normal_cosine: (u, v) = ((p − c)·t_u, (p − c)·t_v) and
///     d = (n·t_u, n·t_v)/(n·n̄);
///  4. the weighted least-squares fit d ≈ d0 + G·(u, v).
/// Samples with a non-finite position, normal or weight are ignored. Never returns NaN.
NormalGradientFit fit_normal_gradient(const Vec3f& representative,
                                      std::span<const NormalSample> samples,
                                      float min_normal_cosine = kMinNormalCosine);

std::ostream& operator<<(std::ostream& os, const NormalSample& s);
std::ostream& operator<<(std::ostream& os, const NormalGradientFit& fit);

}  // namespace mrt
