// Known-answer scenes for the conventional ray tracer: every pixel is checked against radiance
// computed analytically (ray–plane intersections and Snell's law written out independently),
// plus determinism across thread counts and a regression image of the default scene.

#include "trace/raytrace/whitted.h"
#include "common/image/image.h"
#include "common/image/image_metrics.h"
#include "common/mesh/procedural.h"
#include "common/scene_io/scene_loader.h"
#include "tests/support/test_support.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/render/camera_rays.h"
#include "trace/render/shading.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <optional>

namespace mrt {
namespace {

constexpr int kSize = 65;

Material diffuse_material(float albedo) {
    Material m;
    m.name = "diffuse";
    m.diffuse = Rgb::Constant(albedo);
    return m;
}

Instance place(std::uint32_t mesh, const Affine3f& transform) {
    Instance i;
    i.kind = Instance::Kind::Mesh;
    i.index = mesh;
    i.transform = transform;
    return i;
}

Scene top_down_scene() {
    Scene s;
    s.camera.eye = Vec3f(0.0f, 10.0f, 0.0f);
    s.camera.look_at = Vec3f(0.0f, 0.0f, 0.0f);
    s.camera.up = Vec3f(0.0f, 0.0f, -1.0f);
    s.camera.vertical_fov = 30.0f * kPi / 180.0f;
    s.camera.width = kSize;
    s.camera.height = kSize;
    s.groups.push_back(Group{"world", {}});
    s.root = 0;
    return s;
}

RenderOutput render(const Scene& scene, int threads = 1, int max_depth = -1) {
    const SceneBvh bvh(scene);
    RenderOptions options = testing::camera_options(scene);
    options.threads = threads;
    options.max_depth = max_depth;
    return render_whitted(scene, bvh, options);
}

/// Where a ray meets the horizontal plane y = height, if it does in front of its origin.
std::optional<Vec3f> hit_plane_y(const Vec3f& o, const Vec3f& d, float height) {
    if (d.y() == 0.0f) {
        return std::nullopt;
    }
    const float t = (height - o.y()) / d.y();
    if (t <= 0.0f) {
        return std::nullopt;
    }
    return o + t * d;
}

TEST(Whitted, DiffusePlaneUnderPointLightMatchesInverseSquareCosineLaw) {
    // L = ρ/π · I · cosθ / d² at every visible point; with an occluding square the shadowed
    // points get the ambient term ρ·A only.
    Scene s = top_down_scene();
    s.materials = {diffuse_material(0.5f), diffuse_material(0.3f)};
    s.ambient = Rgb::Constant(0.1f);
    s.point_lights.push_back(PointLight{Vec3f(0.0f, 2.0f, 0.0f), Rgb(3.0f, 2.0f, 1.0f)});
    s.meshes.push_back(make_quad(100.0f, 100.0f, 0));
    s.meshes.push_back(make_quad(0.4f, 0.4f, 1));
    s.groups[0].children.push_back(place(0, Affine3f::Identity()));
    s.groups[0].children.push_back(place(1, Affine3f(Eigen::Translation3f(1.0f, 1.0f, 0.0f))));

    const Image image = render(s).image;
    const CameraRays camera(s.camera, kSize, kSize);
    const Vec3f light = s.point_lights[0].position;
    const Rgb intensity = s.point_lights[0].intensity;
    const auto in_occluder = [](const Vec3f& p) {
        return std::abs(p.x() - 1.0f) <= 0.2f && std::abs(p.z()) <= 0.2f;
    };
    int shadowed = 0;
    int checked = 0;
    for (int y = 0; y < kSize; ++y) {
        for (int x = 0; x < kSize; ++x) {
            const Ray ray =
                camera.pinhole_ray(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
            Rgb expected;
            const auto top = hit_plane_y(ray.origin, ray.direction, 1.0f);
            if (top && in_occluder(*top)) {
                const Vec3f to_light = light - *top;
                const float d = to_light.norm();
                expected = 0.3f * 0.1f + 0.3f / kPi * intensity * (to_light.y() / d) / (d * d);
            } else {
                const Vec3f p = *hit_plane_y(ray.origin, ray.direction, 0.0f);
                const Vec3f to_light = light - p;
                const float d = to_light.norm();
                // The segment to the light crosses y = 1 at p + to_light / 2.
                const bool blocked = in_occluder(p + 0.5f * to_light);
                // Skip pixels within a hair of the shadow boundary.
                const Vec3f crossing = p + 0.5f * to_light;
                const float margin = std::min(std::abs(std::abs(crossing.x() - 1.0f) - 0.2f),
                                              std::abs(std::abs(crossing.z()) - 0.2f));
                if (margin < 1e-3f) {
                    continue;
                }
                expected = 0.5f * 0.1f;
                if (!blocked) {
                    expected += 0.5f / kPi * intensity * (to_light.y() / d) / (d * d);
                } else {
                    ++shadowed;
                }
            }
            ++checked;
            const Rgb got = image.at(x, y);
            for (int c = 0; c < 3; ++c) {
                ASSERT_NEAR(got[c], expected[c], 2e-5f + 2e-5f * expected[c])
                    << "pixel " << x << "," << y << " channel " << c;
            }
        }
    }
    EXPECT_GT(shadowed, 10);
    EXPECT_GT(checked, kSize * kSize - 20);
}

TEST(Whitted, PerfectMirrorShowsTheBackgroundAndRespectsTheDepthLimit) {
    Scene s = top_down_scene();
    Material mirror = diffuse_material(0.7f);
    mirror.reflectivity = 1.0f;
    s.materials = {mirror};
    s.background = Rgb(0.2f, 0.4f, 0.6f);
    s.ambient = Rgb::Constant(0.5f);
    s.meshes.push_back(make_quad(100.0f, 100.0f, 0));
    s.groups[0].children.push_back(place(0, Affine3f::Identity()));

    const Image mirrored = render(s).image;
    const Image limited = render(s, 1, 0).image;
    for (int y = 0; y < kSize; ++y) {
        for (int x = 0; x < kSize; ++x) {
            for (int c = 0; c < 3; ++c) {
                ASSERT_FLOAT_EQ(mirrored.at(x, y)[c], s.background[c]);
                // No bounce allowed and nothing scattered locally: black.
                ASSERT_FLOAT_EQ(limited.at(x, y)[c], 0.0f);
            }
        }
    }
}

TEST(Whitted, GlassSlabDisplacesTheViewAsSnellsLawPredicts) {
    // A 0.5-thick slab of index 1.5 above a checkerboard lit by ambient light only: each pixel
    // must show the tile found by refracting into the slab and out again.
    Scene s;
    s.camera.eye = Vec3f(0.3f, 4.0f, 0.2f);
    s.camera.look_at = Vec3f(1.5f, -2.0f, 0.9f);
    s.camera.up = Vec3f(0.0f, 0.0f, -1.0f);
    s.camera.vertical_fov = 50.0f * kPi / 180.0f;
    s.camera.width = kSize;
    s.camera.height = kSize;
    s.groups.push_back(Group{"world", {}});
    Material glass;
    glass.diffuse = Rgb::Zero();
    glass.transparency = 1.0f;
    glass.ior = 1.5f;
    s.materials = {diffuse_material(0.2f), diffuse_material(0.8f), glass};
    s.ambient = Rgb::Constant(1.0f);
    s.meshes.push_back(make_checkerboard(40.0f, 40.0f, 40, 40, 0, 1));
    s.meshes.push_back(make_quad(100.0f, 100.0f, 2));
    s.groups[0].children.push_back(place(0, Affine3f(Eigen::Translation3f(0.0f, -2.0f, 0.0f))));
    s.groups[0].children.push_back(place(1, Affine3f::Identity()));
    // The slab's lower face points down.
    s.groups[0].children.push_back(place(1, Affine3f(Eigen::Translation3f(0.0f, -0.5f, 0.0f) *
                                                     Eigen::AngleAxisf(kPi, Vec3f::UnitX()))));

    const Image image = render(s).image;
    const CameraRays camera(s.camera, kSize, kSize);
    int checked = 0;
    for (int y = 0; y < kSize; ++y) {
        for (int x = 0; x < kSize; ++x) {
            const Ray ray =
                camera.pinhole_ray(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
            const Vec3d d = ray.direction.cast<double>().normalized();
            const Vec3d entry = ray.origin.cast<double>() + (-ray.origin.y() / d.y()) * d;
            // In the slab the horizontal direction is kept and sinθ shrinks by 1/1.5.
            const Vec3d horizontal = Vec3d(d.x(), 0.0, d.z());
            const double sin_i = horizontal.norm();
            const double sin_t = sin_i / 1.5;
            const double cos_t = std::sqrt(1.0 - sin_t * sin_t);
            const Vec3d inside = sin_i > 0.0
                                     ? Vec3d(horizontal / sin_i * sin_t + Vec3d(0, -cos_t, 0))
                                     : Vec3d(0, -1, 0);
            const Vec3d exit = entry + (0.5 / cos_t) * inside;
            // Leaving a parallel slab restores the original direction.
            const Vec3d floor = exit + ((-2.0 - exit.y()) / d.y()) * d;
            const double u = floor.x() + 20.0;
            const double v = floor.z() + 20.0;
            const double margin = std::min(
                {u - std::floor(u), std::ceil(u) - u, v - std::floor(v), std::ceil(v) - v});
            if (margin < 0.01) {
                continue;
            }
            const bool first =
                (static_cast<long>(std::floor(u)) + static_cast<long>(std::floor(v))) % 2 == 0;
            ++checked;
            ASSERT_NEAR(image.at(x, y)[0], first ? 0.2f : 0.8f, 1e-5f) << "pixel " << x << "," << y;
        }
    }
    EXPECT_GT(checked, kSize * kSize * 3 / 4);
}

TEST(Shading, RefractionFollowsSnellAndReflectsTotallyPastTheCriticalAngle) {
    const Vec3f n(0.0f, 1.0f, 0.0f);
    for (float degrees : {0.0f, 10.0f, 35.0f, 60.0f, 89.0f}) {
        const float a = degrees * kPi / 180.0f;
        const Vec3f d(std::sin(a), -std::cos(a), 0.0f);
        const auto t = refract(d, n, 1.0f / 1.5f);
        ASSERT_TRUE(t.has_value());
        EXPECT_NEAR(t->norm(), 1.0f, 1e-6f);
        EXPECT_NEAR(t->x(), std::sin(a) / 1.5f, 1e-6f);  // sinθt = η sinθi
        EXPECT_LT(t->y(), 0.0f);
    }
    // Leaving glass (η = 1.5): critical angle asin(1/1.5) ≈ 41.81°.
    const float critical = std::asin(1.0f / 1.5f);
    for (float delta : {-1e-3f, 1e-3f}) {
        const float a = critical + delta;
        const Vec3f d(std::sin(a), -std::cos(a), 0.0f);
        EXPECT_EQ(refract(d, n, 1.5f).has_value(), delta < 0.0f) << "delta " << delta;
    }
}

TEST(Whitted, RayTreeStaysBoundedWithAHugeDepthLimit) {
    // Two parallel half-mirrors that also transmit: without weight-based pruning every bounce
    // doubles the tree and depth 1000 would never finish.
    Scene s = top_down_scene();
    Material glass = diffuse_material(0.0f);
    glass.reflectivity = 0.45f;
    glass.transparency = 0.5f;
    glass.ior = 1.5f;
    s.materials = {glass, diffuse_material(0.5f)};
    s.ambient = Rgb::Constant(1.0f);
    s.meshes.push_back(make_quad(100.0f, 100.0f, 0));
    s.meshes.push_back(make_quad(100.0f, 100.0f, 1));
    s.groups[0].children.push_back(place(0, Affine3f(Eigen::Translation3f(0.0f, 1.0f, 0.0f))));
    s.groups[0].children.push_back(place(0, Affine3f(Eigen::Translation3f(0.0f, 0.5f, 0.0f))));
    s.groups[0].children.push_back(place(1, Affine3f::Identity()));
    const RenderOutput out = render(s, 2, 1000);
    const std::uint64_t pixels = static_cast<std::uint64_t>(kSize) * kSize;
    // Weights fall by at least 0.5 per bounce, so no branch outlives ~12 bounces.
    EXPECT_LT(out.rays.secondary, pixels * 4096);
    for (const float v : out.image.data()) {
        ASSERT_TRUE(std::isfinite(v));
    }
}

std::filesystem::path default_scene() {
    return std::filesystem::path(MRT_SOURCE_DIR) / "data/scenes/two-spheres.json";
}

TEST(Whitted, DefaultSceneIsIdenticalForOneAndTwoThreadsAndFinite) {
    const Scene scene = load_scene(default_scene());
    const SceneBvh bvh(scene);
    RenderOptions options;
    options.width = 96;
    options.height = 96;
    options.quiet = true;
    options.threads = 1;
    const Image one = render_whitted(scene, bvh, options, {.spp = 4}).image;
    options.threads = 2;
    const Image two = render_whitted(scene, bvh, options, {.spp = 4}).image;
    ASSERT_EQ(one.data().size(), two.data().size());
    for (std::size_t i = 0; i < one.data().size(); ++i) {
        ASSERT_TRUE(std::isfinite(one.data()[i]));
        ASSERT_EQ(one.data()[i], two.data()[i]) << "float " << i;
    }
}

TEST(Whitted, DefaultSceneMatchesTheReferenceImage) {
    // tests/data/reference/two-spheres-128.png was rendered by
    //   mrt-trace data/scenes/two-spheres.json -o two-spheres-128.png --width 128 --spp 4
    // and checked by eye. 8-bit sRGB storage limits agreement to about 0.002 RMSE in linear.
    const Scene scene = load_scene(default_scene());
    const SceneBvh bvh(scene);
    RenderOptions options;
    options.width = 128;
    options.height = 128;
    options.quiet = true;
    const Image image = render_whitted(scene, bvh, options, {.spp = 4}).image;
    const Image reference = read_image(std::filesystem::path(MRT_SOURCE_DIR) /
                                       "tests/data/reference/two-spheres-128.png");
    Image clamped = image;
    for (float& v : clamped.data()) {
        v = std::clamp(v, 0.0f, 1.0f);
    }
    EXPECT_LT(rmse(clamped, reference), 0.005);
}

}  // namespace
}  // namespace mrt
