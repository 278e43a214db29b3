#pragma once
// The --stats JSON every tool writes. Key names are a contract other tools read:
// load_seconds, build_seconds, render_seconds, rays, rays_per_second, peak_rss_bytes.

#include "trace/render.h"

#include <cstdint>
#include <filesystem>
#include <string>

namespace mrt {

struct RenderStats {
    std::string method;
    std::string scene;
    int width = 0;
    int height = 0;
    int spp = 0;
    int threads = 0;
    double load_seconds = 0.0;    ///< Reading the scene and its meshes.
    double build_seconds = 0.0;   ///< Building acceleration structures.
    double render_seconds = 0.0;  ///< Tracing the image.
    RayCounters rays;
    std::uint64_t unique_triangles = 0;
    std::uint64_t instanced_triangles = 0;
};

/// Peak resident set size of this process so far, in bytes.
std::uint64_t peak_rss_bytes();

/// Writes the stats as JSON (to a temporary name, renamed into place). Throws mrt::Error.
void write_render_stats(const std::filesystem::path& file, const RenderStats& stats);

}  // namespace mrt
