#pragma once
// The film: where camera samples become pixels through the reconstruction filter. Samples are
// splatted into every pixel whose filter support covers them, so a wide filter reaches across
// tile borders. To stay bit-identical for any thread count, each tile of a pass splats into its
// own padded buffer, and the buffers are added to the film afterwards in fixed tile order: the
// floating-point sums never depend on the schedule.

#include "common/image.h"
#include "common/progress.h"
#include "trace/pixel_filter.h"
#include "trace/render.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

namespace mrt {

/// Weighted sums of one pixel. Double precision: a reference adds thousands of samples.
struct FilmPixel {
    double weight = 0.0;
    double sum[3] = {0.0, 0.0, 0.0};
};

/// The splat buffer of one tile for one pass: the tile's pixels plus a border as wide as the
/// filter reaches beyond a pixel.
class FilmTile {
  public:
    FilmTile(int x0, int y0, int x1, int y1, int image_width, int image_height,
             const PixelFilter& filter);

    /// Adds radiance `radiance` sampled at continuous raster position (x, y), which lies in
    /// pixel (floor x, floor y) of this tile.
    void add_sample(float raster_x, float raster_y, const Rgb& radiance);

    int x0() const { return m_x0; }
    int y0() const { return m_y0; }
    int x1() const { return m_x1; }
    int y1() const { return m_y1; }
    const FilmPixel& at(int x, int y) const {
        return m_pixels[static_cast<std::size_t>(y - m_y0) * static_cast<std::size_t>(width()) +
                        static_cast<std::size_t>(x - m_x0)];
    }

  private:
    int width() const { return m_x1 - m_x0; }
    int m_x0, m_y0, m_x1, m_y1;  ///< Padded and clipped to the image, half-open.
    PixelFilter m_filter;
    std::vector<FilmPixel> m_pixels;
};

class Film {
  public:
    Film(int width, int height, const PixelFilter& filter);

    int width() const { return m_width; }
    int height() const { return m_height; }
    const PixelFilter& filter() const { return m_filter; }

    /// One pass over the image: `pixel(x, y, tile, counters)` is called once for every pixel,
    /// tiles in parallel on `threads` workers (0 = all), and adds that pixel's samples of this
    /// pass with tile.add_sample. Returns the rays cast, summed over threads.
    template <typename PixelFunction>
    RayCounters add_pass(int threads, const std::string& label, bool quiet, PixelFunction&& pixel);

    /// The filtered image: weighted mean of the samples around each pixel (0 where none).
    Image image() const;

    /// Forgets every sample.
    void clear();

  private:
    void merge(const FilmTile& tile);

    int m_width;
    int m_height;
    PixelFilter m_filter;
    std::vector<FilmPixel> m_pixels;
};

template <typename PixelFunction>
RayCounters Film::add_pass(int threads, const std::string& label, bool quiet,
                           PixelFunction&& pixel) {
    const int tiles_x = (m_width + kTileSize - 1) / kTileSize;
    const int tiles_y = (m_height + kTileSize - 1) / kTileSize;
    const int tile_count = tiles_x * tiles_y;
    std::vector<std::optional<FilmTile>> tiles(static_cast<std::size_t>(tile_count));
    tbb::enumerable_thread_specific<RayCounters> counters;
    Progress progress(label, static_cast<std::uint64_t>(tile_count), quiet);
    tbb::task_arena arena(threads > 0 ? threads : tbb::this_task_arena::max_concurrency());
    arena.execute([&] {
        tbb::parallel_for(0, tile_count, [&](int index) {
            RayCounters& local = counters.local();
            const int x0 = (index % tiles_x) * kTileSize;
            const int y0 = (index / tiles_x) * kTileSize;
            const int x1 = std::min(x0 + kTileSize, m_width);
            const int y1 = std::min(y0 + kTileSize, m_height);
            FilmTile& tile = tiles[static_cast<std::size_t>(index)].emplace(x0, y0, x1, y1, m_width,
                                                                            m_height, m_filter);
            for (int y = y0; y < y1; ++y) {
                for (int x = x0; x < x1; ++x) {
                    pixel(x, y, tile, local);
                }
            }
            progress.advance();
        });
    });
    progress.finish();
    for (const std::optional<FilmTile>& tile : tiles) {
        merge(*tile);
    }
    RayCounters total;
    for (const RayCounters& c : counters) {
        total += c;
    }
    return total;
}

}  // namespace mrt
