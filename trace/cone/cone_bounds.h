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

namespace mrt {

/// Whether the sphere may touch the part t ∈ [t_min, t_max] of `cone`, whose footprints are
/// clamped to `max_anisotropy` (≥ 1) and widened by `widening` (the radius of the points'
/// kernel, common/footprint/point_weight.h; 0 for none) before points are weighed: false only when
/// it cannot. Non-finite input is answered true, so a damaged value never hides geometry.
bool cone_may_touch_sphere(const SphereInRayFrame& sphere, const FootprintCone& cone,
                           float max_anisotropy, float widening, float t_min, float t_max);

/// The two steps of cone_may_touch_sphere, for a caller that decomposes the footprint at one of
/// the sphere's depths anyway (the traversal, once per node): a circle around the ellipse,
/// which needs no decomposition, then the rectangle along `axis` (unit; the footprint's major
/// axis at some depth) and its perpendicular. The sphere may touch the cone when both say so.
bool cone_circle_may_touch_sphere(const SphereInRayFrame& sphere, const FootprintCone& cone,
                                  float max_anisotropy, float widening, float t_min, float t_max);
bool cone_rectangle_may_touch_sphere(const SphereInRayFrame& sphere, const FootprintCone& cone,
                                     float max_anisotropy, float widening, float t_min, float t_max,
                                     const Vec2f& axis);

}  // namespace mrt
