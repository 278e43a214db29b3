// The Cornell box as it is distributed (an OBJ with its MTL library and an emissive quad for a
// light), rendered by whitted and distributed against independent expectations: the floor's
// radiance where it sees the whole light, from the closed form of a parallel rectangle's form
// factor, and the red and green walls' radiance where directly lit, from a brute-force double
// quadrature of the light's irradiance. Whitted's lighting is exact where the light is wholly
// visible; distributed must agree within its own noise.

#include "common/scene_io/scene_loader.h"
#include "tests/support/test_support.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/raytrace/distributed.h"
#include "trace/raytrace/whitted.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

namespace mrt {
namespace {

namespace fs = std::filesystem;

// The light of CornellBox-Original.obj: y = 1.98, x ∈ [−0.24, 0.23], z ∈ [−0.22, 0.16], facing
// down, with the radiance of its MTL's Ke.
constexpr double kLightY = 1.98;
constexpr double kLightX0 = -0.24, kLightX1 = 0.23;
constexpr double kLightZ0 = -0.22, kLightZ1 = 0.16;
const Rgb kLightRadiance(17.0f, 12.0f, 4.0f);

/// Form factor from a point to a parallel rectangle [0, a] × [0, b] at height h whose corner is
/// straight above it (Howell's catalogue, C-11).
double corner_form_factor(double a, double b, double h) {
    const double x = a / h;
    const double y = b / h;
    const double sx = std::sqrt(1.0 + x * x);
    const double sy = std::sqrt(1.0 + y * y);
    return (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2.0 * std::numbers::pi);
}

/// Irradiance per unit radiance (π × the form factor) at the floor point (px, 0, pz), from the
/// light, by corner decomposition.
double floor_irradiance_per_radiance(double px, double pz) {
    const auto f = [&](double x, double z) {
        const double dx = x - px;
        const double dz = z - pz;
        const double sign = (dx < 0.0 ? -1.0 : 1.0) * (dz < 0.0 ? -1.0 : 1.0);
        return sign * corner_form_factor(std::abs(dx), std::abs(dz), kLightY);
    };
    return std::numbers::pi * (f(kLightX1, kLightZ1) - f(kLightX0, kLightZ1) -
                               f(kLightX1, kLightZ0) + f(kLightX0, kLightZ0));
}

/// Irradiance per unit radiance at p with unit normal n from the light, by midpoint quadrature
/// of cos θ_receiver · cos θ_light / d² over the light's area (double precision).
double quadrature_irradiance_per_radiance(const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
    constexpr int kSteps = 800;
    const double dx = (kLightX1 - kLightX0) / kSteps;
    const double dz = (kLightZ1 - kLightZ0) / kSteps;
    double sum = 0.0;
    for (int i = 0; i < kSteps; ++i) {
        for (int j = 0; j < kSteps; ++j) {
            const Eigen::Vector3d q(kLightX0 + (i + 0.5) * dx, kLightY, kLightZ0 + (j + 0.5) * dz);
            const Eigen::Vector3d d = q - p;
            const double r2 = d.squaredNorm();
            const double cos_receiver = std::max(0.0, n.dot(d)) / std::sqrt(r2);
            const double cos_light = std::max(0.0, d.y()) / std::sqrt(r2);  // light faces −y
            sum += cos_receiver * cos_light / r2;
        }
    }
    return sum * dx * dz;
}

class CornellBox : public ::testing::Test {
  protected:
    void SetUp() override {
        m_obj = testing::find_data_file("meshes/cornell-box/CornellBox-Original.obj");
        if (!m_obj) {
            GTEST_SKIP() << "the shared data's Cornell box is not on the data path";
        }
    }

