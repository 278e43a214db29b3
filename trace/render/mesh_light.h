#pragma once
// What a mesh area light (common/scene/mesh_light.h: flat triangles emitting uniform radiance
// from one face) delivers to a receiving point: one sampled point for the stochastic tracers,
// its centroid for Whitted's hard shadows, and, unoccluded and deterministically, the irradiance
// (the diffuse term) and the Phong highlight of its whole extent, as trace/render/area_light.h
// gives them for elliptical lights. The cone tracer, whose shadow cones need an ellipse, uses
// equivalent_ellipse instead.

#include "common/math/math.h"
#include "common/scene/mesh_light.h"
#include "common/scene/scene.h"
#include "trace/render/area_light.h"
#include "trace/render/shading.h"

namespace mrt {

/// One point of `light`, uniform by area from (u, v) ∈ [0,1)² (u picks the triangle in
/// proportion to its area and is rescaled within it; Heitz's low-distortion square-to-triangle
/// map then keeps stratified (u, v) stratified on each triangle), seen from p. `irradiance` is
/// the one-sample estimator L·max(0, cos θ_light)·A / d², zero from behind the emitting face:
/// averaged over uniform samples, times the receiver cosine, it converges to the irradiance the
/// light gives p (sample_area_light's conventions).
LightSample sample_mesh_light(const MeshAreaLight& light, const Vec3f& p, float u, float v);

/// `light` reduced to its centroid (Whitted's hard-shadow approximation, as
/// sample_area_light_centre): a point emitter of radiant intensity L·A·max(0, cos θ) towards p.
LightSample sample_mesh_light_centre(const MeshAreaLight& light, const Vec3f& p);

/// The projected solid angle (sr) of `light` above the plane through p with unit normal n:
/// ∫ max(0, n·ω) dω over the directions from p that meet the light's emitting face; times the
/// radiance, the unoccluded irradiance at p. Zero unless p is strictly on the emitting side of
/// the light's plane.
///
/// Exact up to rounding: each triangle is clipped to the half-space above the tangent plane
/// (n·(x − p) ≥ 0; Sutherland–Hodgman against one plane, so a triangle becomes at most a
/// quadrilateral whose new edge lies in the plane) and integrated by Lambert's polygon formula
/// ½·Σ Θᵢ (n·Γᵢ), with Θᵢ the angle edge i subtends at p and Γᵢ the unit normal of the plane
/// through p and the edge. Computed relative to p in double precision, so that a light far from
/// the origin or much larger than its distance keeps its full precision.
double mesh_light_projected_solid_angle(const MeshAreaLight& light, const Vec3f& p, const Vec3f& n);

/// The Phong highlight of `light` at p (unit normal n, unit direction to the eye wo, exponent
/// e ≥ 0) per unit radiance and unit specular colour: ∫ (e+2)/(2π)·max(0, r·ω)^e·max(0, n·ω) dω
/// over the light's emitting directions, with r the mirror of wo about n (as
/// area_light_phong_highlight).
///
/// Exact up to a 1-D quadrature, for any real exponent, wide lobe or narrow. Each triangle is
/// clipped to n·ω ≥ 0 and r·ω ≥ 0, which removes both max(0, ·), and the divergence theorem on
/// the sphere turns the integral over its directions into integrals along its edges (Arvo 1995,
/// "Applications of irradiance tensors", whose recurrences do this for integer exponents).
/// With z = r·ω, y = n·ω and ν each edge's outward co-normal (the unit normal of the plane
/// through p and the edge), ∇·(z^e ∇y) = e(r·n) z^(e−1) − (e+2) z^e y and ∇·(G ∇z) = z^(e−1)
/// for G(z) = −(1 − z^e)/(e(1 − z²)) give
///     highlight = 1/(2π) · Σ_edges [ (r·n)(r·ν) ∫ K_e(z) ds − (n·ν) ∫ z^e ds ],
///     K_e(z) = −(1 − z^e)/(1 − z²)   (bounded: −e/2 on the lobe's axis),
/// with s the arc length of the edge's great arc. Both integrands are smooth along an arc and
/// peak where it passes nearest r, over a width about 1/√e: 8-point Gauss–Legendre panels
/// growing geometrically from that point integrate them to about 1e-7 relative (and into an end
/// on the plane r·ω = 0 too when e < 2 is fractional, where z^e is as rough as a root).
///
/// Cost: per edge, 8·(about log₂(Θ√e) + 1) evaluations of log1p, exp and expm1 on each side of
/// that point, Θ the angle the edge subtends; none for e = 0. The clipped triangles have 3 to 5
/// edges; an edge shared with the next or previous triangle in the list (a quad's diagonal)
/// cancels and is skipped. For the Cornell box's light over its floor: 35 evaluations (e ≤ 10)
/// to 130 (e = 3000), 2 to 8 µs; nothing where the lobe is below 1e-5 of its peak over the
/// light's bounding sphere (most of the floor for e ≥ 80).
float mesh_light_phong_highlight(const MeshAreaLight& light, const Vec3f& p, const Vec3f& n,
                                 const Vec3f& wo, float exponent);

/// The radiance the surface at p (unit shading normal n, unit direction to the eye wo) reflects
/// towards the eye from `light`'s whole extent, unoccluded: the light's radiance times
/// (albedo · projected solid angle / π + specular · highlight). Zero where the light gives
/// neither (as area_light_unoccluded).
Rgb mesh_light_unoccluded(const MeshAreaLight& light, const Vec3f& p, const Vec3f& n,
                          const Vec3f& wo, const Material& material, const Rgb& albedo);

/// mesh_light_unoccluded's two terms apart, per unit radiance, albedo and specular colour (as
/// area_light_terms); terms.reflected(light.radiance(), …) is the reflected radiance.
AreaLightTerms mesh_light_terms(const MeshAreaLight& light, const Vec3f& p, const Vec3f& n,
                                const Vec3f& wo, const Material& material);

/// The one-sided elliptical light that stands in for `light` in the cone tracer: the same
/// centroid, plane and facing (semi_axis_u × semi_axis_v along light.normal()), the same second
/// moments of area about the centroid, and the same emitted power (radiance scaled by
/// light.area() / ellipse area).
///
/// Why the moments: far from a flat emitter, its irradiance is a Taylor series in the emitting
/// points' offsets x from the centroid, whose k-th term is the k-th moment of area times a
/// kernel derivative of relative size (size/distance)^k. Equal power matches the zeroth term,
/// a common centroid makes both first terms vanish, and equal second moments match the second.
/// The ellipse's odd moments vanish, so the first disagreement is the light's own third moment
/// (zero for any centrally symmetric light: parallelograms, the Cornell box's ceiling light) and
/// then the fourth: the relative error in irradiance falls as (size/distance)³ for any light and
/// as (size/distance)⁴ for symmetric ones (at five times its size, 4e-5 for a 1 × 0.6 rectangle
/// seen obliquely, 8e-4 for a triangle).
///
/// A uniform ellipse of semi-axes a, b has variances a²/4 and b²/4 along them, so a = 2√λ₁ and
/// b = 2√λ₂ from the eigenvalues of the light's in-plane covariance (a w × h rectangle gives
/// w/√3 and h/√3 along its sides). A degenerate light (zero area, collinear triangles) still
/// gives a valid ellipse: the minor axis is kept above 1e-4 of the major (pbrt's anisotropy
/// clamp), the major above 1e-6 of the light's distance from the origin (or 1e-6), and the
/// radiance is zero when the light's area is.
EllipticalAreaLight equivalent_ellipse(const MeshAreaLight& light);

/// The lights of a tracer that knows only ellipses (the cone tracer): the scene's elliptical
/// lights, then the equivalent ellipse of each of its mesh lights.
std::vector<EllipticalAreaLight> elliptical_lights(const Scene& scene);

}  // namespace mrt
