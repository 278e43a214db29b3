// The normal-gradient fit of Wand & Straßer §3.2 on surfaces with known curvature: spheres,
// planes, cylinders and paraboloids sampled around a representative point, checked against the
// analytic derivative of their normal; invariance under rigid motions; degenerate inputs.
//
// Tolerances. The deviation d = n/(n·n̄) − n̄ of a sphere of radius r is exactly the gnomonic
// projection u/√(r² − ρ²) (ρ the sample's distance from the axis through the representative), so
// the least-squares slope is 1/r times a weighted mean of f = 1/√(1 − ρ²/r²) ∈ [1, 1/cos θ_max]
// for samples within the angle θ_max of the representative: the tests allow (1/cos θ_max − 1)/r
// for the model's nonlinearity, plus 1e-4 relative for float input, double sums and n̄'s
// quantization (its ≤ 4.35e-5 rad tilt changes the slope by a relative O(tilt)).

#include "preprocess/octree/normal_gradient.h"
#include "common/math/quantization.h"

#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>

#include <cmath>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

namespace mrt {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

using testing::angle_between;
using testing::random_direction;

/// A uniformly distributed rotation (normalised Gaussian quaternion).
Eigen::Matrix3d random_rotation(std::mt19937_64& rng) {
    std::normal_distribution<double> gauss;
    Eigen::Quaterniond q(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
    q.normalize();
    return q.toRotationMatrix();
}

/// Two unit vectors completing the unit n to an orthonormal basis, in double.
void basis_of(const Vec3d& n, Vec3d& a, Vec3d& b) {
    a = (std::abs(n.x()) < 0.9 ? Vec3d::UnitX() : Vec3d::UnitY()).cross(n).normalized();
    b = n.cross(a);
}

NormalSample make_sample(const Vec3d& position, const Vec3d& normal, const Vec3d& representative,
                         double sigma) {
    NormalSample s;
    s.position = position.cast<float>();
    s.normal = normal.cast<float>();
    s.weight = gaussian_sample_weight(static_cast<float>((position - representative).norm()),
                                      static_cast<float>(sigma));
    return s;
}

/// Every output is finite and the frame orthonormal and right-handed.
void expect_well_formed(const NormalGradientFit& fit) {
    ASSERT_TRUE(fit.normal.allFinite() && fit.tangent_u.allFinite() && fit.tangent_v.allFinite())
        << fit;
    ASSERT_TRUE(fit.gradient.allFinite() && fit.offset.allFinite()) << fit;
    EXPECT_NEAR(fit.normal.norm(), 1.0f, 1e-6f) << fit;
    EXPECT_NEAR(fit.tangent_u.norm(), 1.0f, 1e-6f) << fit;
    EXPECT_NEAR(fit.tangent_u.dot(fit.normal), 0.0f, 1e-6f) << fit;
    EXPECT_LE((fit.normal.cross(fit.tangent_u) - fit.tangent_v).norm(), 1e-6f) << fit;
    if (!fit.fitted) {
        EXPECT_EQ(fit.gradient, Mat2f::Zero()) << fit;
        EXPECT_EQ(fit.offset, Vec2f::Zero()) << fit;
    }
}

/// Eigenvalues (ascending) and unit eigenvectors of the symmetric part of a 2×2 matrix.
Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> symmetric_part_eigen(const Mat2f& g) {
    const Eigen::Matrix2d gd = g.cast<double>();
    return Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(0.5 * (gd + gd.transpose()));
}

/// A vector of object space in the fit's (t_u, t_v) components.
Vec2d in_frame(const NormalGradientFit& fit, const Vec3d& v) {
    return {v.dot(fit.tangent_u.cast<double>()), v.dot(fit.tangent_v.cast<double>())};
}

// ---------------------------------------------------------------------------------------------
// Spheres

struct SphereCase {
    Vec3d centre;
    double radius;
    Vec3d axis;  ///< Unit direction from the centre to the representative point.
    double sigma;
    double max_angle;  ///< θ_max: samples lie within this angle of the axis.
};

/// `count` samples uniformly distributed by area on the spherical cap, outward normals.
std::vector<NormalSample> sample_sphere(const SphereCase& s, int count, std::mt19937_64& rng) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    Vec3d a;
    Vec3d b;
    basis_of(s.axis, a, b);
    const Vec3d representative = s.centre + s.radius * s.axis;
    std::vector<NormalSample> samples;
    for (int i = 0; i < count; ++i) {
        // Area-uniform on the cap: cos θ uniform in [cos θ_max, 1].
        const double cos_theta = 1.0 - unit(rng) * (1.0 - std::cos(s.max_angle));
        const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
        const double phi = 2.0 * std::numbers::pi * unit(rng);
        const Vec3d m = cos_theta * s.axis + sin_theta * (std::cos(phi) * a + std::sin(phi) * b);
        samples.push_back(make_sample(s.centre + s.radius * m, m, representative, s.sigma));
    }
    return samples;
}

TEST(NormalGradient, SphereGivesIdentityOverRadius) {
    std::mt19937_64 rng(101);
    double worst_relative = 0.0;
    for (const double radius : {0.01, 0.1, 1.0, 10.0, 100.0}) {
        for (const double sigma_over_radius : {0.002, 0.02, 0.1}) {
            for (int trial = 0; trial < 4; ++trial) {
                SphereCase s;
                s.centre = radius * Vec3d(0.5, -0.25, 2.0) * trial;
                s.radius = radius;
                s.axis = trial == 0 ? Vec3d(0.0, 0.0, -1.0) : random_direction(rng);
                s.sigma = sigma_over_radius * radius;
                s.max_angle = 3.0 * sigma_over_radius;
                const Vec3d representative = s.centre + radius * s.axis;
                const NormalGradientFit fit =
                    fit_normal_gradient(representative.cast<float>(), sample_sphere(s, 400, rng));
                expect_well_formed(fit);
                ASSERT_TRUE(fit.fitted) << fit;

                const double nonlinearity = 1.0 / std::cos(s.max_angle) - 1.0;
                const double tolerance = (nonlinearity + 1e-4) / radius;
                const Eigen::Matrix2d expected = Eigen::Matrix2d::Identity() / radius;
                const double error = (fit.gradient.cast<double>() - expected).cwiseAbs().maxCoeff();
                EXPECT_LE(error, tolerance)
                    << "r " << radius << " σ/r " << sigma_over_radius << " " << fit;
                worst_relative = std::max(worst_relative, error * radius);

                // n̄ is the cap's axis up to the cap's sampling asymmetry and quantization, and
                // the offset d0 is the deviation of the true normal there, to the fit's accuracy.
                const Vec3d n = fit.normal.cast<double>();
                EXPECT_LE(angle_between(n, s.axis), 0.1 * s.max_angle + 1e-4);
                const Vec2d d_true = in_frame(fit, s.axis / s.axis.dot(n));
                EXPECT_LE((fit.offset.cast<double>() - d_true).norm(),
                          nonlinearity * s.max_angle + 1e-4)
                    << fit;
            }
        }
    }
    std::cout << "worst |G − I/r|·r over the sphere cases: " << worst_relative << "\n";
}

TEST(NormalGradient, InwardNormalsGiveMinusIdentityOverRadius) {
    // The same sphere seen from inside (normals pointing to the centre) curves towards its
    // normal: G = −I/r.
    std::mt19937_64 rng(102);
    SphereCase s{Vec3d(1.0, 2.0, 3.0), 2.0, random_direction(rng), 0.04, 0.06};
    std::vector<NormalSample> samples = sample_sphere(s, 400, rng);
    for (NormalSample& sample : samples) {
        sample.normal = -sample.normal;
    }
    const NormalGradientFit fit =
        fit_normal_gradient((s.centre + s.radius * s.axis).cast<float>(), samples);
    expect_well_formed(fit);
    ASSERT_TRUE(fit.fitted);
    const double tolerance = (1.0 / std::cos(s.max_angle) - 1.0 + 1e-4) / s.radius;
    EXPECT_LE((fit.gradient.cast<double>() + Eigen::Matrix2d::Identity() / s.radius)
                  .cwiseAbs()
                  .maxCoeff(),
              tolerance)
        << fit;
}

// ---------------------------------------------------------------------------------------------
// Planes

TEST(NormalGradient, PlaneGivesZero) {
    std::mt19937_64 rng(201);
    std::uniform_real_distribution<double> centred(-1.0, 1.0);
    for (int trial = 0; trial < 20; ++trial) {
        const Vec3d n = trial == 0 ? Vec3d(0.0, 0.0, -1.0) : random_direction(rng);
        Vec3d a;
        Vec3d b;
        basis_of(n, a, b);
        const double sigma = std::pow(10.0, trial % 5 - 2);  // 0.01 … 100
        const Vec3d representative = Vec3d(100.0, -50.0, 20.0) * (trial % 3);
        std::vector<NormalSample> samples;
        for (int i = 0; i < 300; ++i) {
            const Vec3d p = representative + 3.0 * sigma * (centred(rng) * a + centred(rng) * b);
            samples.push_back(make_sample(p, n, representative, sigma));
        }
        const NormalGradientFit fit = fit_normal_gradient(representative.cast<float>(), samples);
        expect_well_formed(fit);
        ASSERT_TRUE(fit.fitted) << fit;
        // Every sample has the same normal, hence bit-identical deviations d: the fit sees a
        // constant function, whatever the rounding of the positions.
        EXPECT_LE(fit.gradient.cwiseAbs().maxCoeff(), 1e-9 / sigma) << fit;
        // n̄ is the plane's normal, quantized; d0 is the deviation between the two.
        // (+ 1e-6 for the float rounding of the samples' normals).
        EXPECT_LE(angle_between(fit.normal.cast<double>(), n), kNormalMaxAngularError + 1e-6);
        EXPECT_LE(fit.offset.norm(), kNormalMaxAngularError + 1e-6f);
    }
}

// ---------------------------------------------------------------------------------------------
// Cylinders

TEST(NormalGradient, CylinderCurvesOnlyAroundItsAxis) {
    std::mt19937_64 rng(301);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (const double radius : {0.01, 1.0, 100.0}) {
        for (const double sigma_over_radius : {0.005, 0.05, 0.1}) {
            const Vec3d axis = random_direction(rng);
            Vec3d e;
            Vec3d unused;
            basis_of(axis, e, unused);
            const Vec3d around = axis.cross(e);  // circumferential direction at the representative
            const Vec3d origin = radius * Vec3d(-1.0, 0.5, 0.25);
            const Vec3d representative = origin + radius * e;
            const double sigma = sigma_over_radius * radius;
            const double max_angle = 3.0 * sigma_over_radius;
            std::vector<NormalSample> samples;
            for (int i = 0; i < 400; ++i) {
                // Area-uniform on the patch: dA = r·dφ·dh.
                const double phi = max_angle * (2.0 * unit(rng) - 1.0);
                const double h = 3.0 * sigma * (2.0 * unit(rng) - 1.0);
                const Vec3d normal = std::cos(phi) * e + std::sin(phi) * around;
                samples.push_back(make_sample(origin + radius * normal + h * axis, normal,
                                              representative, sigma));
            }
            const NormalGradientFit fit =
                fit_normal_gradient(representative.cast<float>(), samples);
            expect_well_formed(fit);
            ASSERT_TRUE(fit.fitted) << fit;

            const double nonlinearity = 1.0 / std::cos(max_angle) - 1.0;
            const auto eigen = symmetric_part_eigen(fit.gradient);
            const double tolerance = (nonlinearity + 1e-4) / radius;
            EXPECT_NEAR(eigen.eigenvalues()(0), 0.0, tolerance) << fit;
            EXPECT_NEAR(eigen.eigenvalues()(1), 1.0 / radius, tolerance) << fit;
            // The eigenvector of 1/r is the circumferential direction (up to sign): the angle
            // between them is at most about the off-diagonal error over the eigenvalue gap.
            const Vec2d circumferential = in_frame(fit, around).normalized();
            EXPECT_GE(std::abs(eigen.eigenvectors().col(1).dot(circumferential)),
                      std::cos(2.0 * (nonlinearity + 1e-4)))
                << fit;
            // And G is symmetric to the same accuracy: no twist.
            EXPECT_NEAR(fit.gradient(0, 1), fit.gradient(1, 0), tolerance) << fit;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Paraboloids: the deviation is exactly linear, a known answer with any curvatures

/// Samples of z = (κ1·x² + κ2·y²)/2 in the frame (e1, e2, n) at `origin`, on a symmetric grid
/// of half-width `extent` (so that the weighted mean normal is exactly n), normals
/// (−κ1·x, −κ2·y, 1) normalised, whose deviation relative to n is exactly (−κ1·x, −κ2·y).
std::vector<NormalSample> sample_paraboloid(const Eigen::Matrix3d& frame, const Vec3d& origin,
                                            double k1, double k2, double extent, double sigma) {
    std::vector<NormalSample> samples;
    const int half = 10;
    for (int i = -half; i <= half; ++i) {
        for (int j = -half; j <= half; ++j) {
            const double x = extent * i / half;
            const double y = extent * j / half;
            const Vec3d local_p(x, y, 0.5 * (k1 * x * x + k2 * y * y));
            const Vec3d local_n = Vec3d(-k1 * x, -k2 * y, 1.0).normalized();
            samples.push_back(
                make_sample(origin + frame * local_p, frame * local_n, origin, sigma));
        }
    }
    return samples;
}

TEST(NormalGradient, ParaboloidGivesMinusItsCurvatures) {
    std::mt19937_64 rng(401);
    const double curvatures[][2] = {{2.0, 0.5}, {-1.0, 1.0}, {3.0, 0.0}, {-0.2, -4.0}};
    for (const auto& k : curvatures) {
        for (int trial = 0; trial < 5; ++trial) {
            const Eigen::Matrix3d frame =
                trial == 0 ? Eigen::Matrix3d::Identity() : random_rotation(rng);
            const Vec3d origin(0.3 * trial, -1.0, 2.0);
            const double extent = 0.05;
            const NormalGradientFit fit = fit_normal_gradient(
                origin.cast<float>(), sample_paraboloid(frame, origin, k[0], k[1], extent, 0.02));
            expect_well_formed(fit);
            ASSERT_TRUE(fit.fitted) << fit;
            // In the fit's frame: G = R·diag(−κ1, −κ2)·Rᵀ with R the 2D rotation taking the
            // paraboloid's (e1, e2) to (t_u, t_v). The residual error comes from n̄'s
            // quantization tilt and float input.
            Eigen::Matrix2d r;
            r.col(0) = in_frame(fit, frame.col(0));
            r.col(1) = in_frame(fit, frame.col(1));
            const Eigen::Matrix2d expected =
                r * Eigen::Vector2d(-k[0], -k[1]).asDiagonal() * r.transpose();
            const double scale = std::max(std::abs(k[0]), std::abs(k[1]));
            EXPECT_LE((fit.gradient.cast<double>() - expected).cwiseAbs().maxCoeff(), 2e-4 * scale)
                << "κ " << k[0] << ", " << k[1] << " " << fit;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Invariance under rigid motions

TEST(NormalGradient, RotationAndTranslationLeaveTheGradientInvariant) {
    // A general surface with randomly placed samples (not the symmetric grid): an ellipsoid-like
    // paraboloid, its samples moved by random rigid motions. G must transform as Q·G·Qᵀ, Q the
    // 2D rotation between the two fits' frames, so its eigenvalues, trace and determinant stay.
    std::mt19937_64 rng(501);
    std::uniform_real_distribution<double> centred(-1.0, 1.0);
    std::vector<NormalSample> base;
    const double k1 = 1.5;
    const double k2 = -0.4;
    const double sigma = 0.05;
    for (int i = 0; i < 300; ++i) {
        const double x = 3.0 * sigma * centred(rng);
        const double y = 3.0 * sigma * centred(rng);
        const Vec3d p(x, y, 0.5 * (k1 * x * x + k2 * y * y) + 0.3 * x * x * y);
        const Vec3d n = Vec3d(-k1 * x - 0.6 * x * y, -k2 * y - 0.3 * x * x, 1.0).normalized();
        base.push_back(make_sample(p, n, Vec3d::Zero(), sigma));
    }
    const NormalGradientFit reference = fit_normal_gradient(Vec3f::Zero(), base);
    ASSERT_TRUE(reference.fitted);
    const double scale = reference.gradient.cast<double>().norm();

    for (int trial = 0; trial < 20; ++trial) {
        Eigen::Matrix3d rotation = random_rotation(rng);
        if (trial == 0) {  // turn +z into −z: the other branch of the canonical basis
            rotation = Eigen::AngleAxisd(std::numbers::pi, Vec3d::UnitX()).toRotationMatrix();
        }
        const Vec3d translation(3.0 * centred(rng), -7.0 * centred(rng), 12.0 * centred(rng));
        std::vector<NormalSample> moved = base;
        for (NormalSample& s : moved) {
            s.position = (rotation * s.position.cast<double>() + translation).cast<float>();
            s.normal = (rotation * s.normal.cast<double>()).cast<float>();
        }
        const NormalGradientFit fit = fit_normal_gradient(translation.cast<float>(), moved);
        expect_well_formed(fit);
        ASSERT_TRUE(fit.fitted);
        Eigen::Matrix2d q;  // reference frame → moved frame
        for (int c = 0; c < 2; ++c) {
            const Vec3d t =
                rotation * (c == 0 ? reference.tangent_u : reference.tangent_v).cast<double>();
            q.col(c) = in_frame(fit, t);
        }
        const Eigen::Matrix2d expected = q * reference.gradient.cast<double>() * q.transpose();
        // The two fits' n̄ are quantized independently, each tilted by up to 4.35e-5 rad,
        // which changes G by a relative O(tilt): 1e-4 (measured: 5e-7).
        EXPECT_LE((fit.gradient.cast<double>() - expected).norm(), 1e-4 * scale) << fit;
        const auto a = symmetric_part_eigen(reference.gradient);
        const auto b = symmetric_part_eigen(fit.gradient);
        EXPECT_NEAR(a.eigenvalues()(0), b.eigenvalues()(0), 1e-4 * scale);
        EXPECT_NEAR(a.eigenvalues()(1), b.eigenvalues()(1), 1e-4 * scale);
        EXPECT_NEAR(fit.gradient.determinant(), reference.gradient.determinant(),
                    2e-4 * scale * scale);
    }
}

// ---------------------------------------------------------------------------------------------
// Degenerate input

TEST(NormalGradient, NoSamplesOneSampleOrTwoGiveNoFit) {
    const NormalGradientFit none = fit_normal_gradient(Vec3f::Zero(), {});
    expect_well_formed(none);
    EXPECT_FALSE(none.fitted);
    EXPECT_EQ(none.normal, Vec3f(0.0f, 0.0f, 1.0f));

    const Vec3f n = Vec3f(1.0f, -2.0f, 0.5f).normalized();
    std::vector<NormalSample> samples = {{Vec3f(0.1f, 0.0f, 0.0f), n, 0.7f}};
    const NormalGradientFit one = fit_normal_gradient(Vec3f::Zero(), samples);
    expect_well_formed(one);
    EXPECT_FALSE(one.fitted);
    EXPECT_EQ(one.normal, decode_normal(encode_normal(n)));

    samples.push_back({Vec3f(0.0f, 0.1f, 0.0f), n, 0.7f});
    const NormalGradientFit two = fit_normal_gradient(Vec3f::Zero(), samples);
    expect_well_formed(two);
    EXPECT_FALSE(two.fitted);
}

TEST(NormalGradient, CollinearOrCoincidentSamplesGiveNoFit) {
    std::mt19937_64 rng(601);
    std::uniform_real_distribution<double> centred(-1.0, 1.0);
    const Vec3d n = random_direction(rng);
    Vec3d a;
    Vec3d b;
    basis_of(n, a, b);
    const Vec3d c(5.0, -3.0, 1.0);
    std::vector<NormalSample> line;
    std::vector<NormalSample> point;
    for (int i = 0; i < 200; ++i) {
        const double t = 0.1 * centred(rng);
        // Varying normals along the line (a curved wire), so that d is not constant.
        const Vec3d normal = (n + 3.0 * t * a).normalized();
        line.push_back(make_sample(c + t * a, normal, c, 0.05));
        point.push_back(make_sample(c, normal, c, 0.05));
    }
    for (const auto& samples : {line, point}) {
        const NormalGradientFit fit = fit_normal_gradient(c.cast<float>(), samples);
        expect_well_formed(fit);
        EXPECT_FALSE(fit.fitted) << fit;
    }
}

TEST(NormalGradient, ZeroWeightsGiveNoFitAndTheUnweightedNormal) {
    std::vector<NormalSample> samples;
    for (int i = 0; i < 50; ++i) {
        samples.push_back(
            {Vec3f(0.01f * static_cast<float>(i % 7), 0.01f * static_cast<float>(i % 5), 0.0f),
             Vec3f(0.0f, 0.6f, 0.8f), 0.0f});
    }
    const NormalGradientFit fit = fit_normal_gradient(Vec3f::Zero(), samples);
    expect_well_formed(fit);
    EXPECT_FALSE(fit.fitted);
    EXPECT_EQ(fit.normal, decode_normal(encode_normal(Vec3f(0.0f, 0.6f, 0.8f))));
}

TEST(NormalGradient, InvalidSamplesAreIgnored) {
    // Valid samples of a sphere plus samples with NaN positions, NaN or Inf normals, negative,
    // NaN or Inf weights: the fit equals the one of the valid samples alone, bit for bit.
    std::mt19937_64 rng(701);
    SphereCase s{Vec3d::Zero(), 1.0, Vec3d(0.0, 0.0, 1.0), 0.05, 0.15};
    const std::vector<NormalSample> valid = sample_sphere(s, 200, rng);
    std::vector<NormalSample> mixed = valid;
    const Vec3f p(0.0f, 0.0f, 1.0f);
    const Vec3f n(0.0f, 0.0f, 1.0f);
    mixed.push_back({Vec3f(kNaN, 0.0f, 1.0f), n, 1.0f});
    mixed.push_back({p, Vec3f(kNaN, 0.0f, 1.0f), 1.0f});
    mixed.push_back({p, Vec3f(kInfinity, 0.0f, 1.0f), 1.0f});
    mixed.push_back({p, n, -1.0f});
    mixed.push_back({p, n, kNaN});
    mixed.push_back({p, n, kInfinity});
    const NormalGradientFit a = fit_normal_gradient(p, valid);
    const NormalGradientFit b = fit_normal_gradient(p, mixed);
    expect_well_formed(b);
    ASSERT_TRUE(a.fitted && b.fitted);
    EXPECT_EQ(a.normal, b.normal);
    EXPECT_EQ(a.gradient, b.gradient);
    EXPECT_EQ(a.offset, b.offset);
}

TEST(NormalGradient, NormalsFacingAwayAreSkipped) {
    // A plane whose samples mostly face +n, a lighter third flipped: n̄ = +n, and the flipped
    // ones (n_i·n̄ = −1) drop out of the fit, which sees a plane.
    std::mt19937_64 rng(801);
    std::uniform_real_distribution<double> centred(-1.0, 1.0);
    const Vec3d n = random_direction(rng);
    Vec3d a;
    Vec3d b;
    basis_of(n, a, b);
    std::vector<NormalSample> samples;
    for (int i = 0; i < 300; ++i) {
        const Vec3d p = 0.1 * (centred(rng) * a + centred(rng) * b);
        samples.push_back(make_sample(p, i % 3 == 0 ? -n : n, Vec3d::Zero(), 0.05));
    }
    const NormalGradientFit fit = fit_normal_gradient(Vec3f::Zero(), samples);
    expect_well_formed(fit);
    ASSERT_TRUE(fit.fitted);
    EXPECT_GT(fit.normal.cast<double>().dot(n), 0.999);
    EXPECT_LE(fit.gradient.cwiseAbs().maxCoeff(), 1e-6f);

    // Normals all around the equator cancel: n̄ falls back to +z, every normal is orthogonal
    // to it (n·n̄ = 0 ≤ ε) and nothing is left to fit.
    std::vector<NormalSample> ring;
    for (int i = 0; i < 64; ++i) {
        const double phi = 2.0 * std::numbers::pi * i / 64;
        ring.push_back(
            {Vec3f(static_cast<float>(0.1 * std::cos(phi)), static_cast<float>(0.1 * std::sin(phi)),
                   0.0f),
             Vec3f(static_cast<float>(std::cos(phi)), static_cast<float>(std::sin(phi)), 0.0f),
             1.0f});
    }
    const NormalGradientFit cancelled = fit_normal_gradient(Vec3f::Zero(), ring);
    expect_well_formed(cancelled);
    EXPECT_FALSE(cancelled.fitted);
}

TEST(NormalGradient, ExtremeInputNeverProducesNanOrInf) {
    // Random magnitudes from 1e-30 to 1e30, zero normals, huge weights: whatever comes out is
    // finite, unit where it should be, and G = 0 whenever the fit is flagged as failed.
    std::mt19937_64 rng(901);
    std::uniform_real_distribution<double> exponent(-30.0, 30.0);
    std::uniform_real_distribution<double> centred(-1.0, 1.0);
    std::uniform_int_distribution<int> pick(0, 9);
    for (int trial = 0; trial < 2000; ++trial) {
        std::vector<NormalSample> samples;
        const int count = pick(rng) + 1;
        for (int i = 0; i < count; ++i) {
            const double magnitude = std::pow(10.0, exponent(rng));
            NormalSample s;
            s.position =
                (magnitude * Vec3d(centred(rng), centred(rng), centred(rng))).cast<float>();
            s.normal =
                pick(rng) == 0 ? Vec3f(Vec3f::Zero()) : Vec3f(random_direction(rng).cast<float>());
            s.weight = static_cast<float>(std::pow(10.0, exponent(rng)));
            samples.push_back(s);
        }
        const NormalGradientFit fit = fit_normal_gradient(
            (std::pow(10.0, exponent(rng)) * random_direction(rng)).cast<float>(), samples);
        expect_well_formed(fit);
    }
}

}  // namespace
}  // namespace mrt
