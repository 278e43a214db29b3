#pragma once
// What every tracer takes and returns, and the one parallel image loop they share: square tiles
// handed to oneTBB, each pixel computed independently from its own random stream, so the image
// is bit-identical for any thread count and any tile schedule.

#include "common/image.h"
#include "common/progress.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstdint>
#include <iosfwd>
#include <string>

namespace mrt {

/// Rays cast, by kind.
struct RayCounters {
    std::uint64_t primary = 0;    ///< Camera rays.
    std::uint64_t secondary = 0;  ///< Reflection and refraction rays.
    std::uint64_t shadow = 0;     ///< Visibility rays towards lights.

    std::uint64_t total() const { return primary + secondary + shadow; }
    RayCounters& operator+=(const RayCounters& o) {
        primary += o.primary;
        secondary += o.secondary;
        shadow += o.shadow;
        return *this;
    }
};

struct RenderOptions {
    int width = 0;           ///< Image width in pixels.
    int height = 0;          ///< Image height in pixels.
    int spp = 1;             ///< Samples per pixel (1 = the pixel centre).
    std::uint64_t seed = 0;  ///< Seed of every random stream.
    int threads = 0;         ///< Worker threads; 0 = all hardware threads.
    int max_depth = -1;      ///< Reflection/refraction depth; −1 = the scene's.
    bool quiet = false;      ///< No progress bar.
};

struct RenderOutput {
    Image image;
    RayCounters rays;
    double render_seconds = 0.0;
};

std::ostream& operator<<(std::ostream& os, const RayCounters& c);

/// Side of the square tiles the image is cut into.
inline constexpr int kTileSize = 16;

/// Runs `pixel(x, y, counters) -> Rgb` for every pixel of a width × height image on `threads`
/// workers (0 = all), with a progress bar labelled `label`, and returns the image and the
/// counters summed over threads.
template <typename PixelFunction>
RenderOutput render_image(const RenderOptions& options, const std::string& label,
                          PixelFunction&& pixel) {
    RenderOutput out;
    out.image = Image(options.width, options.height);
    const int tiles_x = (options.width + kTileSize - 1) / kTileSize;
    const int tiles_y = (options.height + kTileSize - 1) / kTileSize;
    const int tile_count = tiles_x * tiles_y;
    tbb::enumerable_thread_specific<RayCounters> counters;
    Progress progress(label, static_cast<std::uint64_t>(tile_count), options.quiet);
    const int threads =
        options.threads > 0 ? options.threads : tbb::this_task_arena::max_concurrency();
    tbb::task_arena arena(threads);
    arena.execute([&] {
        tbb::parallel_for(0, tile_count, [&](int tile) {
            RayCounters& local = counters.local();
            const int x0 = (tile % tiles_x) * kTileSize;
            const int y0 = (tile / tiles_x) * kTileSize;
            const int x1 = std::min(x0 + kTileSize, options.width);
            const int y1 = std::min(y0 + kTileSize, options.height);
            for (int y = y0; y < y1; ++y) {
                for (int x = x0; x < x1; ++x) {
                    out.image.set(x, y, pixel(x, y, local));
                }
            }
            progress.advance();
        });
    });
    progress.finish();
    for (const RayCounters& c : counters) {
        out.rays += c;
    }
    return out;
}

}  // namespace mrt
