#include "trace/render/shading.h"

#include "common/math/sampling.h"

#include <algorithm>
#include <cmath>

namespace mrt {

std::optional<Vec3f> refract(const Vec3f& d, const Vec3f& n, float eta) {
    const float cos_i = std::min(1.0f, -d.dot(n));
    const float sin2_t = eta * eta * std::max(0.0f, 1.0f - cos_i * cos_i);
    if (sin2_t >= 1.0f) {
        return std::nullopt;
    }
    const float cos_t = std::sqrt(1.0f - sin2_t);
    const Vec3f t = eta * d + (eta * cos_i - cos_t) * n;
    return t.normalized();
}

Rgb phong_brdf(const Material& material, const Rgb& diffuse_albedo, const Vec3f& n, const Vec3f& wi,
               const Vec3f& wo) {
    Rgb f = diffuse_albedo * (1.0f / kPi);
    if ((material.specular > 0.0f).any()) {
        f += material.specular * phong_lobe(material.phong_exponent, n, wi, wo);
    }
    return f;
}

float phong_lobe(float exponent, const Vec3f& n, const Vec3f& wi, const Vec3f& wo) {
    const float cos_alpha = reflect(-wi, n).dot(wo);
    return cos_alpha > 0.0f ? (exponent + 2.0f) / (2.0f * kPi) * std::pow(cos_alpha, exponent)
                            : 0.0f;
}

LightSample sample_point_light(const PointLight& light, const Vec3f& p) {
    const Vec3f to_light = light.position - p;
    const float d2 = to_light.squaredNorm();
    const float d = std::sqrt(d2);
    if (!(d > 0.0f)) {
        return {Vec3f(0.0f, 0.0f, 1.0f), 0.0f, Rgb::Zero()};
    }
    return {to_light / d, d, light.intensity / d2};
}

LightSample flat_emitter_point(const Vec3f& point, const Vec3f& normal, bool two_sided,
                               const Rgb& radiance_area, const Vec3f& p) {
    const Vec3f to_light = point - p;
    const float d2 = to_light.squaredNorm();
    const float d = std::sqrt(d2);
    if (!(d > 0.0f)) {
        return {Vec3f(0.0f, 0.0f, 1.0f), 0.0f, Rgb::Zero()};
    }
    const Vec3f wi = to_light / d;
    const float cos_light = -wi.dot(normal);
    const float cos_emit = two_sided ? std::abs(cos_light) : std::max(0.0f, cos_light);
    return {wi, d, radiance_area * (cos_emit / d2)};
}

namespace {

/// What the emitter point `point` of `light` delivers to p (see LightSample).
LightSample emitter_point(const EllipticalAreaLight& light, const Vec3f& point, const Vec3f& p) {
    return flat_emitter_point(point, light.normal(), light.two_sided, light.radiance * light.area(),
                              p);
}

}  // namespace

LightSample sample_area_light_centre(const EllipticalAreaLight& light, const Vec3f& p) {
    return emitter_point(light, light.center, p);
}

LightSample sample_area_light(const EllipticalAreaLight& light, const Vec3f& p, float u, float v) {
    return sample_area_light_at(light, concentric_disc(u, v), p);
}

LightSample sample_area_light_at(const EllipticalAreaLight& light, const Vec2f& disc,
                                 const Vec3f& p) {
    return emitter_point(
        light, light.center + disc.x() * light.semi_axis_u + disc.y() * light.semi_axis_v, p);
}

}  // namespace mrt
