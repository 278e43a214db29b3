#pragma once
// The local geometry at a ray hit, in world space: what shading and secondary rays need.

#include "common/footprint/footprint.h"
#include "common/math/ray.h"
#include "common/scene/scene.h"
#include "trace/bvh/scene_bvh.h"

#include <cstdint>

namespace mrt {

struct SurfacePoint {
    Vec3f position;          ///< World hit point, from the barycentric interpolation.
    Vec3f geometric_normal;  ///< Unit normal of the triangle plane (world), facing the ray.
    Vec3f shading_normal;    ///< Unit interpolated vertex normal (world), same side as above.
    Vec2f uv{0.0f, 0.0f};    ///< Interpolated texture coordinates (zero when the mesh has none).
    bool has_uv = false;
    bool entering = true;      ///< The ray arrived from the side the mesh's winding faces.
    float error_bound = 0.0f;  ///< Absolute floating-point error bound of `position`.
    std::uint32_t material = 0;
    /// Maps object-space normals to world space (inverse transpose of the instance's linear
    /// part), kept for the surface differential so the inverse is taken once per hit.
    Mat3f normal_matrix = Mat3f::Identity();

    /// Origin for a ray leaving this point in direction d, clear of the surface.
    Vec3f spawn_origin(const Vec3f& d) const {
        return offset_ray_origin(position, geometric_normal, error_bound, d);
    }
};

/// Normal and texture-coordinate derivatives at `sp` (made by make_surface_point for `hit`) for
/// a ray whose hit-point differentials are dp_dx, dp_dy: the triangle's barycentric planes in
/// world space, so instance transforms (including non-uniform scales) are accounted for.
SurfaceDifferential make_surface_differential(const Scene& scene, const SceneHit& hit,
                                              const SurfacePoint& sp, const Vec3f& dp_dx,
                                              const Vec3f& dp_dy);

/// Builds the world-space surface point of `hit` for a ray travelling along `direction`. Both
/// normals are flipped to face against the ray (entering records whether they were flipped).
SurfacePoint make_surface_point(const Scene& scene, const SceneHit& hit, const Vec3f& direction);

}  // namespace mrt
