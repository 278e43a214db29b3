// Ray differentials against finite differences of offset rays traced independently in double
// precision: transfer onto a plane, reflection off a sphere and off a normal-interpolated
// triangle, refraction through a glass sphere and a normal-interpolated triangle; the error of
// a forward difference halves with its offset. Plus texture-coordinate derivatives against the
// analytic perspective mapping, the stable 2×2 eigen-decomposition, the anisotropy clamp, the
// widened footprint and the compensated inverse against double precision, and stiff cases that
// must stay finite. The closed-form eigen-decomposition against a long-double reference on
// random and adversarial matrices; the blur cone (convolved Gaussians, add_blur, the aperture of
// depth of field) and its growth along the ray against a central difference in double; the
// anisotropy clamp's clamped ellipse.

#include "common/footprint/footprint.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include <array>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace mrt {
namespace {

using Vec3 = Vec3d;

struct Camera {
    Vec3 eye{0.3, 2.0, 5.0};
    Vec3 top_left{-0.4, 0.1, -1.0};  // direction to raster (0, 0) at unit distance
    Vec3 step_x{0.004, 0.0, 0.0};
    Vec3 step_y{0.0, -0.0035, 0.0007};  // deliberately not square and not orthogonal

    Vec3 direction(double x, double y) const {
        return (top_left + x * step_x + y * step_y).normalized();
    }
    RayDifferential differential(double x, double y) const {
        const Vec3 d = top_left + x * step_x + y * step_y;
        return RayDifferential::pinhole(d.cast<float>(), step_x.cast<float>(),
                                        step_y.cast<float>());
    }
};

Vec3 reflect(const Vec3& d, const Vec3& n) {
    return d - 2.0 * d.dot(n) * n;
}

/// eta = n_incident / n_transmitted, n facing against d.
Vec3 refract(const Vec3& d, const Vec3& n, double eta) {
    const double c1 = -d.dot(n);
    const double c2 = std::sqrt(1.0 - eta * eta * (1.0 - c1 * c1));
    return eta * d + (eta * c1 - c2) * n;
}

double hit_sphere(const Vec3& o, const Vec3& d, const Vec3& c, double r, bool far) {
    const Vec3 oc = o - c;
    const double b = oc.dot(d);
    const double disc = b * b - (oc.squaredNorm() - r * r);
    return far ? -b + std::sqrt(disc) : -b - std::sqrt(disc);
}

/// A traced path at pixel (x, y): where it ends and which way it goes.
struct PathEnd {
    Vec3 position;
    Vec3 direction;
};

/// Checks one propagated differential against one-sided finite differences of `trace` at
/// offsets of 1, 1/2, 1/4 and 1/8 pixel in x and y. A forward difference is off by a term
/// proportional to the offset, so its error must halve with each halving of the offset (the
/// differential is the limit they converge to, not merely close to them), and the Richardson
/// extrapolation 2·f(h/8) − f(h/4), accurate to second order, must agree within `tolerance`.
void expect_matches_finite_differences(const std::function<PathEnd(double, double)>& trace,
                                       const RayDifferential& rd, double x, double y,
                                       double tolerance) {
    const PathEnd centre = trace(x, y);
    const auto forward_difference = [&](double h, bool along_x) {
        const PathEnd a = along_x ? trace(x + h, y) : trace(x, y + h);
        return std::pair<Vec3, Vec3>((a.position - centre.position) / h,
                                     (a.direction - centre.direction) / h);
    };
    for (const bool along_x : {true, false}) {
        const char* axis = along_x ? "x" : "y";
        const Vec3 dp = (along_x ? rd.dp_dx : rd.dp_dy).cast<double>();
        const Vec3 dd = (along_x ? rd.dd_dx : rd.dd_dy).cast<double>();
        const double scale_p = std::max(dp.norm(), 1e-6);
        const double scale_d = std::max(dd.norm(), 1e-6);
        std::vector<std::pair<Vec3, Vec3>> fd;
        for (const double h : {1.0, 0.5, 0.25, 0.125}) {
            fd.push_back(forward_difference(h, along_x));
        }
        for (std::size_t k = 0; k + 1 < fd.size(); ++k) {
            for (const bool position : {true, false}) {
                const Vec3& exact = position ? dp : dd;
                const double scale = position ? scale_p : scale_d;
                const double coarse =
                    ((position ? fd[k].first : fd[k].second) - exact).norm() / scale;
                const double fine =
                    ((position ? fd[k + 1].first : fd[k + 1].second) - exact).norm() / scale;
                // Below ~1e-4 the float differential's own rounding (and a derivative that
                // happens to be nearly linear) hides the first-order term.
                if (coarse > 1e-4) {
                    EXPECT_NEAR(coarse / fine, 2.0, 0.35)
                        << axis << (position ? " dp" : " dd") << " offset 1/" << (1 << k)
                        << ": error " << coarse << " → " << fine;
                }
            }
        }
        const Vec3 p = 2.0 * fd[3].first - fd[2].first;
        const Vec3 d = 2.0 * fd[3].second - fd[2].second;
        EXPECT_LT((p - dp).norm() / scale_p, tolerance)
            << axis << " dp " << dp.transpose() << " vs " << p.transpose();
        EXPECT_LT((d - dd).norm() / scale_d, tolerance)
            << axis << " dd " << dd.transpose() << " vs " << d.transpose();
    }
}

TEST(LargestSingularValue, MatchesADoublePrecisionSvd) {
    // Random matrices over twelve orders of magnitude, nearly singular and nearly collinear ones,
    // against Eigen's SVD in double.
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int i = 0; i < 10000; ++i) {
        Mat2f m;
        m << unit(rng), unit(rng), unit(rng), unit(rng);
        if (i % 3 == 1) {
            m.col(1) = m.col(0) * (1.0f + 1e-4f * unit(rng));
        }
        m *= std::pow(10.0f, 6.0f * unit(rng));
        const double expected =
            Eigen::JacobiSVD<Eigen::Matrix2d>(m.cast<double>()).singularValues()(0);
        ASSERT_NEAR(largest_singular_value(m), expected, 1e-6 * expected) << m;
    }
    EXPECT_EQ(largest_singular_value(Mat2f::Zero()), 0.0f);
    EXPECT_FLOAT_EQ(largest_singular_value(Mat2f(Eigen::Vector2f(3.0f, -0.5f).asDiagonal())), 3.0f);
}

TEST(RayDifferential, TransferOntoAPlaneMatchesFiniteDifferences) {
    const Camera cam;
    const Vec3 n(0.1, 1.0, 0.2);
    const Vec3 normal = n.normalized();
    const double offset = 0.25;  // plane normal·P = offset
    const auto trace = [&](double x, double y) {
        const Vec3 d = cam.direction(x, y);
        const double t = (offset - normal.dot(cam.eye)) / normal.dot(d);
        return PathEnd{cam.eye + t * d, d};
    };
    for (const auto& [x, y] : {std::pair{10.0, 20.0}, std::pair{150.0, 90.0}}) {
        const Vec3 d = cam.direction(x, y);
        const double t = (offset - normal.dot(cam.eye)) / normal.dot(d);
        const RayDifferential rd = cam.differential(x, y).transfer(
            d.cast<float>(), static_cast<float>(t), normal.cast<float>());
        expect_matches_finite_differences(trace, rd, x, y, 1e-3);
    }
}

