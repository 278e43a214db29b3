#pragma once
// What a uniform elliptical area light delivers to a receiving point from its whole extent,
// without occlusion, deterministically: the irradiance (the diffuse term) and the Phong
// highlight. The renderers that do not sample lights (whitted, cone) multiply these by their
// own visibility (a hard shadow ray to the centre, a shadow cone's transmittance).
//
// Both are per unit radiance: multiply by the light's radiance (and the albedo/π or the
// specular colour) for the reflected radiance.

#include "common/math/math.h"
#include "common/scene/scene.h"

namespace mrt {

/// The projected solid angle (sr) of the emitting part of `light` above the plane through p
/// with unit normal n: ∫ max(0, n·ω) dω over the directions from p that meet the light's
/// emitting face. Times the radiance it is the unoccluded irradiance at p (π for an infinite
/// emitter covering the hemisphere). The part of the light behind the tangent plane is clipped;
/// a one-sided light gives nothing behind its face (nor in its own plane).
///
/// Exact for the ellipse to about 1e-5 relative except within about a thousandth of the light's
/// size of its rim: Lambert's contour form Φ = ½∮(x × dx)/|x|² (the limit of Lambert's polygon
/// formula ½·Σ Θᵢ Γᵢ), by the trapezoidal rule, whose error falls exponentially with the number
/// of points for this smooth periodic integrand; the count is doubled until two successive
/// estimates agree. Where the tangent plane cuts the light the clipped boundary (the arc above
/// it and the chord in it) is integrated by Gauss–Legendre panels on the arc and Lambert's exact
/// term for the chord. Computed relative to p in double precision: a light of radius 1e6 over a
/// point at height 1 gives π·(1 − 1e-12), not a rounding error.
double area_light_projected_solid_angle(const EllipticalAreaLight& light, const Vec3f& p,
                                        const Vec3f& n);

/// The Phong highlight of `light` at p (unit normal n, unit direction to the eye wo, exponent
/// e ≥ 0) per unit radiance and unit specular colour: ∫ (e+2)/(2π)·max(0, r·ω)^e·max(0, n·ω) dω
/// over the light's emitting directions, with r the mirror of wo about n (the specular part of
/// phong_brdf, times the cosine, integrated over the light).
///
/// Deterministic multiple importance sampling (the balance heuristic) of two fixed,
/// well-spread point sets: points uniform by area on the ellipse (golden-angle spiral), good
/// where the lobe is wider than the light, and directions distributed as the lobe cos^e
/// around r (spherical Fibonacci), good where the light is wider than the lobe. Finite for any
/// light: under an infinite emitter it is the lobe's own integral over the hemisphere.
float area_light_phong_highlight(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                                 const Vec3f& wo, float exponent);

/// The radiance the surface at p (unit shading normal n, unit direction to the eye wo) reflects
/// towards the eye from `light`'s whole extent, unoccluded: the diffuse term (albedo/π times the
/// projected solid angle) and the Phong highlight, times the light's radiance. Zero where the
/// light gives neither. The one lighting formula of the tracers that do not sample area lights
/// (whitted, cone), which multiply it by their own visibility.
Rgb area_light_unoccluded(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                          const Vec3f& wo, const Material& material, const Rgb& albedo);

/// area_light_unoccluded's two terms apart, per unit radiance, albedo and specular colour: the
/// projected solid angle over π and the highlight; for a tracer that sees a different share of
/// the light through each (the cone tracer weighs a penumbra's hidden part of the light by its
/// irradiance for the first, by its area for the second: trace/cone/light_share.h).
struct AreaLightTerms {
    float diffuse = 0.0f;
    float highlight = 0.0f;

    /// The radiance reflected toward the eye with the given shares of each term visible
    /// (area_light_unoccluded for shares of 1).
    Rgb reflected(const EllipticalAreaLight& light, const Material& material, const Rgb& albedo,
                  float diffuse_share = 1.0f, float highlight_share = 1.0f) const {
        return reflected(light.radiance, material, albedo, diffuse_share, highlight_share);
    }
    /// The same for a light of `radiance` (a mesh light's: trace/render/mesh_light.h).
    Rgb reflected(const Rgb& radiance, const Material& material, const Rgb& albedo,
                  float diffuse_share = 1.0f, float highlight_share = 1.0f) const {
        return radiance * (albedo * (diffuse_share * diffuse) +
                           material.specular * (highlight_share * highlight));
    }
};
AreaLightTerms area_light_terms(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                                const Vec3f& wo, const Material& material);

}  // namespace mrt
