#pragma once
// Which pixels hold detail at their own scale: adaptive refinement's test (Whitted 1980; for
// pyramidal rays Genetti, Gordon & Williams 1998). A tracer that prefilters its pixel with one
// sample (the cone tracer) averages a glint or an edge inside the footprint by its attributes,
// not by what the rays see; where a pixel's value differs much from a neighbour's, that detail
// is there, and narrower cones see it better.

#include "common/math/math.h"
#include "trace/render/render.h"

#include <cstdint>
#include <vector>

namespace mrt {

/// One value per pixel of a rectangle of the frame, and whether it was computed.
class PixelValues {
  public:
    explicit PixelValues(const PixelWindow& region);

    const PixelWindow& region() const { return m_region; }
    bool contains(int x, int y) const { return m_region.contains(x, y); }
    /// Pixel (x, y) of the frame, inside region().
    void set(int x, int y, const Rgb& value) {
        const std::size_t i = m_region.offset(x, y);
        m_values[i] = value;
        m_known[i] = 1;
    }
    bool known(int x, int y) const { return m_known[m_region.offset(x, y)] != 0; }
    const Rgb& at(int x, int y) const { return m_values[m_region.offset(x, y)]; }

  private:
    PixelWindow m_region;
    std::vector<Rgb> m_values;
    std::vector<std::uint8_t> m_known;
};

/// For every pixel of `window` (at window.offset): whether it is known and some known
/// edge neighbour (left, right, above, below) differs from it by more than `contrast` in any
/// channel. Values that are not finite never count as contrast.
std::vector<std::uint8_t> high_contrast_pixels(const PixelValues& values, const PixelWindow& window,
                                               float contrast);

}  // namespace mrt