TEST(RayDifferential, ReflectionOffASphereMatchesFiniteDifferences) {
    const Camera cam;
    const Vec3 centre(0.0, 1.5, 0.0);
    const double r = 1.2;
    const Vec3 plane_n(0, 1, 0);
    // Reflect off the sphere, then transfer to the floor y = 0: checks the whole chain.
    const auto trace = [&](double x, double y) {
        const Vec3 d = cam.direction(x, y);
        const double t = hit_sphere(cam.eye, d, centre, r, false);
        const Vec3 p = cam.eye + t * d;
        const Vec3 rr = reflect(d, (p - centre) / r);
        return PathEnd{p, rr};
    };
    const double x = 95.0, y = 70.0;
    const Vec3 d = cam.direction(x, y);
    const double t = hit_sphere(cam.eye, d, centre, r, false);
    ASSERT_TRUE(std::isfinite(t));
    const Vec3 p = cam.eye + t * d;
    const Vec3 n = (p - centre) / r;
    const RayDifferential at_hit =
        cam.differential(x, y).transfer(d.cast<float>(), static_cast<float>(t), n.cast<float>());
    // Sphere: N = (P − C)/r, so dN = dP/r (Igehy eq. 22).
    const RayDifferential reflected =
        at_hit.reflect(d.cast<float>(), n.cast<float>(), at_hit.dp_dx / static_cast<float>(r),
                       at_hit.dp_dy / static_cast<float>(r));
    expect_matches_finite_differences(trace, reflected, x, y, 2e-3);
}

TEST(RayDifferential, RefractionThroughAGlassSphereMatchesFiniteDifferences) {
    const Camera cam;
    const Vec3 centre(0.0, 1.5, 0.0);
    const double r = 1.2;
    const double ior = 1.5;
    const auto trace = [&](double x, double y) {
        const Vec3 d = cam.direction(x, y);
        const double t1 = hit_sphere(cam.eye, d, centre, r, false);
        const Vec3 p1 = cam.eye + t1 * d;
        const Vec3 inside = refract(d, (p1 - centre) / r, 1.0 / ior);
        const double t2 = hit_sphere(p1, inside, centre, r, true);
        const Vec3 p2 = p1 + t2 * inside;
        const Vec3 out = refract(inside, -(p2 - centre) / r, ior);
        return PathEnd{p2, out};
    };
    for (const auto& [x, y] : {std::pair{95.0, 70.0}, std::pair{110.0, 60.0}}) {
        const Vec3 d = cam.direction(x, y);
        const double t1 = hit_sphere(cam.eye, d, centre, r, false);
        ASSERT_TRUE(std::isfinite(t1));
        const Vec3 p1 = cam.eye + t1 * d;
        const Vec3 n1 = (p1 - centre) / r;
        const float inv_r = static_cast<float>(1.0 / r);
        RayDifferential rd = cam.differential(x, y).transfer(
            d.cast<float>(), static_cast<float>(t1), n1.cast<float>());
        rd = rd.refract(d.cast<float>(), n1.cast<float>(), rd.dp_dx * inv_r, rd.dp_dy * inv_r,
                        static_cast<float>(1.0 / ior));
        const Vec3 inside = refract(d, n1, 1.0 / ior);
        const double t2 = hit_sphere(p1, inside, centre, r, true);
        const Vec3 p2 = p1 + t2 * inside;
        const Vec3 n2 = -(p2 - centre) / r;  // inside: the normal facing the ray points inwards
        rd = rd.transfer(inside.cast<float>(), static_cast<float>(t2), n2.cast<float>());
        // Flipped normal, flipped derivative.
        rd = rd.refract(inside.cast<float>(), n2.cast<float>(), -rd.dp_dx * inv_r,
                        -rd.dp_dy * inv_r, static_cast<float>(ior));
        expect_matches_finite_differences(trace, rd, x, y, 3e-3);
    }
}

/// A triangle with distinct, unnormalised vertex normals and uvs.
struct InterpolatedTriangle {
    Vec3 p[3] = {Vec3(-2.0, 0.0, -3.0), Vec3(2.5, 0.3, -2.5), Vec3(0.0, 0.2, 2.0)};
    Vec3 n[3] = {Vec3(-0.4, 1.0, -0.3), Vec3(0.5, 1.2, -0.2), Vec3(0.1, 0.8, 0.6)};
    Vec2d uv[3] = {Vec2d(0.0, 0.0), Vec2d(3.0, 0.5), Vec2d(1.0, 4.0)};

    /// Hit of o + t·d with the triangle's plane: t and barycentrics (b1, b2).
    std::tuple<double, double, double> hit(const Vec3& o, const Vec3& d) const {
        const Vec3 e1 = p[1] - p[0];
        const Vec3 e2 = p[2] - p[0];
        Eigen::Matrix3d m;
        m << -d, e1, e2;
        const Vec3 s = m.colPivHouseholderQr().solve(o - p[0]);
        return {s[0], s[1], s[2]};
    }
    Vec3 normal(double b1, double b2) const {
        return ((1 - b1 - b2) * n[0] + b1 * n[1] + b2 * n[2]).normalized();
    }
    SurfaceDifferential differential(double b1, double b2, const RayDifferential& rd,
                                     bool flip) const {
        Vec3f pf[3], nf[3];
        Vec2f uvf[3];
        for (int i = 0; i < 3; ++i) {
            pf[i] = p[i].cast<float>();
            nf[i] = n[i].cast<float>();
            uvf[i] = uv[i].cast<float>();
        }
        return triangle_differential(pf, nf, uvf, static_cast<float>(b1), static_cast<float>(b2),
                                     rd.dp_dx, rd.dp_dy, flip ? Facing::Back : Facing::Front);
    }
};

TEST(RayDifferential, ReflectionAndRefractionAtANormalInterpolatedTriangle) {
    const Camera cam;
    const InterpolatedTriangle tri;
    const Vec3 geometric = (tri.p[1] - tri.p[0]).cross(tri.p[2] - tri.p[0]).normalized();
    for (const bool refracting : {false, true}) {
        const auto trace = [&](double x, double y) {
            const Vec3 d = cam.direction(x, y);
            const auto [t, b1, b2] = tri.hit(cam.eye, d);
            Vec3 n = tri.normal(b1, b2);
            if (n.dot(d) > 0) {
                n = -n;
            }
            const Vec3 out = refracting ? refract(d, n, 1.0 / 1.5) : reflect(d, n);
            return PathEnd{cam.eye + t * d, out};
        };
        const double x = 104.0, y = 110.0;
        const Vec3 d = cam.direction(x, y);
        const auto [t, b1, b2] = tri.hit(cam.eye, d);
        ASSERT_GT(b1, 0.0);
        ASSERT_GT(b2, 0.0);
        ASSERT_LT(b1 + b2, 1.0);
        Vec3 n = tri.normal(b1, b2);
        const bool flip = n.dot(d) > 0;
        if (flip) {
            n = -n;
        }
        const RayDifferential at_hit = cam.differential(x, y).transfer(
            d.cast<float>(), static_cast<float>(t), geometric.cast<float>());
        const SurfaceDifferential s = tri.differential(b1, b2, at_hit, flip);
        const RayDifferential out =
            refracting
                ? at_hit.refract(d.cast<float>(), n.cast<float>(), s.dn_dx, s.dn_dy, 1.0f / 1.5f)
                : at_hit.reflect(d.cast<float>(), n.cast<float>(), s.dn_dx, s.dn_dy);
        expect_matches_finite_differences(trace, out, x, y, 2e-3);
    }
}

