#pragma once
// What every tracer takes and returns. Images are computed in square tiles handed to oneTBB
// (trace/render/film.h), each sample from its own counter-based random stream, so an image is
// bit-identical for any thread count and any tile schedule.

#include "common/image/image.h"
#include "common/system/enum_names.h"
#include "common/system/fields.h"
#include "common/texture/texture.h"
#include "trace/render/pixel_filter.h"

#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>

namespace mrt {

/// Rays cast, by kind.
struct RayCounters {
    std::uint64_t primary = 0;    ///< Camera rays.
    std::uint64_t secondary = 0;  ///< Reflection and refraction rays.
    std::uint64_t shadow = 0;     ///< Visibility rays towards lights.

    std::uint64_t total() const { return primary + secondary + shadow; }

    /// Named as --stats writes them.
    static constexpr auto fields = std::tuple{
        Field{"primary_rays", &RayCounters::primary},
        Field{"secondary_rays", &RayCounters::secondary},
        Field{"shadow_rays", &RayCounters::shadow},
        Field{"rays", &RayCounters::total},
    };
    RayCounters& operator+=(const RayCounters& o) { return add_fields(*this, o); }
};

/// Which rays carry ray differentials.
enum class Differentials {
    /// Camera rays when the texture filter reads them and the scene has a texture; at each hit
    /// only when a texture there or a reflected or refracted ray reads them. The default.
    WhenRead,
    /// Every ray, transferred and propagated at every hit whether or not anything reads them:
    /// with the `none` texture filter this prices carrying them (lookups stay unfiltered).
    Always,
};

inline constexpr EnumNames<Differentials, 2> kDifferentialsNames{{{
    {Differentials::WhenRead, "when-read"},
    {Differentials::Always, "always"},
}}};

/// Parses "when-read" | "always"; throws mrt::Error otherwise.
Differentials parse_differentials(const std::string& text);
std::string to_string(Differentials differentials);

/// A window of a frame: pixels [x0, x1) × [y0, y1).
struct PixelWindow {
    int x0 = 0;
    int y0 = 0;
    int x1 = 0;
    int y1 = 0;

    int width() const { return x1 - x0; }
    int height() const { return y1 - y0; }
    std::size_t area() const {
        return static_cast<std::size_t>(width()) * static_cast<std::size_t>(height());
    }
    bool contains(int x, int y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
    /// Row-major index of pixel (x, y) of the frame, inside the window.
    std::size_t offset(int x, int y) const {
        return static_cast<std::size_t>(y - y0) * static_cast<std::size_t>(width()) +
               static_cast<std::size_t>(x - x0);
    }
    bool operator==(const PixelWindow&) const = default;
};

/// What every tracer reads. What only one reads is in its own options: WhittedOptions
/// (trace/raytrace/whitted.h), DistributedOptions (trace/raytrace/distributed.h), ConeOptions
/// (trace/cone/cone_tracer.h); which command-line options feed which is trace/render/method.h.
struct RenderOptions {
    int width = 0;   ///< Frame width in pixels.
    int height = 0;  ///< Frame height in pixels.
    /// Render only this window of the frame (inside it, non-empty): the image is the window's,
    /// every pixel of it as the full frame's render has it (the same per-pixel random streams;
    /// the pixels around it whose samples the filter, or the adaptive pass's neighbourhood,
    /// reaches are traced too). Empty: the whole frame.
    std::optional<PixelWindow> crop;
    std::uint64_t seed = 0;  ///< Seed of every random stream.
    int threads = 0;         ///< Worker threads; 0 = all hardware threads.
    int max_depth = -1;      ///< Reflection/refraction depth; −1 = the scene's.
    bool quiet = false;      ///< No progress bar.
    PixelFilter filter;      ///< Reconstruction filter every sample is splatted through.
    /// How textures are filtered (Igehy §4); all but None make rays carry differentials.
    TextureFilter texture_filter = TextureFilter::Anisotropic;
    Differentials differentials = Differentials::WhenRead;
};

struct RenderOutput {
    Image image;
    RayCounters rays;
    double render_seconds = 0.0;
    int spp = 1;                      ///< Samples per pixel used (adaptive: the cap).
    int passes = 1;                   ///< Passes over the image.
    double last_pass_seconds = 0.0;   ///< Duration of the final pass.
    std::uint64_t samples = 0;        ///< Camera samples, all pixels and passes.
    std::optional<double> std_error;  ///< Estimated RMS standard error (references).
};

std::ostream& operator<<(std::ostream& os, const RayCounters& c);
std::ostream& operator<<(std::ostream& os, const PixelWindow& w);

/// The window an image is rendered for: the crop, or the whole frame.
inline PixelWindow output_window(const RenderOptions& options) {
    return options.crop.value_or(PixelWindow{0, 0, options.width, options.height});
}

/// Side of the square tiles the image is cut into.
inline constexpr int kTileSize = 16;

}  // namespace mrt
