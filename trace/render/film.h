#pragma once
// The film: where camera samples become pixels through the reconstruction filter. Samples are
// splatted into every pixel whose filter support covers them, so a wide filter reaches across
// tile borders. To stay bit-identical for any thread count, each tile of a pass splats into its
// own padded buffer, and the buffers are added to the film afterwards in fixed tile order: the
// floating-point sums never depend on the schedule.

#include "common/image/image.h"
#include "common/system/progress.h"
#include "trace/render/pixel_filter.h"
#include "trace/render/render.h"

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
    /// A film for `window` of a width × height frame (the whole frame when empty). Samples are
    /// placed in the frame's coordinates; image() is the window's.
    Film(int width, int height, const PixelFilter& filter,
         std::optional<PixelWindow> window = std::nullopt);

    int width() const { return m_width; }
    int height() const { return m_height; }
    const PixelFilter& filter() const { return m_filter; }

    /// One pass: `pixel(x, y, tile, counters)` is called once for every pixel of the frame's
    /// tiles that lie within the filter's reach plus `margin` pixels of the window, tiles in
    /// parallel on `threads` workers (0 = all), and adds that pixel's samples of this pass
    /// with tile.add_sample. The window's pixels get exactly the sums the whole frame's render
    /// gives them: the same tiles reach them, merged in the same order. Returns the rays cast,
    /// summed over threads.
    template <typename PixelFunction>
    RayCounters add_pass(int threads, const std::string& label, bool quiet, PixelFunction&& pixel,
                         int margin = 0);

    /// Pixels the last pass called `pixel` for.
    std::uint64_t last_pass_pixels() const { return m_last_pass_pixels; }
    const PixelWindow& window() const { return m_window; }

    /// The window's filtered image: weighted mean of the samples around each pixel (0 where
    /// none).
    Image image() const;

    /// Forgets every sample.
    void clear();

  private:
    void merge(const FilmTile& tile);

    int m_width;
    int m_height;
    PixelFilter m_filter;
    PixelWindow m_window;
    std::vector<FilmPixel> m_pixels;
    std::uint64_t m_last_pass_pixels = 0;
};

/// Pixels beyond its own that a sample reaches through `filter`.
int filter_reach(const PixelFilter& filter);

template <typename PixelFunction>
RayCounters Film::add_pass(int threads, const std::string& label, bool quiet, PixelFunction&& pixel,
                           int margin) {
    const int tiles_x = (m_width + kTileSize - 1) / kTileSize;
    const int tiles_y = (m_height + kTileSize - 1) / kTileSize;
    // The frame's tiles that the window needs: those within reach of it. The same grid as the
    // whole frame's, so that every tile is the same pixels and splats in the same order.
    const int reach = filter_reach(m_filter) + std::max(0, margin);
    const int x0 = std::max(0, m_window.x0 - reach);
    const int y0 = std::max(0, m_window.y0 - reach);
    const int x1 = std::min(m_width, m_window.x1 + reach);
    const int y1 = std::min(m_height, m_window.y1 + reach);
    std::vector<int> active;
    for (int ty = y0 / kTileSize; ty * kTileSize < y1 && ty < tiles_y; ++ty) {
        for (int tx = x0 / kTileSize; tx * kTileSize < x1 && tx < tiles_x; ++tx) {
            active.push_back(ty * tiles_x + tx);
        }
    }
    std::vector<std::optional<FilmTile>> tiles(active.size());
    tbb::enumerable_thread_specific<RayCounters> counters;
    Progress progress(label, static_cast<std::uint64_t>(active.size()), quiet);
    tbb::task_arena arena(threads > 0 ? threads : tbb::this_task_arena::max_concurrency());
    arena.execute([&] {
        tbb::parallel_for(std::size_t{0}, active.size(), [&](std::size_t slot) {
            RayCounters& local = counters.local();
            const int index = active[slot];
            const int tile_x0 = (index % tiles_x) * kTileSize;
            const int tile_y0 = (index / tiles_x) * kTileSize;
            const int tile_x1 = std::min(tile_x0 + kTileSize, m_width);
            const int tile_y1 = std::min(tile_y0 + kTileSize, m_height);
            FilmTile& tile = tiles[slot].emplace(tile_x0, tile_y0, tile_x1, tile_y1, m_width,
                                                 m_height, m_filter);
            for (int y = tile_y0; y < tile_y1; ++y) {
                for (int x = tile_x0; x < tile_x1; ++x) {
                    pixel(x, y, tile, local);
                }
            }
            progress.advance();
        });
    });
    progress.finish();
    m_last_pass_pixels = 0;
    for (const std::optional<FilmTile>& tile : tiles) {
        merge(*tile);
    }
    for (const int index : active) {
        const int tile_x0 = (index % tiles_x) * kTileSize;
        const int tile_y0 = (index / tiles_x) * kTileSize;
        m_last_pass_pixels += static_cast<std::uint64_t>(std::min(kTileSize, m_width - tile_x0)) *
                              static_cast<std::uint64_t>(std::min(kTileSize, m_height - tile_y0));
    }
    RayCounters total;
    for (const RayCounters& c : counters) {
        total += c;
    }
    return total;
}

}  // namespace mrt