TEST(RayDifferential, UvDerivativesAtGrazingIncidenceMatchThePerspectiveMapping) {
    // Camera 0.5 above the plane y = 0 looking almost along it; uv = (x, z) on the plane.
    const Vec3 eye(0.0, 0.5, 0.0);
    const Vec3 step_x(0.002, 0.0, 0.0);
    const Vec3 step_y(0.0, -0.002, 0.0);
    const Vec3 top_left(-0.3, 0.05, -1.0);
    InterpolatedTriangle plane;
    plane.p[0] = Vec3(-1000, 0, 1000);
    plane.p[1] = Vec3(1000, 0, 1000);
    plane.p[2] = Vec3(0, 0, -1000);
    for (int i = 0; i < 3; ++i) {
        plane.n[i] = Vec3(0, 1, 0);
        plane.uv[i] = Vec2d(plane.p[i].x(), plane.p[i].z());
    }
    for (const double y : {30.0, 40.0, 49.0}) {  // row 49 is ~1.1° above the horizon
        const double x = 60.0;
        const Vec3 d = top_left + x * step_x + y * step_y;
        // P = eye − eye_y·d/d_y: differentiate the perspective mapping in closed form.
        const auto dp = [&](const Vec3& step) {
            return Vec3(-eye.y() * (step * d.y() - d * step.y()) / (d.y() * d.y()));
        };
        const Vec3 unit = d.normalized();
        const double t = -eye.y() / unit.y();
        const RayDifferential at_hit =
            RayDifferential::pinhole(d.cast<float>(), step_x.cast<float>(), step_y.cast<float>())
                .transfer(unit.cast<float>(), static_cast<float>(t), Vec3f(0, 1, 0));
        const auto [th, b1, b2] = plane.hit(eye, unit);
        const SurfaceDifferential s = plane.differential(b1, b2, at_hit, false);
        const Vec3 ex = dp(step_x);
        const Vec3 ey = dp(step_y);
        EXPECT_NEAR(s.duv_dx.x(), ex.x(), 1e-3 * ex.norm());
        EXPECT_NEAR(s.duv_dx.y(), ex.z(), 1e-3 * ex.norm());
        EXPECT_NEAR(s.duv_dy.x(), ey.x(), 1e-3 * ey.norm());
        EXPECT_NEAR(s.duv_dy.y(), ey.z(), 1e-3 * ey.norm());
        EXPECT_EQ(s.dn_dx, Vec3f::Zero());
    }
}

TEST(FootprintCone, ProjectsOntoTheRayFrameAndGrowsLinearly) {
    const Camera cam;
    const Vec3 d = cam.direction(40, 60);
    const RayDifferential rd = cam.differential(40, 60);
    const FootprintCone cone = FootprintCone::from_differential(d.cast<float>(), rd);
    EXPECT_NEAR(cone.u.dot(d.cast<float>()), 0.0f, 1e-6f);
    EXPECT_NEAR(cone.v.dot(d.cast<float>()), 0.0f, 1e-6f);
    EXPECT_EQ(cone.start_dev, Mat2f::Zero());  // pinhole: all rays leave one point
    // At distance t the footprint spans what offset rays at that distance span (first order).
    const double t = 7.0;
    const Vec3 px = (cam.eye + t * cam.direction(40.001, 60) - (cam.eye + t * d)) / 0.001;
    const Vec3 projected = px - px.dot(d) * d;
    const Mat2f f = cone.at(static_cast<float>(t));
    EXPECT_NEAR(f(0, 0), projected.dot(cone.u.cast<double>()), 1e-4 * projected.norm());
    EXPECT_NEAR(f(1, 0), projected.dot(cone.v.cast<double>()), 1e-4 * projected.norm());
    EXPECT_NEAR(cone.max_diameter(2.0f * static_cast<float>(t)),
                2.0f * cone.max_diameter(static_cast<float>(t)), 1e-5f);
}

TEST(FootprintCone, SymmetricEigenIsStableForThinEllipses) {
    for (const double ratio : {1.0, 1e-2, 1e-6, 1e-10}) {
        for (const double angle : {0.0, 0.3, 1.2, 2.9}) {
            const double c = std::cos(angle), s = std::sin(angle);
            // R·diag(1, ratio)·Rᵀ
            const double a = c * c + ratio * s * s;
            const double b = c * s * (1 - ratio);
            const double cc = s * s + ratio * c * c;
            const SymmetricEigen2 e = symmetric_eigen2(static_cast<float>(a), static_cast<float>(b),
                                                       static_cast<float>(cc));
            EXPECT_NEAR(e.major, 1.0, 1e-6);
            EXPECT_GE(e.minor, 0.0f);
            EXPECT_LE(e.minor, e.major);
            // The minor eigenvalue of the float matrix is known only to float precision of
            // the entries (~1e-7 absolute); the closed form must not lose more.
            EXPECT_NEAR(e.minor, ratio, 3e-7 + 1e-5 * ratio);
            EXPECT_NEAR(
                std::abs(e.major_axis.dot(Vec2f(static_cast<float>(c), static_cast<float>(s)))),
                1.0f, ratio == 1.0 ? 1.0f : 1e-5f);
        }
    }
    // Against Eigen's solver on a generic matrix.
    Eigen::Matrix2d m;
    m << 3.0, 1.25, 1.25, 0.7;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(m);
    const SymmetricEigen2 e = symmetric_eigen2(3.0f, 1.25f, 0.7f);
    EXPECT_NEAR(e.major, solver.eigenvalues()[1], 1e-5);
    EXPECT_NEAR(e.minor, solver.eigenvalues()[0], 1e-5);
    EXPECT_NEAR(std::abs(e.major_axis.cast<double>().dot(solver.eigenvectors().col(1))), 1.0, 1e-6);
}

TEST(FootprintCone, AnisotropyClampWidensTheMinorAxisOnly) {
    Mat2f f;
    f << 8.0f, 0.0f, 0.0f, 0.01f;
    const Mat2f clamped = FootprintCone::clamp_anisotropy(f, 4.0f);
    const Mat2f c = clamped * clamped.transpose();
    const SymmetricEigen2 e = symmetric_eigen2(c(0, 0), c(0, 1), c(1, 1));
    EXPECT_NEAR(std::sqrt(e.major), 8.0f, 1e-5f);
    EXPECT_NEAR(std::sqrt(e.minor), 2.0f, 1e-5f);
    Mat2f round;
    round << 1.0f, 0.2f, -0.1f, 0.9f;
    EXPECT_EQ(FootprintCone::clamp_anisotropy(round, 4.0f), round);
}

