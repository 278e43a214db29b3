#pragma once
// The conventional ray tracer (Whitted 1980), the speed baseline of every comparison: one ray
// per pixel centre (or a fixed jittered grid with spp > 1), Phong shading with hard shadows from
// point lights and from area lights reduced to their centres, mirror reflection and refraction
// weighted by the material coefficients, total internal reflection, and a depth limit
// (trace/raytrace/ray_tree.h).

#include "common/scene/scene.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/raytrace/ray_tree.h"
#include "trace/render/render.h"

namespace mrt {

using WhittedTracer = RayTree<CentreSampling>;

/// What the Whitted tracer reads beyond RenderOptions.
struct WhittedOptions {
    /// Rays per pixel: 1 traces the pixel centre; more trace a jittered grid (seeded by
    /// RenderOptions::seed), the conventional supersampled tracer.
    int spp = 1;
};

/// Renders the scene's camera with the Whitted tracer, samples reconstructed with
/// options.filter, textures from `textures` (built for options.texture_filter: preparing the
/// mip-mapped textures is load work, not render work).
RenderOutput render_whitted(const Scene& scene, const SceneBvh& bvh, const TextureSampler& textures,
                            const RenderOptions& options, const WhittedOptions& whitted = {});

/// The same, preparing the textures itself.
RenderOutput render_whitted(const Scene& scene, const SceneBvh& bvh, const RenderOptions& options,
                            const WhittedOptions& whitted = {});

}  // namespace mrt
