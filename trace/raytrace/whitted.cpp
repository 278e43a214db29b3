#include "trace/raytrace/whitted.h"

#include "common/math/sampling.h"
#include "trace/render/camera_rays.h"
#include "trace/render/film.h"
#include "trace/render/method.h"

#include <chrono>

namespace mrt {

RenderOutput render_whitted(const Scene& scene, const SceneBvh& bvh, const RenderOptions& options,
                            const WhittedOptions& whitted) {
    const TextureSampler textures(scene, options.texture_filter);
    return render_whitted(scene, bvh, textures, options, whitted);
}

RenderOutput render_whitted(const Scene& scene, const SceneBvh& bvh, const TextureSampler& textures,
                            const RenderOptions& options, const WhittedOptions& whitted) {
    const CameraRays camera(scene.camera, options.width, options.height);
    const int max_depth = options.max_depth >= 0 ? options.max_depth : scene.max_depth;
    const WhittedTracer tracer(scene, bvh, textures, max_depth, options.differentials);
    const int spp = std::max(1, whitted.spp);
    const float scale = footprint_scale(spp);
    Film film(options.width, options.height, options.filter, options.crop);
    const auto start = std::chrono::steady_clock::now();
    RenderOutput out;
    out.rays = film.add_pass(
        options.threads, std::string(to_string(Method::Whitted)), options.quiet,
        [&](int x, int y, FilmTile& tile, RayCounters& counters) {
            CentreSampling centre;
            for (int s = 0; s < spp; ++s) {
                const Vec2f offset = pixel_sample(options.seed, x, y, s, spp);
                const float rx = static_cast<float>(x) + offset.x();
                const float ry = static_cast<float>(y) + offset.y();
                ++counters.primary;
                tile.add_sample(rx, ry,
                                tracer.camera_radiance(
                                    camera.pinhole_ray(rx, ry),
                                    [&] { return camera.pinhole_differential(rx, ry, scale); },
                                    counters, centre));
            }
        });
    out.image = film.image();
    out.spp = spp;
    out.samples = static_cast<std::uint64_t>(spp) * film.last_pass_pixels();
    out.render_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    out.last_pass_seconds = out.render_seconds;
    return out;
}

}  // namespace mrt
