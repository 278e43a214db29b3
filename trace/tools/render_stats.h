#pragma once
// The --stats JSON every tool writes. Key names are a contract other tools read:
// load_seconds, build_seconds, render_seconds, rays, rays_per_second, peak_rss_bytes, filter,
// passes, samples, mean_spp, std_error (null unless a reference estimated it), stopped (the
// image is incomplete).

#include "trace/cone/cone_tracer.h"
#include "trace/render/render.h"

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace mrt {

struct RenderStats {
    std::string method;
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
    double time_budget = 0.0;                 ///< Requested budget in seconds; 0 = none.
    std::uint64_t samples = 0;                ///< Camera samples in all.
    std::optional<double> std_error;          ///< RMS standard error of a reference.
    std::uint64_t unique_triangles = 0;
    std::uint64_t instanced_triangles = 0;
    /// The cone tracers: traversal counters and time per phase, under "cone".
    std::optional<ConeRenderStats> cone;
    /// The render stopped before every pixel was done (a time guard ran out): "stopped".
    bool stopped = false;
};

/// Writes the stats as JSON (to a temporary name, renamed into place). Throws mrt::Error.
void write_render_stats(const std::filesystem::path& file, const RenderStats& stats);

}  // namespace mrt
