#pragma once
// Primary rays of a scene camera: the view frame and the mapping from continuous raster
// coordinates (x right, y down, pixel (i, j) covering [i, i+1) × [j, j+1)) to rays.

#include "common/footprint/footprint.h"
#include "common/math/ray.h"
#include "common/math/sampling.h"
#include "common/scene/scene.h"

#include <iosfwd>

namespace mrt {

class CameraRays {
  public:
    /// The camera renders a width × height image (which may differ from camera.width/height:
    /// the field of view stays vertical, the horizontal extent follows the image's aspect times
    /// camera.pixel_aspect).
    CameraRays(const Camera& camera, int width, int height);

    /// Pinhole ray through raster position (x, y); unit direction.
    Ray pinhole_ray(float raster_x, float raster_y) const;

    /// Thin-lens ray through raster position (x, y) with lens sample (u, v) in [0,1)²
    /// (concentric mapping onto the aperture disc); equals pinhole_ray when the aperture is 0.
    Ray lens_ray(float raster_x, float raster_y, float lens_u, float lens_v) const;

    /// Ray differential of pinhole_ray at (x, y) with respect to the raster coordinates, each
    /// pixel step scaled by `scale` (1/√spp when a pixel is shared by spp samples).
    RayDifferential pinhole_differential(float raster_x, float raster_y, float scale = 1.0f) const;

    /// Ray differential of lens_ray(x, y, u, v) across pixels: offset rays share the lens point
    /// and aim at their own point in focus, so in the focal plane the footprint is the pixel's,
    /// as for the pinhole. (The spread over the aperture is not a pixel differential: the
    /// cone tracer adds it as its own cone, zero in focus.)
    RayDifferential lens_differential(float raster_x, float raster_y, float lens_u, float lens_v,
                                      float scale = 1.0f) const;

    const Vec3f& forward() const { return m_forward; }
    const Vec3f& right() const { return m_right; }
    const Vec3f& up() const { return m_up; }
    /// World-space vector between the centres of horizontally / vertically adjacent pixels
    /// on the image plane at distance 1 along forward().
    const Vec3f& pixel_step_x() const { return m_step_x; }
    const Vec3f& pixel_step_y() const { return m_step_y; }
    int width() const { return m_width; }
    int height() const { return m_height; }
    const Camera& camera() const { return m_camera; }

  private:
    Camera m_camera;
    int m_width;
    int m_height;
    Vec3f m_forward, m_right, m_up;
    Vec3f m_top_left;  ///< Direction to raster (0, 0) at distance 1.
    Vec3f m_step_x, m_step_y;
    float m_focal_distance;
};

}  // namespace mrt
