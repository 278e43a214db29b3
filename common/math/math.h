#pragma once
// Small fixed-size linear algebra for the whole project: Eigen types under short names, and the
// handful of numerically delicate scalar helpers every module needs.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>
#include <cstdint>
#include <limits>

namespace mrt {

using Vec2f = Eigen::Vector2f;
using Vec3f = Eigen::Vector3f;
using Vec4f = Eigen::Vector4f;
using Vec2d = Eigen::Vector2d;
using Vec3d = Eigen::Vector3d;
using Vec2i = Eigen::Vector2i;
using Vec3i = Eigen::Vector3i;
using Mat2f = Eigen::Matrix2f;
using Mat3f = Eigen::Matrix3f;
using Mat32f = Eigen::Matrix<float, 3, 2>;
using Mat4f = Eigen::Matrix4f;
/// Affine object-to-parent transform (rotation/scale/shear plus translation).
using Affine3f = Eigen::Transform<float, 3, Eigen::Affine, Eigen::DontAlign>;
/// Affine transform of texture coordinates (scale, rotation, offset).
using Affine2f = Eigen::Transform<float, 2, Eigen::Affine, Eigen::DontAlign>;
/// Linear RGB radiometric quantity; component-wise arithmetic.
using Rgb = Eigen::Array3f;

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInfinity = std::numeric_limits<float>::infinity();

/// a·b − c·d without catastrophic cancellation (Kahan's FMA trick): the error is at most 1.5 ulp
/// even when the two products nearly cancel, as in 2×2 determinants of nearly parallel vectors.
inline float difference_of_products(float a, float b, float c, float d) {
    const float cd = c * d;
    const float err = std::fma(-c, d, cd);
    const float dop = std::fma(a, b, -cd);
    return dop + err;
}

/// True when every component is finite (no NaN, no Inf).
template <typename Derived>
inline bool all_finite(const Eigen::DenseBase<Derived>& v) {
    return v.allFinite();
}

/// Builds an orthonormal basis (t, b) around a unit vector n without a branch-induced
/// discontinuity larger than needed (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
inline void orthonormal_basis(const Vec3f& n, Vec3f& t, Vec3f& b) {
    const float sign = std::copysign(1.0f, n.z());
    const float a = -1.0f / (sign + n.z());
    const float bb = n.x() * n.y() * a;
    t = Vec3f(1.0f + sign * n.x() * n.x() * a, sign * bb, -sign * n.x());
    b = Vec3f(bb, sign + n.y() * n.y() * a, -n.y());
}

/// Luminance of linear Rec.709 RGB.
inline float luminance(const Rgb& c) {
    return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
}

}  // namespace mrt
