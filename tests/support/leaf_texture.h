#pragma once
// A leaf for cut-out tests: an 8-bit RGBA PNG whose alpha is 255 inside an ellipse and 0
// outside, as leaf, fence and hair textures are (a binary mask in the alpha channel).

#include <OpenImageIO/imageio.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace mrt::testing {

/// Whether texel (x, y) of a `size`² leaf is inside it: the ellipse of semi-axes 0.45 (across)
/// and 0.3 (down) of the width around the centre.
inline bool leaf_texel(int x, int y, int size) {
    const double u = ((x + 0.5) / size - 0.5) / 0.45;
    const double v = ((y + 0.5) / size - 0.5) / 0.3;
    return u * u + v * v <= 1.0;
}

/// Writes the leaf as `file` (colour `rgb` in 8-bit sRGB where it stands, black where it does
/// not); returns the share of its texels inside it.
inline double write_leaf_texture(const std::filesystem::path& file, int size,
                                 const std::array<std::uint8_t, 3>& rgb = {60, 160, 40}) {
    std::vector<std::uint8_t> pixels(static_cast<std::size_t>(size) * size * 4, 0);
    std::size_t inside = 0;
    for (int y = 0; y < size; ++y) {
        for (int x = 0; x < size; ++x) {
            if (leaf_texel(x, y, size)) {
                std::uint8_t* p = &pixels[(static_cast<std::size_t>(y) * size + x) * 4];
                p[0] = rgb[0];
                p[1] = rgb[1];
                p[2] = rgb[2];
                p[3] = 255;
                ++inside;
            }
        }
    }
    const auto out = OIIO::ImageOutput::create(file.string());
    const OIIO::ImageSpec spec(size, size, 4, OIIO::TypeDesc::UINT8);
    if (!out || !out->open(file.string(), spec) ||
        !out->write_image(OIIO::TypeDesc::UINT8, pixels.data()) || !out->close()) {
        throw std::runtime_error("cannot write the leaf texture " + file.string());
    }
    return static_cast<double>(inside) / (static_cast<double>(size) * size);
}

}  // namespace mrt::testing
