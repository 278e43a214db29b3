#include "trace/cone/highlight_mixture.h"

#include "trace/render/mesh_light.h"
#include "trace/render/shading.h"

#include <algorithm>
#include <cmath>

namespace mrt {

namespace {

/// gaussian_highlight: half the side of the light's square over the lobe's σ·√2 below which the
/// light is taken as a point.
constexpr float kNarrowLight = 0.25f;

}  // namespace

float gaussian_highlight(float exponent, float mirror_cosine, float normal_cosine,
                         float solid_angle) {
    if (!(normal_cosine > 0.0f) || !(exponent > 0.0f)) {
        return 0.0f;
    }
    // cos^e θ ≈ exp(−θ²/(2σ²)) with σ² = 1/e, θ² ≈ 2·(1 − cos θ).
    const float lobe = (exponent + 2.0f) / (2.0f * kPi) * normal_cosine;
    const float angle_squared = 2.0f * std::max(0.0f, 1.0f - mirror_cosine);
    const float k = std::sqrt(0.5f * exponent);  // 1/(σ·√2)
    const float half = 0.5f * std::sqrt(std::max(0.0f, solid_angle));
    if (!(half * k > kNarrowLight)) {
        // A light much narrower than the lobe (the sun under exponent 300: 0.09): its centre's
        // value, without three erf per contributor; the light's variance it leaves out is
        // (2/3)·(half·k)² of the lobe's, 4 % at the bound.
        return lobe * std::exp(-0.5f * exponent * angle_squared);
    }
    // The light as the square of its solid angle, offset by θ along one side: the Gaussian's
    // integral over it is a product of erf differences, 2πσ²·along·across, exact on the plateau
    // where the light holds the whole lobe, which a Gaussian stand-in for it overshoots.
    const float angle = std::sqrt(angle_squared);
    const float along = 0.5f * (std::erf((half - angle) * k) + std::erf((half + angle) * k));
    const float across = std::erf(half * k);
    return lobe * (2.0f * kPi / exponent) * along * across / solid_angle;
}

HighlightLights::HighlightLights(const Scene& scene)
    : HighlightLights(scene, elliptical_lights(scene)) {}

HighlightLights::HighlightLights(const Scene& scene,
                                 const std::vector<EllipticalAreaLight>& area_lights) {
    for (const PointLight& light : scene.point_lights) {
        if (m_count == kHighlightLights) {
            return;
        }
        m_lights[m_count++].centre = light.position;
    }
    for (const EllipticalAreaLight& light : area_lights) {
        if (m_count == kHighlightLights) {
            return;
        }
        Light& l = m_lights[m_count++];
        l.centre = light.center;
        l.normal = light.normal();
        l.area = light.area();
        l.two_sided = light.two_sided;
    }
}

float HighlightLights::of_light(std::size_t light, const Vec3f& p, const Vec3f& n, const Vec3f& wo,
                                float exponent) const {
    const Light& l = m_lights[light];
    const Vec3f apart = l.centre - p;
    const float squared = apart.squaredNorm();
    if (!(squared > 0.0f)) {
        return 0.0f;
    }
    const Vec3f wi = apart / std::sqrt(squared);
    float solid_angle = 0.0f;
    if (l.area > 0.0f) {
        // The ellipse as its solid angle from p, where it faces p (both faces if two-sided).
        const float facing = -l.normal.dot(wi);
        const float cosine = l.two_sided ? std::abs(facing) : facing;
        if (!(cosine > 0.0f)) {
            return 0.0f;
        }
        solid_angle = std::min(2.0f * kPi, l.area * cosine / squared);
    }
    const Vec3f mirror = reflect(-wo, n);
    const float lobe = gaussian_highlight(exponent, mirror.dot(wi), n.dot(wi), solid_angle);
    return l.area > 0.0f ? solid_angle * lobe : lobe;
}

std::array<float, kHighlightLights> HighlightLights::at(const Vec3f& p, const Vec3f& direction,
                                                        const Vec3f& normal, float exponent,
                                                        float spread) const {
    std::array<float, kHighlightLights> lobes{};
    const float length = normal.norm();
    if (!(length > 0.0f)) {
        return lobes;
    }
    // Facing the eye, as the shader turns the fragment's normal (a refracted cone meets a glass
    // surface from inside).
    const Vec3f n = (normal.dot(direction) > 0.0f ? -1.0f : 1.0f) * normal / length;
    const float widened = widened_exponent(toksvig_exponent(exponent, length), spread);
    for (std::size_t l = 0; l < m_count; ++l) {
        lobes[l] = of_light(l, p, n, -direction, widened);
    }
    return lobes;
}

}  // namespace mrt
