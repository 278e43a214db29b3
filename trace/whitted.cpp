#include "trace/whitted.h"

#include "common/sampling.h"
#include "trace/shading.h"
#include "trace/surface_point.h"

#include <cmath>

namespace mrt {

WhittedTracer::WhittedTracer(const Scene& scene, const SceneBvh& bvh,
                             const TextureSampler& textures, int max_depth)
    : m_scene(scene), m_bvh(bvh), m_textures(textures), m_max_depth(max_depth) {}

Rgb WhittedTracer::direct_light(const SurfacePoint& sp, const Material& material, const Rgb& albedo,
                                const Vec3f& wo, RayCounters& counters) const {
    Rgb sum = Rgb::Zero();
    const auto add = [&](const LightSample& light) {
        // Lights below the geometric surface never reach it, whatever the shading normal says.
        const float cos_geometric = sp.geometric_normal.dot(light.wi);
        const float cos_shading = sp.shading_normal.dot(light.wi);
        if (cos_geometric <= 0.0f || cos_shading <= 0.0f || (light.irradiance <= 0.0f).all()) {
            return;
        }
        ++counters.shadow;
        const Ray shadow{sp.spawn_origin(light.wi), light.wi, light.distance};
        if (m_bvh.occluded(shadow)) {
            return;
        }
        sum += light.irradiance * cos_shading *
               phong_brdf(material, albedo, sp.shading_normal, light.wi, wo);
    };
    for (const PointLight& light : m_scene.point_lights) {
        add(sample_point_light(light, sp.position));
    }
    for (const EllipticalAreaLight& light : m_scene.area_lights) {
        add(sample_area_light_centre(light, sp.position));
    }
    return sum;
}

Rgb WhittedTracer::radiance(const Ray& ray, int depth, RayCounters& counters, float weight) const {
    SceneHit hit;
    if (!m_bvh.intersect(ray, hit)) {
        return m_scene.background;
    }
    const Vec3f d = ray.direction.normalized();
    const SurfacePoint sp = make_surface_point(m_scene, hit, d);
    const Material& material = m_scene.materials[sp.material];
    const Vec3f wo = -d;

    // Light not mirrored or transmitted is scattered locally (ambient + Phong).
    const float local_weight = std::max(0.0f, 1.0f - material.reflectivity - material.transparency);
    const Rgb albedo = m_textures.diffuse(material, sp.uv) * local_weight;
    Rgb result = m_scene.ambient * albedo + direct_light(sp, material, albedo, wo, counters);
    if (depth >= m_max_depth) {
        return result;
    }

    float reflect_weight = material.reflectivity;
    if (material.refracts()) {
        const float eta = sp.entering ? 1.0f / material.ior : material.ior;
        if (const auto t = refract(d, sp.shading_normal, eta)) {
            if (weight * material.transparency >= kMinimumWeight) {
                ++counters.secondary;
                const Ray refracted{sp.spawn_origin(*t), *t, kInfinity};
                result += material.transparency *
                          radiance(refracted, depth + 1, counters, weight * material.transparency);
            }
        } else {
            // Total internal reflection: the transmitted share is mirrored instead.
            reflect_weight += material.transparency;
        }
    }
    if (reflect_weight > 0.0f && weight * reflect_weight >= kMinimumWeight) {
        Vec3f r = reflect(d, sp.shading_normal);
        // An interpolated normal can mirror a ray below the geometric surface; fold it back.
        if (r.dot(sp.geometric_normal) <= 0.0f) {
            r = reflect(d, sp.geometric_normal);
        }
        ++counters.secondary;
        const Ray reflected{sp.spawn_origin(r), r, kInfinity};
        result +=
            reflect_weight * radiance(reflected, depth + 1, counters, weight * reflect_weight);
    }
    return result;
}

RenderOutput render_whitted(const Scene& scene, const SceneBvh& bvh, const RenderOptions& options) {
    const CameraRays camera(scene.camera, options.width, options.height);
    const int max_depth = options.max_depth >= 0 ? options.max_depth : scene.max_depth;
    const TextureSampler textures(scene);
    const WhittedTracer tracer(scene, bvh, textures, max_depth);
    const int spp = std::max(1, options.spp);
    const float inv_spp = 1.0f / static_cast<float>(spp);
    return render_image(options, "whitted", [&](int x, int y, RayCounters& counters) {
        Rgb sum = Rgb::Zero();
        for (int s = 0; s < spp; ++s) {
            const Vec2f offset = pixel_sample(options.seed, x, y, s, spp);
            const Ray ray = camera.pinhole_ray(static_cast<float>(x) + offset.x(),
                                               static_cast<float>(y) + offset.y());
            ++counters.primary;
            sum += tracer.radiance(ray, 0, counters);
        }
        return Rgb(sum * inv_spp);
    });
}

}  // namespace mrt
