#include "preprocess/octree/normal_gradient.h"

#include "common/math/quantization.h"

#include <ostream>
#include <vector>

namespace mrt {

namespace {

bool usable(const NormalSample& s) {
    return s.position.allFinite() && s.normal.allFinite() && std::isfinite(s.weight) &&
           s.weight > 0.0f;
}

/// The direction the average normal is taken from: Σ w·n over usable samples; if there is no
/// weight at all, Σ n over the samples with a finite normal (zero if there is none).
Vec3d summed_normal(std::span<const NormalSample> samples, double& total_weight) {
    Vec3d weighted = Vec3d::Zero();
    Vec3d unweighted = Vec3d::Zero();
    total_weight = 0.0;
    for (const NormalSample& s : samples) {
        if (usable(s)) {
            weighted += static_cast<double>(s.weight) * s.normal.cast<double>();
            total_weight += static_cast<double>(s.weight);
        }
        if (s.normal.allFinite()) {
            unweighted += s.normal.cast<double>();
        }
    }
    return total_weight > 0.0 ? weighted : unweighted;
}

/// One sample in the fit's coordinates: tangent-plane position x = (u, v), deviation d.
struct Projected {
    Vec2d x;
    Vec2d d;
    double weight;
};

}  // namespace

NormalGradientFit fit_normal_gradient(const Vec3f& representative,
                                      std::span<const NormalSample> samples,
                                      float min_normal_cosine) {
    NormalGradientFit fit;
    double total_weight = 0.0;
    const Vec3d sum = summed_normal(samples, total_weight);
    // encode_normal maps a zero or non-finite sum to +z; the round trip puts n̄ on the grid the
    // tracer reads, so that canonical_tangent() gives the same frame on both sides.
    fit.normal = decode_normal(encode_normal(sum.normalized().cast<float>()));
    fit.tangent_u = canonical_tangent(fit.normal);
    fit.tangent_v = canonical_bitangent(fit.normal);
    if (!(total_weight > 0.0)) {
        return fit;
    }

    const Vec3d n = fit.normal.cast<double>();
    const Vec3d tu = fit.tangent_u.cast<double>();
    const Vec3d tv = fit.tangent_v.cast<double>();
    const Vec3d c = representative.cast<double>();

    // Pass 1: project, and the weighted means of x and d. Everything in double: the sums run
    // over hundreds of samples and the centred second moments below subtract nearly equal terms.
    std::vector<Projected> projected;
    projected.reserve(samples.size());
    double weight_sum = 0.0;
    Vec2d x_mean = Vec2d::Zero();
    Vec2d d_mean = Vec2d::Zero();
    for (const NormalSample& s : samples) {
        if (!usable(s)) {
            continue;
        }
        const Vec3d normal = s.normal.cast<double>();
        const double cosine = normal.dot(n);
        if (!(cosine > static_cast<double>(min_normal_cosine))) {
            continue;  // faces away from n̄ (or is not a direction at all)
        }
        const Vec3d offset = s.position.cast<double>() - c;
        Projected p{Vec2d(offset.dot(tu), offset.dot(tv)),
                    Vec2d(normal.dot(tu) / cosine, normal.dot(tv) / cosine),
                    static_cast<double>(s.weight)};
        weight_sum += p.weight;
        x_mean += p.weight * p.x;
        d_mean += p.weight * p.d;
        projected.push_back(p);
    }
    if (!(weight_sum > 0.0)) {
        return fit;
    }
    x_mean /= weight_sum;
    d_mean /= weight_sum;

    // Pass 2: centred second moments. With centred positions the 3×3 normal equations of
    // d ≈ d0 + G·x decouple into d0 = d̄ − G·x̄ and the 2×2 system M·Gᵀ = B, whose matrix M is
    // the weighted covariance of the positions: solving it in closed form is stable once its
    // condition number is known to be moderate, which the spread test below ensures.
    Eigen::Matrix2d m = Eigen::Matrix2d::Zero();
    Eigen::Matrix2d b = Eigen::Matrix2d::Zero();  // b(j, i) = Σ w·x'_j·d'_i
    for (const Projected& p : projected) {
        const Vec2d x = p.x - x_mean;
        const Vec2d d = p.d - d_mean;
        m += p.weight * (x * x.transpose());
        b += p.weight * (x * d.transpose());
    }
    const double m00 = m(0, 0);
    const double m11 = m(1, 1);
    const double m01 = m(0, 1);
    // Eigenvalues of the symmetric M: the larger one by the usual formula (no cancellation),
    // the smaller one as det/λ_max (the difference formula would cancel for thin spreads).
    const double half_trace = 0.5 * (m00 + m11);
    const double half_gap = std::hypot(0.5 * (m00 - m11), m01);
    const double lambda_max = half_trace + half_gap;
    const double det = m00 * m11 - m01 * m01;
    if (!(lambda_max > 0.0) || !(det > kMinPositionSpreadRatioSquared * lambda_max * lambda_max)) {
        return fit;  // the used samples are (nearly) collinear or coincide: no second direction
    }
    Eigen::Matrix2d m_inverse;
    m_inverse << m11, -m01, -m01, m00;
    m_inverse /= det;
    const Eigen::Matrix2d gradient = (m_inverse * b).transpose();
    const Vec2d offset = d_mean - gradient * x_mean;
    if (!gradient.allFinite() || !offset.allFinite()) {
        return fit;
    }
    fit.gradient = gradient.cast<float>();
    fit.offset = offset.cast<float>();
    // A double finite beyond float range would become Inf; the hierarchy stores halves and
    // saturates anyway, but the fit itself promises finite values.
    if (!fit.gradient.allFinite() || !fit.offset.allFinite()) {
        fit.gradient.setZero();
        fit.offset.setZero();
        return fit;
    }
    fit.fitted = true;
    return fit;
}

std::ostream& operator<<(std::ostream& os, const NormalSample& s) {
    const Eigen::IOFormat fmt(Eigen::StreamPrecision, Eigen::DontAlignCols, ", ", ", ", "", "", "(",
                              ")");
    return os << "NormalSample{position " << s.position.format(fmt) << ", normal "
              << s.normal.format(fmt) << ", weight " << s.weight << "}";
}

std::ostream& operator<<(std::ostream& os, const NormalGradientFit& fit) {
    const Eigen::IOFormat fmt(Eigen::StreamPrecision, Eigen::DontAlignCols, ", ", ", ", "", "", "(",
                              ")");
    const Eigen::IOFormat matrix(Eigen::StreamPrecision, Eigen::DontAlignCols, ", ", "; ", "", "",
                                 "[", "]");
    return os << "NormalGradientFit{normal " << fit.normal.format(fmt) << ", tangent_u "
              << fit.tangent_u.format(fmt) << ", tangent_v " << fit.tangent_v.format(fmt)
              << ", gradient " << fit.gradient.format(matrix) << ", offset "
              << fit.offset.format(fmt) << ", fitted " << (fit.fitted ? "true" : "false") << "}";
}

}  // namespace mrt
