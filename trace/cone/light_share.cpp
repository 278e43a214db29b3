#include "trace/cone/light_share.h"

#include "trace/render/shading.h"

#include <algorithm>
#include <cmath>

namespace mrt {

std::optional<Mat2f> light_disc_map(const EllipticalAreaLight& light, const FootprintCone& cone) {
    // At the light the cone's footprint is the light's ellipse E (its semi-axes seen in the
    // cone's frame) over √2, a Gaussian whose units are those of the symmetric root G of
    // E·Eᵀ/2: sample y lies at G·y in the frame, the light's disc point z at E·z there.
    const Mat2f ellipse = cone.project(light.semi_axis_u, light.semi_axis_v);
    const FootprintInverse inverse = FootprintCone::inverse(ellipse);
    if (!(inverse.abs_det > 0.0f)) {
        return std::nullopt;
    }
    const Mat2f root = FootprintCone::convolved(Mat2f::Zero(), ellipse / std::sqrt(2.0f));
    const Mat2f map = inverse.inverse * root;
    if (!all_finite(map)) {
        return std::nullopt;
    }
    return map;
}

float unblocked_light_share(const EllipticalAreaLight& light, const Vec3f& p, const Vec3f& n,
                            const FootprintCone& cone, CoverageMask covered) {
    if (covered == 0) {
        return 1.0f;
    }
    if (covered == kFullCoverage) {
        return 0.0f;
    }
    const float counted = 1.0f - mask_coverage(covered);
    const std::optional<Mat2f> map = light_disc_map(light, cone);
    if (!map) {
        return counted;
    }
    const CoverageSamples& samples = coverage_samples(SamplePattern::LightDisc);
    double all = 0.0;
    double free = 0.0;
    for (int k = 0; k < kCoverageSamples; ++k) {
        const auto i = static_cast<std::size_t>(k);
        const LightSample sample =
            sample_area_light_at(light, *map * Vec2f(samples.x[i], samples.y[i]), p);
        // The light is uniform: every channel has the same weights, up to its radiance.
        const double weight =
            static_cast<double>(std::max(0.0f, n.dot(sample.wi))) * sample.irradiance.sum();
        all += weight;
        free += ((covered >> k) & 1u) == 0 ? weight : 0.0;
    }
    if (!(all > 0.0) || !std::isfinite(all)) {
        return counted;
    }
    return static_cast<float>(free / all);
}

}  // namespace mrt