TEST(RayDifferential, StiffCasesStayFiniteAndBounded) {
    const Vec3f d = Vec3f(1.0f, -std::sin(0.01f * kPi / 180.0f), 0.0f).normalized();  // 89.99°
    RayDifferential rd = RayDifferential::pinhole(d, Vec3f(0, 0.001f, 0), Vec3f(0, 0, 0.001f));
    const RayDifferential grazing = rd.transfer(d, 1e5f, Vec3f(0, 1, 0));
    EXPECT_TRUE(grazing.finite());
    // Exactly parallel to the plane.
    const RayDifferential parallel = rd.transfer(Vec3f(1, 0, 0), 10.0f, Vec3f(0, 1, 0));
    EXPECT_TRUE(parallel.finite());
    EXPECT_LE(parallel.dp_dx.squaredNorm(), RayDifferential::kMaxSquaredLength * 1.01f);
    // Refraction exactly at the critical angle (sin θ = 1/η for η = 1.5).
    const float sin_c = 1.0f / 1.5f;
    const Vec3f critical(sin_c, -std::sqrt(1.0f - sin_c * sin_c), 0.0f);
    const RayDifferential refracted =
        rd.refract(critical, Vec3f(0, 1, 0), Vec3f(0.1f, 0, 0), Vec3f(0, 0, 0.1f), 1.5f);
    EXPECT_TRUE(refracted.finite());
    // A zero-area triangle: zero derivatives, no NaN.
    const Vec3f p[3] = {Vec3f(0, 0, 0), Vec3f(1, 1, 1), Vec3f(2, 2, 2)};
    const Vec3f n[3] = {Vec3f(0, 1, 0), Vec3f(0, 1, 0), Vec3f(0, 1, 0)};
    const Vec2f uv[3] = {Vec2f(0, 0), Vec2f(1, 0), Vec2f(0, 1)};
    const SurfaceDifferential s =
        triangle_differential(p, n, uv, 0.3f, 0.3f, Vec3f(1, 0, 0), Vec3f(0, 0, 1), Facing::Front);
    EXPECT_EQ(s.dn_dx, Vec3f::Zero());
    EXPECT_EQ(s.duv_dy, Vec2f::Zero());
    // A camera 1e5 units from the origin.
    const Vec3f far_d = Vec3f(-1e5f, -1e5f, -1e5f).normalized();
    const RayDifferential far =
        RayDifferential::pinhole(Vec3f(-1e5f, -1e5f, -1e5f), Vec3f(1e2f, 0, 0), Vec3f(0, 1e2f, 0))
            .transfer(far_d, 1.7e5f, Vec3f(0, 1, 0));
    EXPECT_TRUE(far.finite());
    const FootprintCone cone = FootprintCone::from_differential(far_d, far);
    EXPECT_TRUE(std::isfinite(cone.max_diameter(1e5f)));
    // Non-finite input never comes out as NaN.
    const float nan = std::numeric_limits<float>::quiet_NaN();
    RayDifferential broken;
    broken.dd_dx = Vec3f(nan, 0, 0);
    EXPECT_TRUE(broken.reflect(d, Vec3f(0, 1, 0), Vec3f::Zero(), Vec3f::Zero()).finite());
}

// ---------------------------------------------------------------------------------------------
// Widening and inverting footprints (common/footprint/point_weight.h reads both)

Eigen::Matrix2d squared(const Mat2f& f) {
    const Eigen::Matrix2d d = f.cast<double>();
    return d * d.transpose();
}

TEST(FootprintWidening, AddsTheSquaredMatricesInClosedForm) {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    for (int i = 0; i < 2000; ++i) {
        Mat2f f;
        f << uniform(rng), uniform(rng), uniform(rng), uniform(rng);
        if (i % 4 == 1) {
            f.col(1) = f.col(0) * (1.0f + 1e-4f * uniform(rng));  // nearly collinear columns
        }
        if (i % 4 == 2) {
            f *= 1e-3f;  // radius dominates
        }
        const float radius = i % 4 == 3 ? 0.0f : std::abs(uniform(rng));
        const Mat2f g = FootprintCone::widened(f, radius);
        const Eigen::Matrix2d expected =
            squared(f) + static_cast<double>(radius) * radius * Eigen::Matrix2d::Identity();
        // Float rounding of F·Fᵀ and of the root: a few ulps of the largest entry.
        EXPECT_LE((squared(g) - expected).norm(), 1e-5 * std::max(expected.norm(), 1e-30))
            << f << "\nradius " << radius;
        EXPECT_EQ(g(0, 1), g(1, 0));
    }
    EXPECT_EQ(FootprintCone::widened(Mat2f::Zero(), 0.0f), Mat2f::Zero());
    Mat2f infinite = Mat2f::Identity();
    infinite(0, 1) = std::numeric_limits<float>::infinity();
    EXPECT_EQ(FootprintCone::widened(infinite, 1.0f), Mat2f::Zero());
}

TEST(FootprintInverse, MatchesADoubleInverseEvenForNearlyCollinearColumns) {
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    for (int i = 0; i < 2000; ++i) {
        Mat2f f;
        f << uniform(rng), uniform(rng), uniform(rng), uniform(rng);
        if (i % 2 == 1) {
            f.col(1) = f.col(0) + 1e-3f * Vec2f(uniform(rng), uniform(rng));
        }
        const Eigen::Matrix2d d = f.cast<double>();
        const double det = d.determinant();
        const FootprintInverse inverse = FootprintCone::inverse(f);
        // The compensated determinant is exact to a few ulps of the products, whatever the
        // cancellation; the inverse inherits the conditioning, |F|²/|det F|.
        EXPECT_NEAR(inverse.abs_det, std::abs(det),
                    4e-7 * d.cwiseAbs().maxCoeff() * d.cwiseAbs().maxCoeff());
        const double condition = d.squaredNorm() / std::abs(det);
        EXPECT_LE((inverse.inverse.cast<double>() * d - Eigen::Matrix2d::Identity()).norm(),
                  1e-6 * condition + 1e-6)
            << f;
    }
    Mat2f singular;
    singular << 1.0f, 2.0f, 2.0f, 4.0f;
    EXPECT_EQ(FootprintCone::inverse(singular).abs_det, 0.0f);
    EXPECT_EQ(FootprintCone::inverse(singular).inverse, Mat2f::Zero());
    EXPECT_EQ(FootprintCone::inverse(Mat2f::Identity() * 1e-30f).abs_det, 0.0f);  // 1/det = inf
    Mat2f nan = Mat2f::Identity();
    nan(1, 0) = std::numeric_limits<float>::quiet_NaN();
    EXPECT_EQ(FootprintCone::inverse(nan).abs_det, 0.0f);
}

// ---------------------------------------------------------------------------------------------
// The closed-form 2×2 eigen-decomposition against a long-double reference

/// The eigen-decomposition of the float matrix [[a, b], [b, c]] in long double (64-bit mantissa
/// here: the products of floats are exact). The eigenvalues are the roots of
/// λ² − tr·λ + det = 0 by the stable quadratic formula: the discriminant as (a − c)² + 4b², a
/// sum of squares, the root of larger magnitude from it and the other one from det/root. The
/// eigenvector of the larger eigenvalue is orthogonal to the longer row of A − λ·I.
struct Eigen2Reference {
    long double major = 0.0L;
    long double minor = 0.0L;
    long double axis_x = 1.0L, axis_y = 0.0L;  ///< Unit major axis.
};

Eigen2Reference reference_eigen2(float a, float b, float c) {
    const long double la = a, lb = b, lc = c;
    const long double trace = la + lc;
    const long double det = la * lc - lb * lb;
    const long double root = std::sqrt((la - lc) * (la - lc) + 4.0L * lb * lb);
    Eigen2Reference r;
    if (trace >= 0.0L) {
        r.major = 0.5L * (trace + root);
        r.minor = r.major != 0.0L ? det / r.major : 0.0L;
    } else {
        r.minor = 0.5L * (trace - root);
        r.major = det / r.minor;
    }
    // (A − λ·I)·x = 0: x is orthogonal to both rows (a − λ, b) and (b, c − λ).
    const long double x1 = b, y1 = r.major - la;  // ⟂ the first row
    const long double x2 = r.major - lc, y2 = b;  // ⟂ the second row
    const long double n1 = std::hypot(x1, y1), n2 = std::hypot(x2, y2);
    if (n1 >= n2 && n1 > 0.0L) {
        r.axis_x = x1 / n1;
        r.axis_y = y1 / n1;
    } else if (n2 > 0.0L) {
        r.axis_x = x2 / n2;
        r.axis_y = y2 / n2;
    }
    return r;
}

