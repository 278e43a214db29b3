#include "trace/render/camera_rays.h"

#include "common/system/error.h"

#include <cmath>
#include <ostream>

namespace mrt {

CameraRays::CameraRays(const Camera& camera, int width, int height)
    : m_camera(camera), m_width(width), m_height(height) {
    if (width <= 0 || height <= 0) {
        throw Error("camera: image size must be positive, found " + std::to_string(width) + "×" +
                    std::to_string(height));
    }
    const Vec3f view = camera.look_at - camera.eye;
    const Vec3f right = view.cross(camera.up);
    if (!(view.norm() > 0.0f) || !(right.norm() > 0.0f) || !all_finite(right)) {
        throw Error(
            "camera: eye, look_at and up must span a view frame (eye ≠ look_at, up not "
            "parallel to the view direction)");
    }
    m_forward = view.normalized();
    m_right = right.normalized();
    m_up = m_right.cross(m_forward);

    const float half_height = std::tan(0.5f * camera.vertical_fov);
    // The horizontal extent follows the image's aspect ratio times the pixels' own: pixel steps
    // differ along x and y when pixel_aspect ≠ 1, and the differentials with them.
    const float half_width =
        half_height * camera.pixel_aspect * static_cast<float>(width) / static_cast<float>(height);
    m_top_left = m_forward - half_width * m_right + half_height * m_up;
    m_step_x = (2.0f * half_width / static_cast<float>(width)) * m_right;
    m_step_y = (-2.0f * half_height / static_cast<float>(height)) * m_up;
    m_focal_distance = camera.focal_distance > 0.0f ? camera.focal_distance : view.norm();
}

Ray CameraRays::pinhole_ray(float raster_x, float raster_y) const {
    const Vec3f d = m_top_left + raster_x * m_step_x + raster_y * m_step_y;
    return Ray{m_camera.eye, d.normalized(), kInfinity};
}

Ray CameraRays::lens_ray(float raster_x, float raster_y, float lens_u, float lens_v) const {
    if (m_camera.aperture_radius <= 0.0f) {
        return pinhole_ray(raster_x, raster_y);
    }
    // The unnormalised direction has unit length along forward(), so scaling it by the focal
    // distance lands on the plane in focus; every lens point aims at that same point.
    const Vec3f d = m_top_left + raster_x * m_step_x + raster_y * m_step_y;
    const Vec3f focus = m_camera.eye + m_focal_distance * d;
    const Vec2f disc = m_camera.aperture_radius * concentric_disc(lens_u, lens_v);
    const Vec3f origin = m_camera.eye + disc.x() * m_right + disc.y() * m_up;
    return Ray{origin, (focus - origin).normalized(), kInfinity};
}

RayDifferential CameraRays::pinhole_differential(float raster_x, float raster_y,
                                                 float scale) const {
    const Vec3f d = m_top_left + raster_x * m_step_x + raster_y * m_step_y;
    return RayDifferential::pinhole(d, scale * m_step_x, scale * m_step_y);
}

RayDifferential CameraRays::lens_differential(float raster_x, float raster_y, float lens_u,
                                              float lens_v, float scale) const {
    if (m_camera.aperture_radius <= 0.0f) {
        return pinhole_differential(raster_x, raster_y, scale);
    }
    const Vec3f d = m_top_left + raster_x * m_step_x + raster_y * m_step_y;
    const Vec3f focus = m_camera.eye + m_focal_distance * d;
    const Vec2f disc = m_camera.aperture_radius * concentric_disc(lens_u, lens_v);
    const Vec3f origin = m_camera.eye + disc.x() * m_right + disc.y() * m_up;
    return RayDifferential::thin_lens(focus - origin, scale * m_step_x, scale * m_step_y,
                                      m_focal_distance);
}

}  // namespace mrt
