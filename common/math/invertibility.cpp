#include "common/math/invertibility.h"

#include <algorithm>
#include <cmath>

namespace mrt {

namespace {

/// Spectral radius of a non-negative 3×3 matrix that may be scaled very unevenly (a diagonal
/// similarity D⁻¹·M·D with ratios of 1e50): general eigensolvers lose the small entries against
/// the large ones. The coefficients of the characteristic polynomial λ³ − t·λ² + c·λ − d are
/// sums of products along cycles (m_ij·m_ji, m_01·m_12·m_20, …), which such a similarity leaves
/// unchanged, so they are computed from those products. The radius (the Perron root) is the
/// polynomial's largest real root, found by Newton's method from above: from Fujiwara's bound
/// it decreases monotonically, because p is convex right of t/3 and the root is at least t/3
/// (the trace is the sum of three eigenvalues whose real parts are at most the radius). At a
/// multiple root (1 for any scaled permutation) rounding limits it to about 1e-5, plenty for a
/// threshold of 2^22.
double perron_root(const Eigen::Matrix3d& m) {
    const double t = m.trace();
    const double c = m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0) + m(0, 0) * m(2, 2) - m(0, 2) * m(2, 0) +
                     m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1);
    const double d = m(0, 0) * m(1, 1) * m(2, 2) + m(0, 1) * m(1, 2) * m(2, 0) +
                     m(0, 2) * m(1, 0) * m(2, 1) - m(0, 0) * m(1, 2) * m(2, 1) -
                     m(0, 1) * m(1, 0) * m(2, 2) - m(0, 2) * m(1, 1) * m(2, 0);
    double lambda = 2.0 * std::max({std::abs(t), std::sqrt(std::abs(c)), std::cbrt(std::abs(d))});
    constexpr int kMaxIterations = 200;
    for (int i = 0; i < kMaxIterations; ++i) {
        const double p = ((lambda - t) * lambda + c) * lambda - d;
        const double slope = (3.0 * lambda - 2.0 * t) * lambda + c;
        if (!(p > 0.0) || !(slope > 0.0)) {
            break;
        }
        const double next = lambda - p / slope;
        if (!(next < lambda)) {
            break;
        }
        lambda = next;
    }
    return lambda;
}

bool well_conditioned_in_float(const Eigen::Matrix3d& m) {
    const Eigen::Matrix3d rounded = m.cast<float>().cast<double>();
    return scaling_invariant_condition(rounded) <= kMaxScalingInvariantCondition;
}

}  // namespace

double scaling_invariant_condition(const Eigen::Matrix3d& a) {
    if (!all_finite(a)) {
        return kInfinity;
    }
    // Entries of float range give products of three within double range (at most 4e115, at
    // least 1e-135), so the determinant and the cofactors neither overflow nor underflow here.
    const double det = a.determinant();
    if (det == 0.0 || !std::isfinite(det)) {
        return kInfinity;
    }
    const Eigen::Matrix3d inverse = a.inverse();
    if (!all_finite(inverse)) {
        return kInfinity;
    }
    const double radius = perron_root(inverse.cwiseAbs() * a.cwiseAbs());
    return std::isfinite(radius) ? radius : kInfinity;
}

bool invertible_in_single_precision(const Eigen::Matrix3d& linear) {
    if (!well_conditioned_in_float(linear)) {
        return false;
    }
    return well_conditioned_in_float(linear.cast<float>().cast<double>().inverse());
}

Mat3f inverse_in_double(const Mat3f& linear) {
    return linear.cast<double>().inverse().cast<float>();
}

Affine3f inverse_in_double(const Affine3f& transform) {
    const Eigen::Matrix3d inverse = transform.linear().cast<double>().inverse();
    Affine3f result = Affine3f::Identity();
    result.linear() = inverse.cast<float>();
    result.translation() = (-(inverse * transform.translation().cast<double>())).cast<float>();
    return result;
}

}  // namespace mrt
