#pragma once
// The --stats JSON every tool writes. Key names are a contract other tools read:
// load_seconds, build_seconds, render_seconds, rays, rays_per_second, peak_rss_bytes, filter,
// passes, samples, mean_spp, std_error (null unless a reference estimated it), stopped (the
// image is incomplete). Each record's field list (common/system/fields.h) names its keys.

#include "common/system/fields.h"
#include "trace/cone/cone_tracer.h"
#include "trace/render/method.h"
#include "trace/render/render.h"

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>

namespace mrt {

struct RenderStats {
    Method method = Method::Whitted;
    std::string scene;
    int width = 0;  ///< The frame's.
    int height = 0;
    std::optional<PixelWindow> crop;  ///< The window rendered, when not the whole frame.
    int spp = 0;
    int threads = 0;
    double load_seconds = 0.0;    ///< Reading the scene and its meshes.
    double build_seconds = 0.0;   ///< Building acceleration structures.
    double render_seconds = 0.0;  ///< Tracing the image.
    RayCounters rays;
    std::string filter = "box";               ///< Reconstruction filter, as --filter spells it.
    std::string texture_filter = "none";      ///< As --texture-filter spells it.
    std::string differentials = "when-read";  ///< As --differentials spells it.
    int passes = 1;                           ///< Passes over the image.
    double last_pass_seconds = 0.0;           ///< Duration of the final pass.
    std::optional<double> time_budget;        ///< Requested budget in seconds, if any.
    std::uint64_t samples = 0;                ///< Camera samples in all.
    std::optional<double> std_error;          ///< RMS standard error of a reference.
    std::uint64_t unique_triangles = 0;
    std::uint64_t instanced_triangles = 0;
    std::uint64_t peak_rss_bytes = 0;  ///< The process's peak resident memory, in bytes.
    /// The cone tracers: traversal counters and time per phase, under "cone".
    std::optional<ConeRenderStats> cone;
    /// The render stopped before every pixel was done (a time guard ran out): "stopped".
    bool stopped = false;

    /// Camera samples per pixel of the frame, on average.
    double mean_spp() const;
    /// Rays of every kind per second of rendering.
    double rays_per_second() const;

    /// Named as --stats writes them: the ray counts among these, the cone tracers' under "cone"
    /// (left out for the other methods).
    static constexpr auto fields = std::tuple{
        Field{"method", &RenderStats::method},
        Field{"scene", &RenderStats::scene},
        Field{"width", &RenderStats::width},
        Field{"height", &RenderStats::height},
        Field{"crop", &RenderStats::crop},
        Field{"spp", &RenderStats::spp},
        Field{"threads", &RenderStats::threads},
        Field{"load_seconds", &RenderStats::load_seconds},
        Field{"build_seconds", &RenderStats::build_seconds},
        Field{"render_seconds", &RenderStats::render_seconds},
        Field{"filter", &RenderStats::filter},
        Field{"texture_filter", &RenderStats::texture_filter},
        Field{"differentials", &RenderStats::differentials},
        Field{"passes", &RenderStats::passes},
        Field{"last_pass_seconds", &RenderStats::last_pass_seconds},
        Field{"time_budget", &RenderStats::time_budget},
        Field{"samples", &RenderStats::samples},
        Field{"mean_spp", &RenderStats::mean_spp},
        Field{"std_error", &RenderStats::std_error},
        Embedded{&RenderStats::rays},
        Field{"rays_per_second", &RenderStats::rays_per_second},
        Field{"unique_triangles", &RenderStats::unique_triangles},
        Field{"instanced_triangles", &RenderStats::instanced_triangles},
        Field{"peak_rss_bytes", &RenderStats::peak_rss_bytes},
        Field{"stopped", &RenderStats::stopped},
        Field{"cone", &RenderStats::cone},
    };
};

std::ostream& operator<<(std::ostream& os, const RenderStats& s);

/// The stats as the JSON --stats writes.
std::string render_stats_json(const RenderStats& stats);

/// Writes render_stats_json (to a temporary name, renamed into place). Throws mrt::Error.
void write_render_stats(const std::filesystem::path& file, const RenderStats& stats);

}  // namespace mrt
