#include "trace/render/pixel_contrast.h"

#include "common/system/check.h"

#include <array>
#include <utility>

namespace mrt {

PixelValues::PixelValues(const PixelWindow& region)
    : m_region(region), m_values(region.area(), Rgb::Zero()), m_known(region.area(), 0) {}

std::vector<std::uint8_t> high_contrast_pixels(const PixelValues& values, const PixelWindow& window,
                                               float contrast) {
    std::vector<std::uint8_t> high(window.area(), 0);
    constexpr std::array<std::pair<int, int>, 4> kNeighbours{{{-1, 0}, {1, 0}, {0, -1}, {0, 1}}};
    for (int y = window.y0; y < window.y1; ++y) {
        for (int x = window.x0; x < window.x1; ++x) {
            MRT_CHECK(values.contains(x, y));
            if (!values.known(x, y)) {
                continue;
            }
            const Rgb& value = values.at(x, y);
            bool differs = false;
            for (const auto& [dx, dy] : kNeighbours) {
                const int nx = x + dx, ny = y + dy;
                if (values.contains(nx, ny) && values.known(nx, ny)) {
                    // Written so that a NaN on either side compares false.
                    differs = differs || ((values.at(nx, ny) - value).abs() > contrast).any();
                }
            }
            high[window.offset(x, y)] = differs ? 1 : 0;
        }
    }
    return high;
}

}  // namespace mrt