    /// The box seen by a camera at `eye` looking at `at` through a narrow field of view, so that
    /// every pixel sees the same few millimetres around `at`.
    Scene box_looking_at(const Vec3f& eye, const Vec3f& at, const Vec3f& up) const {
        const fs::path file = m_dir.path() / "cornell.json";
        testing::write_file(
            file,
            fmt::format(
                R"({{"camera": {{"eye": [{}, {}, {}], "look_at": [{}, {}, {}], "up": [{}, {}, {}],
                            "fov": 0.3, "resolution": [8, 8]}},
                "objects": [{{"shape": "mesh", "file": "{}", "crease_angle": 60}}]}})",
                eye.x(), eye.y(), eye.z(), at.x(), at.y(), at.z(), up.x(), up.y(), up.z(),
                m_obj->string()));
        return load_scene(file);
    }

    struct Rendered {
        Rgb whitted;
        Rgb distributed;
        Rgb distributed_error;  ///< Standard error of the distributed mean.
    };

    static Rendered render(const Scene& scene) {
        const SceneBvh bvh(scene);
        RenderOptions options = testing::camera_options(scene);
        options.threads = 2;
        Rendered r;
        const Image whitted = render_whitted(scene, bvh, options).image;
        const Image distributed =
            render_distributed(scene, bvh, options,
                               {.sampling = DistributedSampling::Fixed, .spp = 64})
                .image;
        Rgb sum = Rgb::Zero();
        Rgb squares = Rgb::Zero();
        r.whitted = Rgb::Zero();
        const int n = whitted.width() * whitted.height();
        for (int y = 0; y < whitted.height(); ++y) {
            for (int x = 0; x < whitted.width(); ++x) {
                r.whitted += whitted.at(x, y) / static_cast<float>(n);
                sum += distributed.at(x, y);
                squares += distributed.at(x, y).square();
            }
        }
        r.distributed = sum / static_cast<float>(n);
        const Rgb variance = (squares / static_cast<float>(n) - r.distributed.square()).max(0.0f);
        r.distributed_error = (variance / static_cast<float>(n - 1)).sqrt();
        return r;
    }

    static void expect_near(const Rgb& value, const Rgb& expected, const Rgb& tolerance,
                            const char* what) {
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(value[c], expected[c], tolerance[c]) << what << ", channel " << c;
        }
    }

    std::optional<fs::path> m_obj;
    testing::ScratchDirectory m_dir{"cornell"};
};

TEST_F(CornellBox, FloorSeeingTheWholeLightHasTheFormFactorsRadiance) {
    // Behind the tall box and beside the short one: every line to the light is clear.
    const Vec3f floor(0.5f, 0.0f, -0.7f);
    const Scene scene = box_looking_at(floor + Vec3f(0.0f, 1.0f, 0.0f), floor, Vec3f(0, 0, -1));
    const Rgb albedo(0.725f, 0.71f, 0.68f);
    const double e = floor_irradiance_per_radiance(floor.x(), floor.z());
    const Rgb expected = albedo * kLightRadiance * static_cast<float>(e / std::numbers::pi);
    // The quadrature agrees with the closed form (a check of the reference itself).
    EXPECT_NEAR(quadrature_irradiance_per_radiance(floor.cast<double>(), {0, 1, 0}), e, 1e-5 * e);

    const Rendered r = render(scene);
    // The pixels see ±3 mm of the point, over which the irradiance varies by < 1e-4.
    expect_near(r.whitted, expected, expected * 2e-3f, "whitted");
    expect_near(r.distributed, expected, 4.0f * r.distributed_error + expected * 2e-3f,
                "distributed");
    EXPECT_LT((r.distributed_error / expected).maxCoeff(), 0.02f) << "the test must be sharp";
}

TEST_F(CornellBox, WallsDirectlyLitShowTheirMtlColours) {
    struct Wall {
        const char* name;
        Vec3f point;
        Vec3f normal;
        Rgb albedo;
    };
    const Wall walls[] = {
        // The left wall is not flat (x from −0.99 to −1.02): this point is on its triangle
        // (−1.01, 0, 0.99), (−1.02, 1.99, −1.04), (−1.02, 1.99, 0.99), whose normal is
        // (1.99·2.03, 0.01·2.03, 0) normalised.
        {"red", Vec3f(-1.01f - 1.6f * 0.0203f / 4.0397f, 1.6f, 0.3f),
         Vec3f(4.0397f, 0.0203f, 0.0f).normalized(), Rgb(0.63f, 0.065f, 0.05f)},
        {"green", Vec3f(1.0f, 1.6f, 0.3f), Vec3f(-1, 0, 0), Rgb(0.14f, 0.45f, 0.091f)},
    };
    for (const Wall& wall : walls) {
        SCOPED_TRACE(wall.name);
        const Scene scene =
            box_looking_at(wall.point + 0.5f * wall.normal, wall.point, Vec3f(0, 1, 0));
        const double e = quadrature_irradiance_per_radiance(wall.point.cast<double>(),
                                                            wall.normal.cast<double>());
        const Rgb expected =
            wall.albedo * kLightRadiance * static_cast<float>(e / std::numbers::pi);
        const Rendered r = render(scene);
        expect_near(r.whitted, expected, expected * 0.01f, "whitted");
        expect_near(r.distributed, expected, 4.0f * r.distributed_error + expected * 0.01f,
                    "distributed");
    }
}

}  // namespace
}  // namespace mrt
