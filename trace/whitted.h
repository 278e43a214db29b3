#pragma once
// The conventional ray tracer (Whitted 1980), the speed baseline of every comparison: one ray
// per pixel centre (or a fixed jittered grid with spp > 1, box-filtered), Phong shading with
// hard shadows from point lights and from area lights reduced to their centres, mirror
// reflection and refraction weighted by the material coefficients, total internal reflection,
// and a recursion depth limit.

#include "common/camera_rays.h"
#include "common/scene.h"
#include "common/texture.h"
#include "trace/render.h"
#include "trace/scene_bvh.h"

namespace mrt {

class WhittedTracer {
  public:
    WhittedTracer(const Scene& scene, const SceneBvh& bvh, const TextureSampler& textures,
                  int max_depth);

    /// Radiance arriving along `ray` (reflection/refraction depth `depth` so far; `weight` is
    /// the product of the coefficients that scale this ray's contribution to the pixel).
    Rgb radiance(const Ray& ray, int depth, RayCounters& counters, float weight = 1.0f) const;

    /// Branches of the ray tree whose contribution to the pixel is scaled below this are not
    /// traced (Hall & Greenberg 1983, adaptive tree depth control): a tenth of an 8-bit step.
    static constexpr float kMinimumWeight = 1.0f / 2550.0f;

  private:
    Rgb direct_light(const struct SurfacePoint& sp, const Material& material, const Rgb& albedo,
                     const Vec3f& wo, RayCounters& counters) const;

    const Scene& m_scene;
    const SceneBvh& m_bvh;
    const TextureSampler& m_textures;
    int m_max_depth;
};

/// Renders the scene's camera with the Whitted tracer.
RenderOutput render_whitted(const Scene& scene, const SceneBvh& bvh, const RenderOptions& options);

}  // namespace mrt
