#include "trace/render/camera_rays.h"
#include "common/system/error.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mrt {
namespace {

Camera test_camera() {
    Camera c;
    c.eye = Vec3f(1.0f, 2.0f, 3.0f);
    c.look_at = Vec3f(1.0f, 2.0f, -7.0f);
    c.up = Vec3f(0.0f, 1.0f, 0.0f);
    c.vertical_fov = 60.0f * kPi / 180.0f;
    c.width = 200;
    c.height = 100;
    return c;
}

float angle_between(const Vec3f& a, const Vec3f& b) {
    return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// The pinhole differential at (x, y) against central differences of the rays at ±0.01 pixel.
void expect_matches_neighbouring_pinhole_rays(const CameraRays& rays, float x, float y) {
    constexpr float h = 0.01f;
    const RayDifferential d = rays.pinhole_differential(x, y);
    const Vec3f fd_x =
        (rays.pinhole_ray(x + h, y).direction - rays.pinhole_ray(x - h, y).direction) / (2 * h);
    const Vec3f fd_y =
        (rays.pinhole_ray(x, y + h).direction - rays.pinhole_ray(x, y - h).direction) / (2 * h);
    EXPECT_LT((d.dd_dx - fd_x).norm(), 1e-3f * fd_x.norm());
    EXPECT_LT((d.dd_dy - fd_y).norm(), 1e-3f * fd_y.norm());
}

TEST(CameraRays, CentreRayLooksAtTheTarget) {
    const CameraRays rays(test_camera(), 200, 100);
    const Ray r = rays.pinhole_ray(100.0f, 50.0f);
    EXPECT_NEAR((r.direction - Vec3f(0.0f, 0.0f, -1.0f)).norm(), 0.0f, 1e-6f);
    EXPECT_EQ(r.origin, test_camera().eye);
    EXPECT_NEAR(r.direction.norm(), 1.0f, 1e-6f);
}

TEST(CameraRays, ImageEdgesSpanTheFieldOfView) {
    const Camera c = test_camera();
    const CameraRays rays(c, 200, 100);
    const Vec3f forward(0.0f, 0.0f, -1.0f);
    // Vertical: top edge at half the vertical field of view, above the axis.
    const Ray top = rays.pinhole_ray(100.0f, 0.0f);
    EXPECT_NEAR(angle_between(top.direction, forward), 0.5f * c.vertical_fov, 1e-5f);
    EXPECT_GT(top.direction.y(), 0.0f);
    // Horizontal: the aspect ratio (2:1) widens the tangent, not the angle.
    const Ray right = rays.pinhole_ray(200.0f, 50.0f);
    const float expected = std::atan(2.0f * std::tan(0.5f * c.vertical_fov));
    EXPECT_NEAR(angle_between(right.direction, forward), expected, 1e-5f);
    EXPECT_GT(right.direction.x(), 0.0f);
}

TEST(CameraRays, ThinLensRaysOfOnePixelMeetInTheFocalPlane) {
    Camera c = test_camera();
    c.aperture_radius = 0.25f;
    c.focal_distance = 4.0f;
    const CameraRays rays(c, 200, 100);
    const Ray centre = rays.pinhole_ray(37.3f, 81.9f);
    // The pinhole ray reaches the focal plane (distance 4 along the axis) at this point.
    const float t_plane = 4.0f / centre.direction.dot(rays.forward());
    const Vec3f focus = centre.origin + t_plane * centre.direction;
    for (float u : {0.05f, 0.3f, 0.77f, 0.99f}) {
        for (float v : {0.1f, 0.5f, 0.92f}) {
            const Ray r = rays.lens_ray(37.3f, 81.9f, u, v);
            EXPECT_LE((r.origin - c.eye).norm(), c.aperture_radius * (1.0f + 1e-6f));
            EXPECT_NEAR(std::abs((r.origin - c.eye).dot(rays.forward())), 0.0f, 1e-6f);
            const float t =
                (focus - r.origin).dot(rays.forward()) / r.direction.dot(rays.forward());
            EXPECT_NEAR((r.origin + t * r.direction - focus).norm(), 0.0f, 1e-5f);
        }
    }
}

TEST(CameraRays, DifferentialsMatchNeighbouringRays) {
    // Pinhole and thin lens, against central differences of the rays themselves. Lens rays of
    // neighbouring pixels share the lens point and meet the focal plane one pixel apart, as
    // the pinhole rays do: there the two footprints agree.
    Camera c = test_camera();
    c.aperture_radius = 0.25f;
    c.focal_distance = 4.0f;
    const CameraRays rays(c, 200, 100);
    const float x = 37.3f, y = 81.9f, h = 0.01f;
    const RayDifferential pin = rays.pinhole_differential(x, y);
    expect_matches_neighbouring_pinhole_rays(rays, x, y);
    EXPECT_EQ(pin.dp_dx, Vec3f::Zero());
    // Half the step for four samples a pixel.
    EXPECT_LT((rays.pinhole_differential(x, y, 0.5f).dd_dx - 0.5f * pin.dd_dx).norm(), 1e-7f);

    const RayDifferential lens = rays.lens_differential(x, y, 0.2f, 0.7f);
    const Vec3f lx = (rays.lens_ray(x + h, y, 0.2f, 0.7f).direction -
                      rays.lens_ray(x - h, y, 0.2f, 0.7f).direction) /
                     (2 * h);
    EXPECT_LT((lens.dd_dx - lx).norm(), 1e-3f * lx.norm());
    const Ray r = rays.lens_ray(x, y, 0.2f, 0.7f);
    const float t_focus = 4.0f / r.direction.dot(rays.forward());
    const FootprintCone cone = FootprintCone::from_differential(r.direction, lens);
    const FootprintCone pinhole_cone =
        FootprintCone::from_differential(rays.pinhole_ray(x, y).direction, pin);
    const Ray centre = rays.pinhole_ray(x, y);
    const float t_pinhole = 4.0f / centre.direction.dot(rays.forward());
    EXPECT_NEAR(cone.max_diameter(t_focus), pinhole_cone.max_diameter(t_pinhole),
                0.02f * pinhole_cone.max_diameter(t_pinhole));
    // No aperture: the lens differential is the pinhole's.
    const CameraRays pinhole_rays(test_camera(), 200, 100);
    EXPECT_EQ(pinhole_rays.lens_differential(x, y, 0.2f, 0.7f).dd_dx,
              pinhole_rays.pinhole_differential(x, y).dd_dx);
}

TEST(CameraRays, NonSquarePixelsStretchTheHorizontalStepAndItsDifferential) {
    Camera c = test_camera();
    c.pixel_aspect = 2.5f;
    const CameraRays rays(c, 200, 100);
    const Vec3f forward(0.0f, 0.0f, -1.0f);
    EXPECT_NEAR(rays.pixel_step_x().norm(), 2.5f * rays.pixel_step_y().norm(), 1e-7f);
    // The vertical field of view is the camera's; the horizontal one widens by the pixel aspect.
    EXPECT_NEAR(angle_between(rays.pinhole_ray(100.0f, 0.0f).direction, forward),
                0.5f * c.vertical_fov, 1e-5f);
    EXPECT_NEAR(angle_between(rays.pinhole_ray(200.0f, 50.0f).direction, forward),
                std::atan(2.5f * 2.0f * std::tan(0.5f * c.vertical_fov)), 1e-5f);
    expect_matches_neighbouring_pinhole_rays(rays, 151.2f, 12.6f);
    // At the image centre the footprint is an ellipse 2.5 times as wide as tall.
    const FootprintCone cone = FootprintCone::from_differential(
        rays.pinhole_ray(100.0f, 50.0f).direction, rays.pinhole_differential(100.0f, 50.0f));
    EXPECT_NEAR(cone.max_diameter(1.0f) / cone.min_diameter(1.0f), 2.5f, 1e-4f);
}

TEST(CameraRays, ConcentricDiscIsAreaPreserving) {
    // A uniform grid over the square must land uniformly on the disc: E[r²] = 1/2 and a quarter
    // of the samples inside radius 1/2.
    constexpr int n = 400;
    double sum_r2 = 0.0;
    int inner = 0;
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            const Vec2f p = concentric_disc((static_cast<float>(i) + 0.5f) / n,
                                            (static_cast<float>(j) + 0.5f) / n);
            ASSERT_LE(p.norm(), 1.0f + 1e-6f);
            sum_r2 += p.squaredNorm();
            inner += p.norm() < 0.5f ? 1 : 0;
        }
    }
    EXPECT_NEAR(sum_r2 / (n * n), 0.5, 1e-3);
    EXPECT_NEAR(static_cast<double>(inner) / (n * n), 0.25, 2e-3);
}

TEST(CameraRays, RefusesADegenerateViewFrame) {
    Camera c = test_camera();
    c.up = Vec3f(0.0f, 0.0f, 1.0f);  // parallel to the view direction
    EXPECT_THROW(CameraRays(c, 10, 10), Error);
    c = test_camera();
    c.look_at = c.eye;
    EXPECT_THROW(CameraRays(c, 10, 10), Error);
    EXPECT_THROW(CameraRays(test_camera(), 0, 10), Error);
}

}  // namespace
}  // namespace mrt
