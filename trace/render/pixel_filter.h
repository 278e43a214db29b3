#pragma once
// Pixel reconstruction filters. A comparison renders the method and its reference with the same
// filter, so the filter itself is never counted as error.

#include <algorithm>
#include <cmath>
#include <iosfwd>
#include <string>

namespace mrt {

struct PixelFilter {
    enum class Kind { Box, Gaussian };
    Kind kind = Kind::Box;
    /// Half-width of the support in pixels (box: 0.5 is exactly the pixel).
    float radius = 0.5f;
    /// Standard deviation in pixels (Gaussian only).
    float sigma = 0.5f;

    static PixelFilter box() { return {}; }
    /// Gaussian of standard deviation `sigma` pixels, truncated at 3σ (at least half a pixel).
    static PixelFilter gaussian(float sigma) {
        return {Kind::Gaussian, std::max(0.5f, 3.0f * sigma), sigma};
    }

    /// Unnormalised weight of a sample at offset (dx, dy) pixels from a pixel centre. The
    /// Gaussian has its value at the support edge subtracted, so it falls to zero continuously
    /// instead of stepping (no ring of discontinuity around each sample).
    float weight(float dx, float dy) const {
        if (std::abs(dx) > radius || std::abs(dy) > radius) {
            return 0.0f;
        }
        if (kind == Kind::Box) {
            return 1.0f;
        }
        const auto g = [this](float d) {
            const float s2 = 2.0f * sigma * sigma;
            return std::max(0.0f, std::exp(-d * d / s2) - std::exp(-radius * radius / s2));
        };
        return g(dx) * g(dy);
    }
};

/// Parses "box" or "gaussian" / "gaussian:SIGMA" (σ in pixels, default 0.5); throws mrt::Error.
PixelFilter parse_pixel_filter(const std::string& text);

/// The spelling parse_pixel_filter reads back to the same filter ("box", "gaussian:0.5").
std::string to_string(const PixelFilter& f);

std::ostream& operator<<(std::ostream& os, const PixelFilter& f);

}  // namespace mrt
