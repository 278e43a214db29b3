#pragma once
// Local shading shared by the tracers: mirror and refraction directions, the Phong BRDF of the
// paper's materials, and what a light delivers to a point. Directions are unit world vectors;
// `wo` points back along the incoming ray, `wi` towards the light.

#include "common/math/math.h"
#include "common/scene/scene.h"

#include <algorithm>
#include <optional>

namespace mrt {

/// Mirror direction of the incoming direction d about the unit normal n.
inline Vec3f reflect(const Vec3f& d, const Vec3f& n) {
    return d - 2.0f * d.dot(n) * n;
}

/// Refracted direction of the unit incoming direction d at a surface with unit normal n facing
/// against d (n·d ≤ 0), with eta = n_incident / n_transmitted (Snell's law, Igehy eq. 16's
/// form D' = ηD − μN). Nothing on total internal reflection.
std::optional<Vec3f> refract(const Vec3f& d, const Vec3f& n, float eta);

/// Normalised Phong BRDF: diffuse albedo/π plus specular·(e+2)/(2π)·max(0, r·wo)^e, with r the
/// mirror of wi about n (energy-conserving for albedo + specular ≤ 1).
Rgb phong_brdf(const Material& material, const Rgb& diffuse_albedo, const Vec3f& n, const Vec3f& wi,
               const Vec3f& wo);

/// phong_brdf's specular lobe per unit specular colour: (e+2)/(2π)·max(0, r·wo)^e.
float phong_lobe(float exponent, const Vec3f& n, const Vec3f& wi, const Vec3f& wo);

/// The mean-normal length below which toksvig_exponent stops following it. Only a floor for
/// the formula: at |n̄| = 0 with an exponent of 0 it is 0/0. Normals that cancel to 1e-3 already
/// give an exponent below 1e-3/(1 − 1e-3) whatever e: a highlight spread over the hemisphere.
inline constexpr float kMinimumNormalAgreement = 1e-3f;

/// The Phong exponent of a footprint over which the unit normals spread, leaving a mean normal of
/// length `mean_normal_length` (1 where they agree): Toksvig's (2005) e·|n̄| / (|n̄| + e·(1 − |n̄|)),
/// as mip-mapped normal maps use. One normal for the footprint would give a detailed surface seen
/// from afar one coherent highlight where the surface has scattered glints.
inline float toksvig_exponent(float phong_exponent, float mean_normal_length) {
    const float agreement = std::clamp(mean_normal_length, kMinimumNormalAgreement, 1.0f);
    return phong_exponent * agreement / (agreement + phong_exponent * (1.0f - agreement));
}

/// Light arriving at a point from one point-like emitter.
struct LightSample {
    Vec3f wi;        ///< Unit direction from the point to the emitter.
    float distance;  ///< Distance to the emitter.
    Rgb irradiance;  ///< Intensity towards the point / distance² (before the cosine).
};

/// What the point `point` of a flat emitter delivers to p, as the one-sample estimator of an
/// area light sampled uniformly by area: radiance·A·cos θ_emitter / d², with cos θ_emitter
/// against the unit `normal` (its absolute value when `two_sided`, zero behind a one-sided face).
/// `radiance_area` is the radiance times the emitter's whole area.
LightSample flat_emitter_point(const Vec3f& point, const Vec3f& normal, bool two_sided,
                               const Rgb& radiance_area, const Vec3f& p);

/// A point light seen from p.
LightSample sample_point_light(const PointLight& light, const Vec3f& p);

/// An elliptical area light reduced to its centre (Whitted's hard-shadow approximation): a
/// point emitter with the light's radiant intensity L·A·|cos θ| in the direction of p.
LightSample sample_area_light_centre(const EllipticalAreaLight& light, const Vec3f& p);

/// One point of an elliptical area light, chosen uniformly by area from (u, v) ∈ [0,1)² (the
/// concentric disc mapping keeps stratified (u, v) stratified on the ellipse), seen from p.
/// `irradiance` is the one-sample estimator L·|cos θ_light|·A / d²: averaged over uniform
/// samples, times the receiver cosine, it converges to the irradiance the light gives p.
LightSample sample_area_light(const EllipticalAreaLight& light, const Vec3f& p, float u, float v);
/// The same for the point at `disc` of the unit disc (centre + disc.x·semi_axis_u +
/// disc.y·semi_axis_v).
LightSample sample_area_light_at(const EllipticalAreaLight& light, const Vec2f& disc,
                                 const Vec3f& p);

}  // namespace mrt
