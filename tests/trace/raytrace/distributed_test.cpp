// The distributed ray tracer against independent references: the penumbra of a disc light
// behind a straight edge (1D quadrature of the closed-form inner integral), convergence rate,
// the reference's own error estimate, the time budget, adaptivity, determinism, and the
// invariants of depth of field and glossy reflection.

#include "trace/raytrace/distributed.h"

#include "common/image/image_metrics.h"
#include "common/scene_io/scene_loader.h"
#include "common/texture/texture.h"
#include "tests/support/test_support.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/raytrace/ray_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace mrt {
namespace {

// A disc light of radius R at height H facing down onto the plane y = 0 (albedo ρ), and an
// opaque square at height h whose edge lies over x = 0, covering x < 0.
constexpr double kLightRadius = 1.0;
constexpr double kLightHeight = 4.0;
constexpr double kOccluderHeight = 2.0;
constexpr double kRadiance = 3.0;
constexpr double kAlbedo = 0.5;

std::string penumbra_scene_json(const std::string& camera) {
    return R"({
  "camera": )" +
           camera +
           R"(,
  "background": [0, 0, 0],
  "ambient": [0, 0, 0],
  "max_depth": 2,
  "materials": {"floor": {"diffuse": [0.5, 0.5, 0.5]}, "blocker": {"diffuse": [0.2, 0.3, 0.4]}},
  "lights": [{"type": "ellipse", "center": [0, 4, 0], "semi_axis_u": [1, 0, 0],
              "semi_axis_v": [0, 0, 1], "radiance": [3, 3, 3]}],
  "objects": [
    {"shape": "quad", "size": [40, 40], "material": "floor"},
    {"shape": "quad", "size": [20, 20], "material": "blocker",
     "transform": {"translate": [-10, 2, 0]}}
  ]
})";
}

Scene penumbra_scene(int width = 40, int height = 30) {
    return parse_scene(penumbra_scene_json(R"({"eye": [2.5, 7, 6], "look_at": [0.3, 0, 0],
        "fov": 40, "resolution": [)" + std::to_string(width) +
                                           ", " + std::to_string(height) + "]}"),
                       "penumbra.json");
}

/// Irradiance at (x, 0, 0) from the disc light, the part with light x-coordinate < −x hidden
/// by the occluder (the segment to light point q crosses y = h at x/2 + q_x/2 for h = H/2).
/// E = L ∫∫ H² / d⁴ dA; the inner integral over z is closed-form:
/// ∫ dz/(a²+z²)² = z/(2a²(a²+z²)) + atan(z/a)/(2a³), a² = (q_x − x)² + H².
double penumbra_irradiance(double x) {
    const double lower = std::max(-x, -kLightRadius);
    if (lower >= kLightRadius) {
        return 0.0;
    }
    const auto inner = [&](double qx) {
        const double z = std::sqrt(std::max(0.0, kLightRadius * kLightRadius - qx * qx));
        const double a2 = (qx - x) * (qx - x) + kLightHeight * kLightHeight;
        const double a = std::sqrt(a2);
        return 2.0 * (z / (2.0 * a2 * (a2 + z * z)) + std::atan(z / a) / (2.0 * a2 * a));
    };
    // Simpson's rule after substituting q_x = R·sin θ removes the square-root end points.
    const double t0 = std::asin(lower / kLightRadius);
    const double t1 = std::numbers::pi / 2.0;
    const int n = 20000;
    const double step = (t1 - t0) / n;
    double sum = 0.0;
    for (int i = 0; i <= n; ++i) {
        const double t = t0 + i * step;
        const double w = (i == 0 || i == n) ? 1.0 : (i % 2 == 1 ? 4.0 : 2.0);
        sum += w * inner(kLightRadius * std::sin(t)) * kLightRadius * std::cos(t);
    }
    return kRadiance * kLightHeight * kLightHeight * sum * step / 3.0;
}

/// Closed-form irradiance of an unoccluded disc on a parallel plane at lateral offset x.
double disc_irradiance(double x) {
    const double r2 = kLightRadius * kLightRadius;
    const double h2 = kLightHeight * kLightHeight;
    return std::numbers::pi * kRadiance / 2.0 *
           (1.0 - (x * x + h2 - r2) /
                      std::sqrt((x * x + h2 + r2) * (x * x + h2 + r2) - 4.0 * r2 * x * x));
}

TEST(PenumbraReference, QuadratureMatchesTheClosedFormWhereNothingIsHidden) {
    for (const double x : {1.0, 1.3, 2.5, 6.0}) {
        EXPECT_NEAR(penumbra_irradiance(x), disc_irradiance(x), 1e-9 * disc_irradiance(x));
    }
    EXPECT_EQ(penumbra_irradiance(-1.0), 0.0);
    // The edge over x = 0 hides exactly half the disc from the point below it.
    EXPECT_NEAR(penumbra_irradiance(0.0), 0.5 * disc_irradiance(0.0), 1e-9);
}

