#pragma once
// Whether a transform's linear part can be inverted in single precision, decided without regard
// to its scale. A determinant compared with a fixed (or magnitude-relative) threshold refuses
// exact uniform scales of 1e13 (det 1e39 overflows a float) or 1e-30 (det 1e-90 underflows),
// and a non-uniform scale such as [1e30, 1, 1], although each has an exact, representable
// inverse. The measure used instead is Bauer's scaling-invariant condition number
// ρ(|A⁻¹|·|A|) (spectral radius of the product of the entrywise absolute values), unchanged when
// rows or columns are scaled, which is exactly the freedom of scale that must not matter.
// Its reciprocal bounds the componentwise relative distance to the nearest singular matrix
// (Demmel, "The componentwise distance to the nearest singular matrix", 1992): if no entry
// moves by more than a fraction 1/ρ of itself, the matrix stays invertible.

#include "common/math/math.h"

namespace mrt {

/// Largest scaling-invariant condition number accepted: rounding each entry to float (relative
/// error 2^-24) moves it at most 1/4 of the way to the nearest singular matrix.
inline constexpr double kMaxScalingInvariantCondition = 4194304.0;  // 2^22

/// ρ(|A⁻¹|·|A|), computed in double (1 for any scaled permutation, 3 or less for a rotation);
/// infinity when `a` is singular or not finite.
double scaling_invariant_condition(const Eigen::Matrix3d& a);

/// True when `linear`, rounded to float, has finite entries, a scaling-invariant condition
/// number of at most kMaxScalingInvariantCondition, and an inverse whose entries, rounded to
/// float, are finite and again so conditioned (so that it neither overflows nor underflows).
bool invertible_in_single_precision(const Eigen::Matrix3d& linear);

/// The inverse computed in double and rounded once. In float arithmetic the determinant of a
/// uniform scale of 1e13 overflows (and Eigen's inverse comes out zero) and that of 1e-30
/// underflows (NaN); here every transform the loader accepts has its exact, representable
/// inverse.
Mat3f inverse_in_double(const Mat3f& linear);
Affine3f inverse_in_double(const Affine3f& transform);

}  // namespace mrt
