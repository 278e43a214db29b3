#pragma once
// The weight a ray cone gives a surface point (Wand & Straßer §4.3), chosen so that the
// compositing of §4.4 can do what it says: "The point hierarchy is constructed to guarantee
// that any fragment in the interior of any surface has at least a weight of one. Therefore, we
// can interpret weight sums of less than one as alpha values". The bare Gaussian of eq. 2,
// exp(−|F⁻¹x|²), cannot keep that promise: summed over points of spacing h on a surface whose
// normal makes the angle θ with the ray it grows as π·|det F|/(h²·cos θ) — π/4 at the selection
// threshold of §5.1 (h = the footprint's minimum diameter) and normal incidence, 50 measured for
// footprints of 3 h — and at the threshold it swings by ±17 % per axis with the lattice's offset.
//
// Quadrature. The Gaussian integrates to π·|det F| over the ray's u/v plane. A surface crossing
// the cone covers the plane with the projected area element |n·d|·dA, so with points standing
// for areas A_i at offsets x_i
//
//     Σ_i exp(−|F⁻¹x_i|²) · A_i·|n_i·d| / (π·|det F|)  ≈  1 in a surface's interior,
//                                                          ½ on a straight boundary through
//                                                            the cone's axis, 0 outside —
//
// the alpha ramp, whatever the footprint's size, anisotropy and orientation and the incidence.
// A_i = coverage_i·h², the octree's coverage being the surface area a point stands for relative
// to a voxel face (preprocess/octree/point_octree.h). The two cosines of grazing incidence
// (projected area, projected density) cancel analytically: the weight is multiplied by |n·d|, never
// divided by it, so it goes to 0 smoothly and a point seen edge-on weighs nothing.
//
// Widening. At the threshold F's semi-axes are h/2 and its Gaussian has σ = h/(2√2); sampled at
// spacing h, Poisson summation gives a ripple of 2·exp(−2π²σ²/h²) = 17 % per axis. A point
// stands for the surface around its voxel centre, not for the centre itself, so the weight uses
// the ray's Gaussian convolved with the point's own kernel exp(−|x|²/(β·h)²) — squared
// footprints add (Wand §4.2; Zwicker et al.'s EWA resampling filter): G·Gᵀ = F·Fᵀ + (β·h)²·I.
// β = ½, about the voxel's own extent (a uniform ±h/2 has the second moment of r = 0.41·h),
// raises σ to at least h/2 and the ripple to 1.4 % per axis, for a blur small beside the
// prefilter's own σ = h (√(1 + 1/8 + 1/8) against √(1 + 1/8) at the threshold). It also bounds
// |det G| ≥ (β·h)² from below: no division by a vanishing determinant, even at a cone's apex.
// A larger β only smooths the stored data's own errors (below) at 2–3× the points per ray.
//
// Clip. Gaussian factors below 2 % are dropped (§4.4, footnote 2), |G⁻¹x|² > ln 50 = 3.91,
// which removes exactly 2 % of a 2D Gaussian's mass; the scale puts it back.
//
// κ. What is left is the error of the stored data, measured in
// tests/common/footprint/point_weight_test.cpp on real octrees (planes at many orientations, a
// sphere, the Stanford bunny; docs/ point-weights.md). The octree makes both inputs of the
// quadrature right: coverage is each point's share of its samples' area (so a node's coverages add
// up to its surface's area, seams and the denser points of slanted surfaces included), and a point
// is placed on the surface, voxel centre + offset·h·normal (preprocess/octree/point_octree.h), not
// up to √3/2·h off it, where a nearly axis-aligned surface would jump by h at each voxel layer it
// crosses. The unscaled sum then ranges over [0.67, 1.38] in surface interiors (21 350 cones,
// mean 1.00; before the octree stored offsets and area shares it was [0.30, 1.74]); κ = 1.6 lifts
// the minimum to 1.07 and puts the maximum at 2.2.

#include "common/footprint/footprint.h"
#include "common/math/math.h"

#include <cmath>
#include <iosfwd>