constexpr int kIrradianceSamples = 4096;

/// Irradiance at (x, 0, 0) on the floor (albedo kAlbedo) as the tracer sees it: the mean
/// radiance of stratified rays shot straight down from height `above`, times π/ρ.
double traced_irradiance(const RayTree<StochasticSampling>& tree, double x, float above,
                         RayCounters& counters) {
    double sum = 0.0;
    // The stratification key differs per point so that points do not share one pattern.
    const int point = static_cast<int>(std::lround(x * 1000.0));
    for (int k = 0; k < kIrradianceSamples; ++k) {
        StratifiedSampler sampler(11, point, 0, k, kIrradianceSamples);
        StochasticSampling sampling(sampler);
        const Ray ray{Vec3f(static_cast<float>(x), above, 0.0f), Vec3f(0.0f, -1.0f, 0.0f),
                      kInfinity};
        sum += tree.radiance(ray, 0, counters, sampling)[0];
    }
    return sum / kIrradianceSamples * std::numbers::pi / kAlbedo;
}

TEST(Distributed, SoftShadowMatchesTheAnalyticPenumbra) {
    const Scene scene = penumbra_scene();
    const SceneBvh bvh(scene);
    const TextureSampler textures(scene);
    const RayTree<StochasticSampling> tree(scene, bvh, textures, 0);
    const double full = disc_irradiance(0.0);
    for (const double x : {-1.5, -0.9, -0.6, -0.3, 0.0, 0.2, 0.5, 0.8, 1.5}) {
        // Straight down onto (x, 0, 0) from under the occluder.
        RayCounters counters;
        EXPECT_NEAR(traced_irradiance(tree, x, 1.0f, counters), penumbra_irradiance(x), 0.01 * full)
            << "x = " << x;
        EXPECT_EQ(counters.shadow, static_cast<std::uint64_t>(kIrradianceSamples));
    }
}

// The same disc light over a sphere of radius a centred on its axis at height c.
constexpr double kSphereRadius = 0.3;
constexpr double kSphereHeight = 2.0;

/// Irradiance at (x, 0, 0) below the disc light with the sphere in the way, by midpoint
/// quadrature over the disc in polar coordinates with an exact segment–sphere test.
double sphere_shadow_irradiance(double x) {
    const int radial = 600;
    const int angular = 1200;
    double sum = 0.0;
    for (int i = 0; i < radial; ++i) {
        const double r = kLightRadius * (i + 0.5) / radial;
        for (int j = 0; j < angular; ++j) {
            const double phi = 2.0 * std::numbers::pi * (j + 0.5) / angular;
            const double qx = r * std::cos(phi) - x;  // light point relative to the receiver
            const double qz = r * std::sin(phi);
            const double d2 = qx * qx + qz * qz + kLightHeight * kLightHeight;
            // Closest approach of the ray from the receiver towards q to the sphere centre.
            const double cx = -x;
            const double t = (cx * qx + kSphereHeight * kLightHeight) / d2;
            const double px = t * qx - cx;
            const double py = t * kLightHeight - kSphereHeight;
            const double pz = t * qz;
            if (px * px + py * py + pz * pz < kSphereRadius * kSphereRadius) {
                continue;
            }
            sum += kLightHeight * kLightHeight / (d2 * d2) * r;
        }
    }
    const double cell = (kLightRadius / radial) * (2.0 * std::numbers::pi / angular);
    return kRadiance * sum * cell;
}

