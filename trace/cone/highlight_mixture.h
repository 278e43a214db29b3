#pragma once
// Highlights as a mixture of the lobes of what a cone meets, not the lobe of their average.
//
// A fragment's attributes are prefiltered: its normal is the weighted mean of its points' and
// triangles' normals, and Toksvig's exponent widens the Phong lobe by how much they spread
// (footprint_material in trace/cone/cone_tracer.cpp). For a highlight much narrower than the
// spread that is the wrong shape: where one of the footprint's points faces the light's mirror
// direction and the others do not, the reference has a glint and the mean normal, pointing
// between them, a faint smear somewhere else. The field's glass bunnies under the sun
// (exponent 300) are the case: a few pixels of radiance 10–20 hold most of its error
// (docs/cone-tracer.md, "Where the field's error is").
//
// So every contributor also adds the highlight its own normal (and its own normals' spread,
// OctreePoint::normal_length) receives from each of the scene's first kHighlightLights lights,
// and the fragment averages those, as it averages every other attribute. The shader keeps the
// exact highlight of the mean normal (area_light_phong_highlight, phong_brdf) and adds the
// mixture's difference from the same approximation at the mean normal: exact where the
// contributors agree, the mixture where they do not.
//
// The lobe is Phong's cos^e of the angle θ between the light and the mirror direction, as the
// Gaussian exp(−e·θ²/2) (θ² from 2·(1 − cos θ)); a light of solid angle Ω is a Gaussian of the
// same per-axis variance Ω/(4π) as its uniform disc, and the two convolve in closed form.

#include "common/math/math.h"
#include "common/scene/scene.h"

#include <array>
#include <cstddef>

namespace mrt {

/// Lights whose highlights are mixed per contributor (the first point lights, then the area
/// lights, in the scene's order); the others get the mean normal's alone.
inline constexpr std::size_t kHighlightLights = 4;

/// The Phong exponent whose lobe (of angular variance 1/e per axis, in its Gaussian form) is
/// widened by `spread` more: 1/(1/e + spread).
inline float widened_exponent(float exponent, float spread) {
    return exponent > 0.0f && spread > 0.0f ? exponent / (1.0f + exponent * spread) : exponent;
}

/// The angular variance per axis a mirror direction spreads by where the unit normal turns by
/// `turn_x` and `turn_y` across a footprint's two columns (its Gaussian exp(−|F⁻¹x|²) has the
/// covariance F·Fᵀ/2): the mirror turns twice as far as the normal, 2·(|turn_x|² + |turn_y|²)/2
/// over the two axes.
inline float mirror_spread(const Vec3f& turn_x, const Vec3f& turn_y) {
    return turn_x.squaredNorm() + turn_y.squaredNorm();
}

/// Phong's lobe with the cosine at the receiver, (e + 2)/(2π)·cos^e θ·(n·ω), in its Gaussian
/// form, for a light of solid angle `solid_angle` (0: a point light) centred at cos θ =
/// `mirror_cosine` from the mirror direction, `normal_cosine` = n·ω: per unit solid angle of the
/// light, so that times the solid angle it is the highlight per unit radiance
/// (area_light_phong_highlight) and for a point light it is phong_brdf's specular lobe times
/// the cosine.
float gaussian_highlight(float exponent, float mirror_cosine, float normal_cosine,
                         float solid_angle);

/// The lights of a scene as the mixture needs them, once per scene (ConeGeometry): where each is
/// and how large it is (world space).
class HighlightLights {
  public:
    /// The scene's point lights, then `area_lights` (the scene's ellipses and its mesh lights'
    /// equivalent ones: elliptical_lights).
    HighlightLights(const Scene& scene, const std::vector<EllipticalAreaLight>& area_lights);
    /// The same with the scene's own elliptical_lights.
    explicit HighlightLights(const Scene& scene);

    std::size_t count() const { return m_count; }

    /// The highlights (of_light) of light 0 … count() − 1 on a surface at p, seen along the unit
    /// `direction`, with normal `normal` (its length the agreement of the normals it stands
    /// for, 1 for one normal; Toksvig's exponent widens `exponent` by it).
    /// `spread`: the lobe widened further by it (widened_exponent), the turn of a triangle's
    /// normals across the footprint (ConeSurface::lobe_spread).
    std::array<float, kHighlightLights> at(const Vec3f& p, const Vec3f& direction,
                                           const Vec3f& normal, float exponent,
                                           float spread = 0.0f) const;

    /// One light's highlight at the world point p with unit normal n, seen from the unit
    /// direction wo (towards the eye), with Phong exponent `exponent` (already widened), per unit
    /// specular colour and per unit of what the light emits: gaussian_highlight times the solid
    /// angle of an area light (per unit radiance, as area_light_phong_highlight), as it is for a
    /// point light (per unit irradiance, as phong_brdf's lobe times the cosine).
    float of_light(std::size_t light, const Vec3f& p, const Vec3f& n, const Vec3f& wo,
                   float exponent) const;

  private:
    struct Light {
        Vec3f centre = Vec3f::Zero();
        Vec3f normal = Vec3f::Zero();  ///< Unit, for an area light; zero for a point light.
        float area = 0.0f;             ///< Area of an area light's ellipse; 0 for a point light.
        bool two_sided = false;
    };
    std::array<Light, kHighlightLights> m_lights{};
    std::size_t m_count = 0;
};

}  // namespace mrt