namespace mrt {

/// Gaussian factors below this are clipped to zero (Wand §4.4, footnote 2).
inline constexpr float kPointWeightClip = 0.02f;
/// The clip as a bound on the exponent: a point weighs something when |G⁻¹x|² ≤ ln(1/0.02).
/// The clip ellipse {x : |G⁻¹x|² ≤ this} is what a node's points must be culled against.
inline constexpr float kPointWeightClipExponent = 3.91202300543f;
/// β: radius of a point's own kernel exp(−|x|²/(β·h)²), in voxel sides h.
inline constexpr float kPointKernelRadius = 0.5f;
/// κ: the factor that lifts the smallest interior weight sum measured to at least one.
inline constexpr float kPointWeightSafety = 1.6f;
/// The largest interior weight sum measured with κ, with a margin (the bound the tests hold).
/// The cost of κ: a fragment's alpha saturates once the footprint's Gaussian covers 1/κ ≈ 60 %
/// of a surface, and a silhouette's half-alpha point lies about half a standard deviation of
/// the widened footprint outside it.
inline constexpr float kPointWeightMaxInteriorSum = 2.4f;

/// What a point's weight needs from the ray and the node, computed once per (ray, node) at the
/// node's depth — a node spans a few per cent of its distance along a cone, so the footprint
/// hardly changes over it (Wand §5.2 decomposes once per box too) — or once per point from its
/// own t where the cone is near its apex (depth of field) and F changes fast.
struct PointWeightFrame {
    /// G, ray u/v units per pixel: the ray's clamped footprint widened by the points' kernel.
    /// Cull the node's points (bounding spheres, §4.6) with its clip ellipse, not with F's.
    Mat2f footprint = Mat2f::Zero();
    /// G⁻¹: an offset in the ray's u/v plane → the coordinates of the unit Gaussian.
    Mat2f inverse = Mat2f::Zero();
    /// κ·h²/(π·|det G|·(1 − clip)), dimensionless: the weight of a point of coverage 1 on the
    /// cone's axis with its normal along the ray. 0 for a degenerate frame (h = 0, non-finite).
    float scale = 0.0f;
};

std::ostream& operator<<(std::ostream& os, const PointWeightFrame& frame);

/// The frame for the points of a node of spacing h (voxel side, the units of F) seen through
/// the ray footprint F at their depth, already anisotropy-clamped as the traversal clamps it
/// (FootprintCone::clamp_anisotropy, §5.1), in ray u/v units per pixel.
PointWeightFrame point_weight_frame(const Mat2f& ray_footprint, float spacing);

/// The same from the cone at ray parameter t: F(t), clamped to `max_anisotropy`.
PointWeightFrame point_weight_frame(const FootprintCone& cone, float t, float spacing,
                                    float max_anisotropy);

/// The weight of a point at `offset_uv` from the cone's axis (its components along the ray's u
/// and v, in the units of F and h), whose unit normal n has n·d = `normal_dot_direction` with
/// the ray's unit direction d (either sign: n is a surface's, not a side's), and whose coverage
/// is `coverage` as the tracer decodes it (decode_coverage8 of the stored code). Zero outside the
/// clip, for a point seen edge-on and for a degenerate frame; NaN offsets weigh 0.
inline float point_weight(const PointWeightFrame& frame, const Vec2f& offset_uv,
                          float normal_dot_direction, float coverage);

/// The Gaussian's exponent q = |G⁻¹·offset|² of a point at `offset_uv` (point_weight's).
inline float point_weight_exponent(const Mat2f& inverse, const Vec2f& offset_uv) {
    return (inverse * offset_uv).squaredNorm();
}

/// point_weight from its exponent q, for a caller that clipped q itself.
inline float point_weight_of_exponent(const PointWeightFrame& frame, float q,
                                      float normal_dot_direction, float coverage) {
    return frame.scale * coverage * std::abs(normal_dot_direction) * std::exp(-q);
}

inline float point_weight(const PointWeightFrame& frame, const Vec2f& offset_uv,
                          float normal_dot_direction, float coverage) {
    const float q = point_weight_exponent(frame.inverse, offset_uv);
    if (!(q <= kPointWeightClipExponent)) {
        return 0.0f;
    }
    return point_weight_of_exponent(frame, q, normal_dot_direction, coverage);
}

}  // namespace mrt