TEST(Distributed, SoftShadowOfASphereMatchesTheDiscLightClosedForm) {
    // On the axis the sphere hides a coaxial disc of radius ρ = H·tan(asin(a/c)) of the light,
    // and a coaxial disc of radius r gives E = πL·r²/(H² + r²): the rest is an annulus.
    const double rho = kLightHeight * std::tan(std::asin(kSphereRadius / kSphereHeight));
    const auto coaxial = [](double r) {
        return std::numbers::pi * kRadiance * r * r / (kLightHeight * kLightHeight + r * r);
    };
    const double on_axis = coaxial(kLightRadius) - coaxial(rho);
    EXPECT_NEAR(sphere_shadow_irradiance(0.0), on_axis, 2e-3 * on_axis);

    const Scene scene = parse_scene(R"({
      "camera": {"eye": [0, 1, 6], "look_at": [0, 0, 0]},
      "materials": {"floor": {"diffuse": [0.5, 0.5, 0.5]}, "ball": {"diffuse": [1, 1, 1]}},
      "lights": [{"type": "ellipse", "center": [0, 4, 0], "semi_axis_u": [1, 0, 0],
                  "semi_axis_v": [0, 0, 1], "radiance": [3, 3, 3]}],
      "objects": [
        {"shape": "quad", "size": [40, 40], "material": "floor"},
        {"shape": "sphere", "radius": 0.3, "segments": 256, "rings": 128, "material": "ball",
         "transform": {"translate": [0, 2, 0]}}
      ]
    })",
                                    "sphere.json");
    const SceneBvh bvh(scene);
    const TextureSampler textures(scene);
    const RayTree<StochasticSampling> tree(scene, bvh, textures, 0);
    const double full = disc_irradiance(0.0);
    // The umbra is gone (ρ < R): on the axis the light shows an annulus; the penumbra reaches
    // out to where the sphere's image leaves the disc.
    for (const double x : {0.0, 0.2, 0.45, 0.7, 1.0, 1.5}) {
        RayCounters counters;
        const double expected = x == 0.0 ? on_axis : sphere_shadow_irradiance(x);
        EXPECT_NEAR(traced_irradiance(tree, x, 0.5f, counters), expected, 0.01 * full)
            << "x = " << x;
    }
    EXPECT_LT(on_axis, 0.8 * full);  // the shadow is really there
}

RenderOptions options_for(const Scene& scene) {
    RenderOptions o = testing::camera_options(scene);
    o.threads = 2;
    return o;
}

/// One stratified batch of `spp` samples in every pixel.
DistributedOptions fixed(int spp) {
    return {.sampling = DistributedSampling::Fixed, .spp = spp};
}

RenderOutput reference(const Scene& scene, const SceneBvh& bvh, int spp, std::uint64_t seed) {
    RenderOptions o = options_for(scene);
    o.seed = seed;
    return render_distributed(scene, bvh, o,
                              {.sampling = DistributedSampling::Reference, .spp = spp});
}

TEST(Distributed, ErrorFallsAtLeastAsFastAsOneOverRootSpp) {
    const Scene scene = penumbra_scene();
    const SceneBvh bvh(scene);
    const RenderOutput truth = reference(scene, bvh, 4096, 99);
    ASSERT_TRUE(truth.std_error.has_value());
    std::vector<double> log_spp;
    std::vector<double> log_error;
    for (const int spp : {4, 16, 64, 256}) {
        double squared = 0.0;
        for (const std::uint64_t seed : {1u, 2u}) {
            RenderOptions o = options_for(scene);
            o.seed = seed;
            const double e = rmse(render_distributed(scene, bvh, o, fixed(spp)).image, truth.image);
            squared += e * e / 2.0;
        }
        // The reference's own noise adds in quadrature; take it out.
        squared -= *truth.std_error * *truth.std_error;
        ASSERT_GT(squared, 0.0) << "spp " << spp;
        log_spp.push_back(std::log(spp));
        log_error.push_back(0.5 * std::log(squared));
    }
    const double n = static_cast<double>(log_spp.size());
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (std::size_t i = 0; i < log_spp.size(); ++i) {
        sx += log_spp[i];
        sy += log_error[i];
        sxx += log_spp[i] * log_spp[i];
        sxy += log_spp[i] * log_error[i];
    }
    const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    // Independent samples give −1/2; stratifying the pixel and the light can only help, up to
    // −3/4 for the discontinuities of edges and shadow boundaries in 2D strata.
    EXPECT_LT(slope, -0.45);
    EXPECT_GT(slope, -0.85);
}

TEST(Distributed, ReferenceStandardErrorMatchesTheSpreadOfTwoSeeds) {
    const Scene scene = penumbra_scene();
    const SceneBvh bvh(scene);
    const RenderOutput a = reference(scene, bvh, 64, 1);
    const RenderOutput b = reference(scene, bvh, 64, 2);
    ASSERT_TRUE(a.std_error && b.std_error);
    EXPECT_EQ(a.passes, 8);
    EXPECT_EQ(a.samples, 64u * 40u * 30u);
    const double predicted = std::sqrt(*a.std_error * *a.std_error + *b.std_error * *b.std_error);
    const double measured = rmse(a.image, b.image);
    EXPECT_GT(measured / predicted, 0.8);
    EXPECT_LT(measured / predicted, 1.25);
}