std::string matrix_text(float a, float b, float c) {
    std::ostringstream os;
    os << std::setprecision(9) << "[[" << a << ", " << b << "], [" << b << ", " << c << "]]";
    return os.str();
}

/// The tolerances of symmetric_eigen2 against the reference on the same float entries. It
/// computes in double, so what it loses is the final rounding to float (2⁻²⁴ ≈ 6e-8 relative
/// per value) and double rounding, ~1e-16 of the major eigenvalue: 2.5e-7 relative covers four
/// half-ulps, 1e-12·major absolute leaves ~4 orders of magnitude of margin over the double
/// error (a float computation would lose ~1e-7·major and fail it). The axis: the float
/// rounding of a unit vector turns it by ~1e-7; double rounding by ~1e-16·major/gap.
constexpr long double kEigenRelative = 2.5e-7L;
constexpr long double kEigenAbsolute = 1e-12L;
constexpr long double kAxisAngle = 2.5e-7L;
constexpr long double kAxisPerCondition = 1e-12L;
/// Below this gap (relative to the major eigenvalue) the axis is not checked: it is ill-defined.
constexpr long double kAxisGap = 1e-5L;

/// The largest errors seen, relative to the bounds (≤ 1 passes).
struct EigenErrors {
    double major = 0.0, minor = 0.0, axis = 0.0;
};

void expect_matches_reference(float a, float b, float c, EigenErrors* worst = nullptr) {
    const SymmetricEigen2 e = symmetric_eigen2(a, b, c);
    const std::string m = matrix_text(a, b, c);
    ASSERT_TRUE(std::isfinite(e.major) && std::isfinite(e.minor) && e.major_axis.allFinite() &&
                e.minor_axis.allFinite())
        << m;
    EXPECT_GE(e.major, e.minor) << m;
    EXPECT_GE(e.minor, 0.0f) << m;
    // Unit, orthogonal axes whatever the matrix.
    EXPECT_NEAR(e.major_axis.norm(), 1.0f, 1e-6f) << m;
    EXPECT_NEAR(e.minor_axis.norm(), 1.0f, 1e-6f) << m;
    EXPECT_NEAR(e.major_axis.dot(e.minor_axis), 0.0f, 1e-6f) << m;

    const Eigen2Reference r = reference_eigen2(a, b, c);
    // A positive semi-definite matrix rounded to float may come out indefinite by ~1e-7·major:
    // the implementation clamps that minor eigenvalue to 0.
    const long double ref_minor = std::max(r.minor, 0.0L);
    const long double major_error = std::abs(e.major - r.major);
    const long double major_bound = kEigenRelative * r.major;
    const long double minor_error = std::abs(e.minor - ref_minor);
    const long double minor_bound = kEigenRelative * ref_minor + kEigenAbsolute * r.major;
    EXPECT_LE(major_error, major_bound) << m << ": " << e.major << " vs " << r.major;
    EXPECT_LE(minor_error, minor_bound) << m << ": " << e.minor << " vs " << r.minor;
    const long double gap = r.major - ref_minor;
    double axis_ratio = 0.0;
    if (gap > kAxisGap * r.major) {
        // sin of the angle between the axes, whatever their signs.
        const long double sine =
            std::abs(e.major_axis.x() * r.axis_y - e.major_axis.y() * r.axis_x);
        const long double bound = kAxisAngle + kAxisPerCondition * r.major / gap;
        EXPECT_LE(sine, bound) << m << ": axis " << e.major_axis.transpose() << " vs " << r.axis_x
                               << " " << r.axis_y;
        axis_ratio = static_cast<double>(sine / bound);
    }
    if (worst != nullptr) {
        worst->major = std::max(worst->major, static_cast<double>(major_error / major_bound));
        if (minor_bound > 0.0L) {
            worst->minor = std::max(worst->minor, static_cast<double>(minor_error / minor_bound));
        }
        worst->axis = std::max(worst->axis, axis_ratio);
    }
}

/// R(θ)·diag(λ1, λ2)·R(θ)ᵀ in long double, rounded to float entries.
std::array<float, 3> rotated_diagonal(long double l1, long double l2, long double theta) {
    const long double cs = std::cos(theta), sn = std::sin(theta);
    return {static_cast<float>(l1 * cs * cs + l2 * sn * sn),
            static_cast<float>((l1 - l2) * cs * sn),
            static_cast<float>(l1 * sn * sn + l2 * cs * cs)};
}

TEST(SymmetricEigen2, MatchesALongDoubleReferenceOnRandomMatrices) {
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    EigenErrors worst;
    double worst_generated_minor = 0.0, worst_generated_axis = 0.0;
    for (int i = 0; i < 5000; ++i) {
        const long double l1 = std::pow(10.0L, -12.0L + 24.0L * uniform(rng));
        const long double l2 = l1 * std::pow(10.0L, -10.0L * uniform(rng));
        const long double theta = 2.0L * static_cast<long double>(kPi) * uniform(rng);
        const auto [a, b, c] = rotated_diagonal(l1, l2, theta);
        expect_matches_reference(a, b, c, &worst);
        // Against the eigenvalues the matrix was built with: rounding the entries to float
        // moves them by up to ‖δA‖₂ ≤ ‖δA‖_F ≤ 2⁻²⁴·√2·λ1 (Weyl) — that, not the
        // decomposition, limits how well the minor eigenvalue of a thin ellipse is known —
        // and the axis by ‖δA‖/(λ1 − λ2) (Davis–Kahan).
        const SymmetricEigen2 e = symmetric_eigen2(a, b, c);
        const long double input = 1.2e-7L * l1;
        const long double minor_bound = input + kEigenRelative * l2;
        EXPECT_LE(std::abs(e.minor - l2), minor_bound) << matrix_text(a, b, c);
        worst_generated_minor = std::max(worst_generated_minor,
                                         static_cast<double>(std::abs(e.minor - l2) / minor_bound));
        if (l1 - l2 > kAxisGap * l1) {
            const long double sine =
                std::abs(e.major_axis.x() * std::sin(theta) - e.major_axis.y() * std::cos(theta));
            const long double bound = 2.0L * input / (l1 - l2) + kAxisAngle;
            EXPECT_LE(sine, bound) << matrix_text(a, b, c);
            worst_generated_axis =
                std::max(worst_generated_axis, static_cast<double>(sine / bound));
        }
    }
    RecordProperty("worst_major_over_bound", std::to_string(worst.major));
    RecordProperty("worst_minor_over_bound", std::to_string(worst.minor));
    RecordProperty("worst_axis_over_bound", std::to_string(worst.axis));
    RecordProperty("worst_generated_minor_over_bound", std::to_string(worst_generated_minor));
    RecordProperty("worst_generated_axis_over_bound", std::to_string(worst_generated_axis));
}

