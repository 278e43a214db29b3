#include "trace/render/film.h"

namespace mrt {

int filter_reach(const PixelFilter& filter) {
    // The filter's support beyond half a pixel.
    return std::max(0, static_cast<int>(std::ceil(filter.radius - 0.5f)));
}

namespace {

bool is_pixel_box(const PixelFilter& filter) {
    return filter.kind == PixelFilter::Kind::Box && filter.radius == 0.5f;
}

}  // namespace

FilmTile::FilmTile(int x0, int y0, int x1, int y1, int image_width, int image_height,
                   const PixelFilter& filter)
    : m_x0(std::max(0, x0 - filter_reach(filter))),
      m_y0(std::max(0, y0 - filter_reach(filter))),
      m_x1(std::min(image_width, x1 + filter_reach(filter))),
      m_y1(std::min(image_height, y1 + filter_reach(filter))),
      m_filter(filter),
      m_pixels(static_cast<std::size_t>(m_x1 - m_x0) * static_cast<std::size_t>(m_y1 - m_y0)) {}

void FilmTile::add_sample(float raster_x, float raster_y, const Rgb& sample) {
    // A NaN or Inf from a degenerate path would poison every pixel the filter reaches; it
    // counts as black (its weight stays, so the estimate is not biased upwards).
    const Rgb radiance = sample.allFinite() ? sample : Rgb(Rgb::Zero());
    const auto accumulate = [&](int x, int y, float weight) {
        FilmPixel& p =
            m_pixels[static_cast<std::size_t>(y - m_y0) * static_cast<std::size_t>(width()) +
                     static_cast<std::size_t>(x - m_x0)];
        p.weight += weight;
        for (int c = 0; c < 3; ++c) {
            p.sum[c] += static_cast<double>(weight) * static_cast<double>(radiance[c]);
        }
    };
    if (is_pixel_box(m_filter)) {
        // The half-open pixel square: a sample on a pixel border belongs to one pixel only.
        const int x = std::clamp(static_cast<int>(std::floor(raster_x)), m_x0, m_x1 - 1);
        const int y = std::clamp(static_cast<int>(std::floor(raster_y)), m_y0, m_y1 - 1);
        accumulate(x, y, 1.0f);
        return;
    }
    const float r = m_filter.radius;
    const int xa = std::max(m_x0, static_cast<int>(std::ceil(raster_x - 0.5f - r)));
    const int xb = std::min(m_x1 - 1, static_cast<int>(std::floor(raster_x - 0.5f + r)));
    const int ya = std::max(m_y0, static_cast<int>(std::ceil(raster_y - 0.5f - r)));
    const int yb = std::min(m_y1 - 1, static_cast<int>(std::floor(raster_y - 0.5f + r)));
    for (int y = ya; y <= yb; ++y) {
        for (int x = xa; x <= xb; ++x) {
            const float w = m_filter.weight(raster_x - (static_cast<float>(x) + 0.5f),
                                            raster_y - (static_cast<float>(y) + 0.5f));
            if (w > 0.0f) {
                accumulate(x, y, w);
            }
        }
    }
}

Film::Film(int width, int height, const PixelFilter& filter, std::optional<PixelWindow> window)
    : m_width(width),
      m_height(height),
      m_filter(filter),
      m_window(window.value_or(PixelWindow{0, 0, width, height})),
      m_pixels(static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {}

void Film::merge(const FilmTile& tile) {
    for (int y = tile.y0(); y < tile.y1(); ++y) {
        for (int x = tile.x0(); x < tile.x1(); ++x) {
            const FilmPixel& from = tile.at(x, y);
            FilmPixel& to =
                m_pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(m_width) +
                         static_cast<std::size_t>(x)];
            to.weight += from.weight;
            for (int c = 0; c < 3; ++c) {
                to.sum[c] += from.sum[c];
            }
        }
    }
}

Image Film::image() const {
    Image image(m_window.width(), m_window.height());
    for (int y = m_window.y0; y < m_window.y1; ++y) {
        for (int x = m_window.x0; x < m_window.x1; ++x) {
            const FilmPixel& p =
                m_pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(m_width) +
                         static_cast<std::size_t>(x)];
            if (p.weight > 0.0) {
                image.set(x - m_window.x0, y - m_window.y0,
                          Rgb(static_cast<float>(p.sum[0] / p.weight),
                              static_cast<float>(p.sum[1] / p.weight),
                              static_cast<float>(p.sum[2] / p.weight)));
            }
        }
    }
    return image;
}

void Film::clear() {
    std::fill(m_pixels.begin(), m_pixels.end(), FilmPixel{});
}

}  // namespace mrt
