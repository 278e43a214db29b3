// Ray differentials against finite differences of offset rays traced independently in double
// precision: transfer onto a plane, reflection off a sphere and off a normal-interpolated
// triangle, refraction through a glass sphere and a normal-interpolated triangle; the error of
// a forward difference halves with its offset. Plus texture-coordinate derivatives against the
// analytic perspective mapping, the stable 2×2 eigen-decomposition, the anisotropy clamp, the
// widened footprint and the compensated inverse against double precision, and stiff cases that
// must stay finite.

#include "common/footprint.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
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
                                     rd.dp_dx, rd.dp_dy, flip);
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
        triangle_differential(p, n, uv, 0.3f, 0.3f, Vec3f(1, 0, 0), Vec3f(0, 0, 1), false);
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
// Widening and inverting footprints (common/point_weight.h reads both)

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

}  // namespace
}  // namespace mrt