TEST(SymmetricEigen2, StaysFiniteAndAccurateOnAdversarialMatrices) {
    std::mt19937_64 rng(22);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    // Nearly collinear axes: F·Fᵀ for F whose columns are δ apart, in long double and in float
    // (as ellipse_of forms it), at unit, huge and tiny scales.
    for (const long double delta : {1e-3L, 1e-4L, 1e-5L, 1e-6L, 1e-7L}) {
        for (const long double scale : {1.0L, 1e12L, 1e-12L}) {
            for (int k = 0; k < 20; ++k) {
                const long double phi = 2.0L * static_cast<long double>(kPi) * uniform(rng);
                const long double s1 = scale * std::pow(10.0L, uniform(rng) * 2.0L - 1.0L);
                const long double s2 = scale * std::pow(10.0L, uniform(rng) * 2.0L - 1.0L);
                const long double f00 = s1 * std::cos(phi), f10 = s1 * std::sin(phi);
                const long double f01 = s2 * std::cos(phi + delta),
                                  f11 = s2 * std::sin(phi + delta);
                const long double a = f00 * f00 + f01 * f01, b = f00 * f10 + f01 * f11,
                                  c = f10 * f10 + f11 * f11;
                SCOPED_TRACE(::testing::Message() << "delta " << static_cast<double>(delta)
                                                  << " scale " << static_cast<double>(scale));
                expect_matches_reference(static_cast<float>(a), static_cast<float>(b),
                                         static_cast<float>(c));
                // The whole path from a float F: its product rounds each entry by ~2⁻²⁴ of |F|²,
                // so against the exact eigenvalues of F·Fᵀ the minor one is known only to
                // ~1e-7·major absolute (it is ~δ²·major/4 here, below that for δ ≤ 1e-4).
                Mat2f f;
                f << static_cast<float>(f00), static_cast<float>(f01), static_cast<float>(f10),
                    static_cast<float>(f11);
                const Eigen::Matrix2d fd = f.cast<double>();
                const Eigen::Matrix2d exact = fd * fd.transpose();
                const Eigen2Reference r = reference_eigen2(static_cast<float>(exact(0, 0)),
                                                           static_cast<float>(exact(0, 1)),
                                                           static_cast<float>(exact(1, 1)));
                const SymmetricEigen2 e = FootprintCone::ellipse_of(f);
                ASSERT_TRUE(std::isfinite(e.major) && std::isfinite(e.minor) &&
                            e.major_axis.allFinite());
                EXPECT_GE(e.minor, 0.0f);
                EXPECT_GE(e.major, e.minor);
                EXPECT_LE(std::abs(e.major - r.major), 1e-6L * r.major);
                EXPECT_LE(std::abs(e.minor - std::max(r.minor, 0.0L)), 3e-7L * r.major);
                // Both columns lie within δ of the major axis.
                const long double sine =
                    std::abs(e.major_axis.x() * std::sin(phi) - e.major_axis.y() * std::cos(phi));
                EXPECT_LE(sine, delta + 1e-6L);
            }
        }
    }
    // Exactly equal eigenvalues: multiples of the identity, with b = 0 and with b tiny.
    for (const float k : {1e-30f, 1e-12f, 1.0f, 3.7f, 1e12f, 1e30f}) {
        const SymmetricEigen2 e = symmetric_eigen2(k, 0.0f, k);
        EXPECT_EQ(e.major, k);
        EXPECT_EQ(e.minor, k);
        expect_matches_reference(k, 0.0f, k);
        for (const float tiny :
             {k * 1e-20f, -k * 1e-20f, k * 1e-7f, std::numeric_limits<float>::denorm_min()}) {
            expect_matches_reference(k, tiny, k);
        }
    }
    // Diagonal: b = 0 with a < c and a > c; the axes are exactly the coordinate axes.
    for (const auto& [a, c] :
         {std::pair{1.0f, 2.0f}, std::pair{2.0f, 1.0f}, std::pair{1e-12f, 1e12f},
          std::pair{1e12f, 1e-12f}, std::pair{0.0f, 5.0f}, std::pair{5.0f, 0.0f}}) {
        const SymmetricEigen2 e = symmetric_eigen2(a, 0.0f, c);
        EXPECT_EQ(e.major, std::max(a, c));
        EXPECT_EQ(e.minor, std::min(a, c));
        EXPECT_EQ(std::abs(e.major_axis.x()), a > c ? 1.0f : 0.0f) << a << " " << c;
        EXPECT_EQ(std::abs(e.major_axis.y()), a > c ? 0.0f : 1.0f) << a << " " << c;
        expect_matches_reference(a, 0.0f, c);
    }
    // a = c with b ≠ 0: eigenvalues a ± |b|, axes along the diagonals.
    for (const float b : {0.5f, -0.5f, 1.0f, -1.0f, 1e-7f, 1e-3f}) {
        const SymmetricEigen2 e = symmetric_eigen2(1.0f, b, 1.0f);
        EXPECT_NEAR(e.major, 1.0f + std::abs(b), 1e-7f);
        EXPECT_NEAR(e.minor, 1.0f - std::abs(b), 1e-7f);
        const float s = std::sqrt(0.5f);
        EXPECT_NEAR(std::abs(e.major_axis.dot(Vec2f(s, b > 0.0f ? s : -s))), 1.0f, 1e-6f) << b;
        expect_matches_reference(1.0f, b, 1.0f);
        expect_matches_reference(3e11f, 3e11f * b, 3e11f);
    }
    // The zero matrix.
    const SymmetricEigen2 zero = symmetric_eigen2(0.0f, 0.0f, 0.0f);
    EXPECT_EQ(zero.major, 0.0f);
    EXPECT_EQ(zero.minor, 0.0f);
    expect_matches_reference(0.0f, 0.0f, 0.0f);
    // Huge and tiny scales of random positive semi-definite matrices (1e±30: the squares of
    // the entries leave float's range, not double's).
    for (const long double scale : {1e12L, 1e-12L, 1e30L, 1e-30L}) {
        for (int k = 0; k < 200; ++k) {
            const long double l1 = scale * (1.0L + 9.0L * uniform(rng));
            const long double l2 = l1 * std::pow(10.0L, -10.0L * uniform(rng));
            const auto [a, b, c] =
                rotated_diagonal(l1, l2, 2.0L * static_cast<long double>(kPi) * uniform(rng));
            SCOPED_TRACE(::testing::Message() << "scale " << static_cast<double>(scale));
            expect_matches_reference(a, b, c);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The blur cone: convolved Gaussians, add_blur, the aperture of depth of field

/// A random footprint matrix of the kinds the tracer makes: generic, singular (parallel
/// columns), nearly collinear, zero, at scales from 10^lowest to 10^highest. The closed-form
/// root of convolved() and widened() takes det(F·Fᵀ + B·Bᵀ) in float, which underflows for
/// entries of F below ~1e-10 and overflows above ~4e9 (see the report of these tests): the
/// scales stay well inside that range.
Mat2f random_footprint(std::mt19937_64& rng, int kind, float lowest = -6.0f, float highest = 6.0f) {
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    Mat2f f;
    f << uniform(rng), uniform(rng), uniform(rng), uniform(rng);
    switch (kind % 5) {
        case 1:
            f.col(1) = f.col(0) * uniform(rng);
            break;
        case 2:
            f.col(1) = f.col(0) * (1.0f + 1e-4f * uniform(rng));
            break;
        case 3:
            f = Mat2f::Zero();
            break;
        default:
            break;
    }
    return f * std::pow(10.0f, lowest + (highest - lowest) * 0.5f * (uniform(rng) + 1.0f));
}

/// ‖G·Gᵀ − expected‖ relative to ‖expected‖ (0 when both are 0).
double relative_square_error(const Mat2f& g, const Eigen::Matrix2d& expected) {
    const double error = (squared(g) - expected).norm();
    return error == 0.0 ? 0.0 : error / expected.norm();
}

TEST(FootprintBlur, ConvolvedAddsTheSquaredMatrices) {
    std::mt19937_64 rng(23);
    double worst = 0.0;
    for (int i = 0; i < 4000; ++i) {
        const Mat2f f = random_footprint(rng, i);
        const Mat2f b = i % 7 == 0 ? Mat2f::Zero() : random_footprint(rng, i / 5);
        const Mat2f g = FootprintCone::convolved(f, b);
        ASSERT_TRUE(g.allFinite()) << f << "\n" << b;
        EXPECT_EQ(g(0, 1), g(1, 0));
        const Eigen::Matrix2d expected = squared(f) + squared(b);
        // Float rounding of the products, the sum and the closed-form root: a few ulps of the
        // largest entry.
        const double error = relative_square_error(g, expected);
        EXPECT_LE(error, 2e-6) << "F " << f << "\nB " << b;
        worst = std::max(worst, error);
    }
    RecordProperty("worst_relative_error", std::to_string(worst));
    EXPECT_EQ(FootprintCone::convolved(Mat2f::Zero(), Mat2f::Zero()), Mat2f::Zero());
    // B = 0 keeps F's ellipse, F = 0 gives B's.
    Mat2f f;
    f << 2.0f, 0.5f, -1.0f, 0.25f;
    EXPECT_LE(relative_square_error(FootprintCone::convolved(f, Mat2f::Zero()), squared(f)), 1e-6);
    EXPECT_LE(relative_square_error(FootprintCone::convolved(Mat2f::Zero(), f), squared(f)), 1e-6);
}

TEST(FootprintBlur, ABlurredConeAddsItsBlurAtEveryDepth) {
    std::mt19937_64 rng(24);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    for (int i = 0; i < 500; ++i) {
        FootprintCone cone;
        cone.start_dev = i % 3 == 0 ? Mat2f::Zero() : random_footprint(rng, i);
        cone.incr_dev = random_footprint(rng, i / 3);
        const std::array<float, 6> ts = {0.0f, 1e-3f, 0.5f, 1.0f, 7.5f, 1e3f * uniform(rng)};
        // Unblurred, at(t) is the pixel cone exactly.
        ASSERT_FALSE(cone.blurred);
        for (const float t : ts) {
            EXPECT_EQ(cone.at(t), cone.pixel_at(t));
            EXPECT_EQ(cone.pixel_at(t), Mat2f(cone.start_dev + t * cone.incr_dev));
        }
        const Mat2f blur_start = i % 4 == 0 ? Mat2f::Zero() : random_footprint(rng, i / 2);
        const Mat2f blur_incr = random_footprint(rng, i / 4);
        cone.add_blur(blur_start, blur_incr);
        EXPECT_TRUE(cone.blurred);
        EXPECT_EQ(cone.blur_start, blur_start);
        EXPECT_EQ(cone.blur_incr, blur_incr);
        for (const float t : ts) {
            const Mat2f b = blur_start + t * blur_incr;
            const Eigen::Matrix2d expected = squared(cone.pixel_at(t)) + squared(b);
            EXPECT_LE(relative_square_error(cone.at(t), expected), 2e-6) << "t " << t;
        }
        // A second blur: exact at t = 0 (and as t → ∞), approximate in between.
        const Mat2f second_start = random_footprint(rng, i);
        const Mat2f second_incr = random_footprint(rng, i + 1);
        const FootprintCone once = cone;
        cone.add_blur(second_start, second_incr);
        EXPECT_LE(
            relative_square_error(cone.at(0.0f), squared(once.at(0.0f)) + squared(second_start)),
            5e-6);
    }
}

TEST(FootprintBlur, TheApertureConeVanishesInFocusAndNeverShrinksTheFootprint) {
    std::mt19937_64 rng(25);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    for (int i = 0; i < 300; ++i) {
        // A thin-lens pixel cone (from the lens point: no start) or a general one.
        FootprintCone cone;
        // Pixel angles of 1e-4 to 1e-2, pixel footprints at the lens of 1e-4 to 0.1.
        cone.incr_dev = random_footprint(rng, i % 5 == 3 ? 0 : i, -4.0f, -2.0f);
        if (i % 2 == 1) {
            cone.start_dev = random_footprint(rng, i / 2, -4.0f, -1.0f);
        }
        const FootprintCone pixel = cone;
        const float focus = std::pow(10.0f, 4.0f * uniform(rng) - 1.0f);
        const float b = std::pow(10.0f, 3.0f * uniform(rng) - 3.0f);  // aperture / √2
        cone.add_blur(b * Mat2f::Identity(), (-b / focus) * Mat2f::Identity());
        // In focus: B(f) = b − f·(b/f) is zero up to the rounding of b/f, a few ulps of b.
        const float residual = 4.0f * std::numeric_limits<float>::epsilon() * b;
        const Eigen::Matrix2d in_focus = squared(pixel.at(focus));
        EXPECT_LE((squared(cone.at(focus)) - in_focus).norm(),
                  2e-6 * in_focus.norm() + 2.0 * residual * residual)
            << "focus " << focus << " b " << b << "\n"
            << pixel.at(focus);
        // Never smaller than the pixel cone: G·Gᵀ = F·Fᵀ + B·Bᵀ ⪰ F·Fᵀ, so both eigenvalues are
        // at least the pixel cone's (Weyl), up to float rounding of F·Fᵀ.
        for (const float s : {0.0f, 0.25f, 0.5f, 0.9f, 0.999f, 1.0f, 1.001f, 1.1f, 2.0f, 10.0f}) {
            const float t = s * focus;
            const SymmetricEigen2 blurred = cone.ellipse(t);
            const SymmetricEigen2 sharp = pixel.ellipse(t);
            const float slack = 2e-6f * sharp.major;
            EXPECT_GE(blurred.major, sharp.major - slack) << "t " << t << " focus " << focus;
            EXPECT_GE(blurred.minor, sharp.minor - slack) << "t " << t << " focus " << focus;
        }
        // At the lens the blur is the aperture's.
        EXPECT_GE(cone.ellipse(0.0f).minor, 0.999f * b * b);
    }
}

/// The blurred cone's footprint at t in double: the symmetric root of F·Fᵀ + B·Bᵀ by an
/// eigen-decomposition, independent of the closed form under test.
Eigen::Matrix2d root_in_double(const FootprintCone& cone, double t) {
    const Eigen::Matrix2d f = cone.start_dev.cast<double>() + t * cone.incr_dev.cast<double>();
    const Eigen::Matrix2d b = cone.blur_start.cast<double>() + t * cone.blur_incr.cast<double>();
    const Eigen::Matrix2d sum = f * f.transpose() + b * b.transpose();
    return Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(sum).operatorSqrt();
}

/// d root_in_double/dt by a central difference: truncation h²·G‴/6 and rounding 1e-16·G/h are
/// both below 1e-9 of G′ at h = 1e-5 of the depth's scale.
Eigen::Matrix2d growth_in_double(const FootprintCone& cone, double t) {
    const double h = 1e-5 * std::max(std::abs(t), 1.0);
    return (root_in_double(cone, t + h) - root_in_double(cone, t - h)) / (2.0 * h);
}

/// ‖growth_at(t) − the double difference‖ relative to the latter's norm.
double growth_error(const FootprintCone& cone, float t) {
    const Eigen::Matrix2d expected = growth_in_double(cone, t);
    const Eigen::Matrix2d got = cone.growth_at(t).cast<double>();
    return (got - expected).norm() / std::max(expected.norm(), 1e-300);
}

TEST(FootprintBlur, GrowthIsTheDerivativeOfTheConvolvedFootprint) {
    // The blurred cones the tracer makes, at depths across their length.
    Mat2f pixel;
    pixel << 2e-3f, 3e-4f, -5e-4f, 1.5e-3f;
    Mat2f ellipse;
    ellipse << 0.4f, 0.1f, -0.05f, 0.25f;
    // A shadow cone to an elliptical light 5 away: the hit's footprint shrinking to the light,
    // the light's ellipse growing from the hit.
    FootprintCone shadow;
    shadow.start_dev = 40.0f * pixel;
    shadow.incr_dev = -shadow.start_dev / 5.0f;
    shadow.add_blur(Mat2f::Zero(), ellipse / (std::sqrt(2.0f) * 5.0f));
    // Depth of field: the pixel cone from the lens, the aperture's cone vanishing in focus at 3.
    FootprintCone lens;
    lens.incr_dev = pixel;
    lens.add_blur(0.05f * Mat2f::Identity(), (-0.05f / 3.0f) * Mat2f::Identity());
    // A rough reflection: the reflected footprint widened radially.
    FootprintCone glossy;
    glossy.start_dev = 10.0f * pixel;
    glossy.incr_dev = 3.0f * pixel.transpose();
    glossy.add_blur(Mat2f::Zero(), std::sqrt(2.0f) * 0.05f * Mat2f::Identity());
    for (const float t : {0.01f, 0.5f, 1.0f, 2.5f, 4.0f, 4.99f}) {
        EXPECT_LE(growth_error(shadow, t), 1e-4) << "shadow cone at t " << t;
    }
    for (const float t : {0.0f, 0.1f, 1.0f, 2.9f, 3.0f, 3.1f, 10.0f, 100.0f}) {
        EXPECT_LE(growth_error(lens, t), 1e-4) << "lens cone at t " << t;
    }
    for (const float t : {0.0f, 0.01f, 1.0f, 30.0f}) {
        EXPECT_LE(growth_error(glossy, t), 1e-4) << "glossy cone at t " << t;
    }
    // A footprint collapsed to a segment (F and B of rank one along one axis): C is singular, the
    // root's derivative along the segment is d√a/dt = a′/(2√a), zero across it.
    FootprintCone segment;
    segment.start_dev << 1.0f, 0.0f, 0.0f, 0.0f;
    segment.incr_dev << 0.5f, 0.0f, 0.0f, 0.0f;
    segment.add_blur(Mat2f::Zero(), segment.incr_dev);
    // a(1) = 1.5² + 0.5² = 2.5, a′(1) = 2·1.5·0.5 + 2·0.5·0.5 = 2.
    const Mat2f along = segment.growth_at(1.0f);
    EXPECT_NEAR(along(0, 0), 2.0 / (2.0 * std::sqrt(2.5)), 1e-6);
    EXPECT_EQ(along(0, 1), 0.0f);
    EXPECT_EQ(along(1, 1), 0.0f);
    // Unblurred, the growth is the increment itself.
    FootprintCone plain;
    plain.start_dev = pixel;
    plain.incr_dev = 2.0f * pixel;
    EXPECT_EQ(plain.growth_at(3.0f), plain.incr_dev);
}

TEST(FootprintBlur, GrowthMatchesADoubleDifferenceOnRandomCones) {
    std::mt19937_64 rng(26);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    double worst = 0.0;
    for (int i = 0; i < 4000; ++i) {
        // Full-rank footprints and blurs (kinds 0 and 4 of random_footprint), so that
        // F·Fᵀ + B·Bᵀ is invertible and its root differentiable, over twelve decades of scale
        // and four of depth; the pixel cone and the blur within three decades of each other at
        // that depth, as the tracer's are (beyond, the smaller one is below float rounding of
        // the larger in both the closed form and the reference).
        const int kind = i % 2 == 0 ? 0 : 4;
        const float scale = 12.0f * uniform(rng) - 6.0f;
        const float depth = 4.0f * uniform(rng) - 2.0f;
        FootprintCone cone;
        cone.start_dev = random_footprint(rng, kind, scale - 1.5f, scale + 1.5f);
        cone.incr_dev = random_footprint(rng, kind, scale - depth - 1.5f, scale - depth + 1.5f);
        cone.add_blur(random_footprint(rng, kind, scale - 1.5f, scale + 1.5f),
                      random_footprint(rng, kind, scale - depth - 1.5f, scale - depth + 1.5f));
        const float t = std::pow(10.0f, depth) * 2.0f * uniform(rng);
        const Mat2f growth = cone.growth_at(t);
        ASSERT_TRUE(growth.allFinite()) << "t " << t;
        EXPECT_EQ(growth(0, 1), growth(1, 0));
        // The shader's one-decomposition footprint is the traversal's at(t), to the bit.
        EXPECT_EQ(cone.local_at(t).footprint, cone.at(t)) << "t " << t;
        const double error = growth_error(cone, t);
        // Float rounding of C and of the root, amplified where the footprint is thin: the
        // minor axis's derivative divides by its own root.
        EXPECT_LE(error, 5e-4) << "t " << t << "\nF0 " << cone.start_dev << "\ndF " << cone.incr_dev
                               << "\nB0 " << cone.blur_start << "\ndB " << cone.blur_incr;
        worst = std::max(worst, error);
    }
    RecordProperty("worst_relative_error", std::to_string(worst));
}

// ---------------------------------------------------------------------------------------------
// The anisotropy clamp that also returns the clamped ellipse

TEST(FootprintCone, AnisotropyClampReturnsTheClampedEllipse) {
    std::mt19937_64 rng(26);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    int clamped_count = 0;
    for (int i = 0; i < 4000; ++i) {
        const Mat2f f = random_footprint(rng, i);
        const float anisotropy =
            i % 11 == 0 ? 1.0f : (i % 13 == 0 ? 1e4f : 1.0f + 31.0f * uniform(rng));
        SymmetricEigen2 e;
        const Mat2f clamped = FootprintCone::clamp_anisotropy(f, anisotropy, e);
        EXPECT_EQ(clamped, FootprintCone::clamp_anisotropy(f, anisotropy));
        ASSERT_TRUE(clamped.allFinite());
        clamped_count += clamped == f ? 0 : 1;
        // The floor exactly as the clamp computes it.
        EXPECT_GE(e.minor, e.major / (anisotropy * anisotropy)) << f << "\nA " << anisotropy;
        const SymmetricEigen2 recomputed = FootprintCone::ellipse_of(clamped);
        // Both come from float products of the same matrix (or of its clamped columns): the
        // eigenvalues agree to float rounding of the largest one.
        EXPECT_NEAR(e.major, recomputed.major, 1e-6f * e.major) << f << "\nA " << anisotropy;
        EXPECT_NEAR(e.minor, recomputed.minor, 1e-6f * e.major) << f << "\nA " << anisotropy;
        // The axis is an eigenvector of the returned ellipse whatever the gap, and equals the
        // recomputed one up to sign where the gap makes it well defined.
        const Eigen::Matrix2d c = squared(clamped);
        const Eigen::Vector2d axis = e.major_axis.cast<double>();
        EXPECT_LE((c * axis - static_cast<double>(e.major) * axis).norm(), 2e-6 * e.major)
            << f << "\nA " << anisotropy;
        if (e.major - e.minor > 1e-3f * e.major) {
            EXPECT_NEAR(std::abs(e.major_axis.dot(recomputed.major_axis)), 1.0f, 1e-5f)
                << f << "\nA " << anisotropy;
        }
        // The returned matrix itself keeps to the limit, to float rounding.
        EXPECT_GE(recomputed.minor,
                  recomputed.major / (anisotropy * anisotropy) - 1e-6f * recomputed.major);
    }
    EXPECT_GT(clamped_count, 1000);
}

}  // namespace
}  // namespace mrt