TEST(Distributed, TimeBudgetStopsWithinTheBudgetPlusOnePass) {
    const Scene scene = penumbra_scene(96, 72);
    const SceneBvh bvh(scene);
    const DistributedOptions budget{.spp_max = 65536, .time_budget = 0.3};
    const RenderOutput out = render_distributed(scene, bvh, options_for(scene), budget);
    EXPECT_GE(out.passes, 2);
    EXPECT_LE(out.render_seconds, budget.time_budget + out.last_pass_seconds + 0.1);
    EXPECT_GT(out.samples, static_cast<std::uint64_t>(96 * 72 * 2));
}

TEST(Distributed, SecondPassSamplesOnlyWhereThereIsVariance) {
    // Nothing in view: every pass-1 sample is the background, so pass 2 adds nothing.
    Scene empty = parse_scene(R"({"camera": {"eye": [0, 0, 5], "look_at": [0, 0, 0],
        "resolution": [32, 24]}, "background": [0.2, 0.3, 0.4], "objects": []})",
                              "empty.json");
    const SceneBvh empty_bvh(empty);
    RenderOptions o = options_for(empty);
    const RenderOutput flat = render_distributed(empty, empty_bvh, o);
    EXPECT_EQ(flat.passes, 2);
    EXPECT_EQ(flat.samples, 2u * 32u * 24u);
    EXPECT_NEAR(flat.image.at(5, 5)[2], 0.4f, 1e-6f);

    const Scene scene = penumbra_scene();
    const SceneBvh bvh(scene);
    const RenderOutput out = render_distributed(scene, bvh, options_for(scene), {.spp_max = 32});
    EXPECT_GT(out.samples, 2u * 40u * 30u);
    EXPECT_LT(out.samples, 32u * 40u * 30u);
}

TEST(Distributed, DeterministicForAnyThreadCount) {
    const Scene scene = penumbra_scene();
    const SceneBvh bvh(scene);
    RenderOptions o = options_for(scene);
    o.filter = PixelFilter::gaussian(0.7f);
    o.seed = 5;
    o.threads = 1;
    const Image one = render_distributed(scene, bvh, o).image;
    o.threads = 4;
    const Image four = render_distributed(scene, bvh, o).image;
    EXPECT_EQ(one.data(), four.data());
    o.seed = 6;
    EXPECT_NE(one.data(), render_distributed(scene, bvh, o).image.data());
}

TEST(Distributed, RoughMirrorKeepsAllTheEnergyOfAUniformSky) {
    // A perfect rough mirror under a uniform sky reflects exactly the sky, whatever the spread:
    // directions spread below the surface are folded back, not lost.
    const Scene scene = parse_scene(R"({
      "camera": {"eye": [0, 3, 3], "look_at": [0, 0, 0], "fov": 30, "resolution": [24, 16]},
      "background": [0.5, 0.25, 1.0],
      "materials": {"mirror": {"diffuse": [0, 0, 0], "reflectivity": 1, "roughness": 0.6}},
      "objects": [{"shape": "quad", "size": [100, 100], "material": "mirror"}]
    })",
                                    "mirror.json");
    const SceneBvh bvh(scene);
    const Image image = render_distributed(scene, bvh, options_for(scene), fixed(4)).image;
    for (int y = 0; y < image.height(); ++y) {
        for (int x = 0; x < image.width(); ++x) {
            EXPECT_NEAR(image.at(x, y)[0], 0.5f, 1e-5f);
            EXPECT_NEAR(image.at(x, y)[2], 1.0f, 1e-5f);
        }
    }
}

TEST(Distributed, DepthOfFieldBlursOnlyWhatIsOutOfFocus) {
    const auto scene_with = [](double aperture, double focus) {
        return parse_scene(R"({
          "camera": {"eye": [0, 4, 0], "look_at": [0, 0, 0], "up": [0, 0, -1], "fov": 40,
                     "resolution": [32, 32], "aperture_radius": )" +
                               std::to_string(aperture) + R"(, "focal_distance": )" +
                               std::to_string(focus) + R"(},
          "ambient": [1, 1, 1],
          "materials": {"black": {"diffuse": [0, 0, 0]}, "white": {"diffuse": [1, 1, 1]}},
          "objects": [{"shape": "checkerboard", "size": [4, 4], "tiles": [8, 8],
                       "materials": ["black", "white"]}]
        })",
                           "dof.json");
    };
    const auto render = [](const Scene& scene) {
        const SceneBvh bvh(scene);
        return render_distributed(scene, bvh, options_for(scene), fixed(256)).image;
    };
    const Image pinhole = render(scene_with(0.0, 4.0));
    const Image focused = render(scene_with(0.3, 4.0));
    const Image blurred = render(scene_with(0.3, 2.0));
    EXPECT_LT(rmse(focused, pinhole), 0.03);
    EXPECT_GT(rmse(blurred, pinhole), 0.15);
}

}  // namespace
}  // namespace mrt
