#include "trace/render_stats.h"

#include "common/atomic_file.h"
#include "common/error.h"
#include "common/memory_usage.h"

#include <nlohmann/json.hpp>

#include <fstream>
#include <ostream>
#include <system_error>

namespace mrt {

std::ostream& operator<<(std::ostream& os, const RayCounters& c) {
    return os << "RayCounters{primary " << c.primary << ", secondary " << c.secondary << ", shadow "
              << c.shadow << "}";
}

void write_render_stats(const std::filesystem::path& file, const RenderStats& stats) {
    const double rays = static_cast<double>(stats.rays.total());
    const nlohmann::json j = {
        {"method", stats.method},
        {"scene", stats.scene},
        {"width", stats.width},
        {"height", stats.height},
        {"spp", stats.spp},
        {"threads", stats.threads},
        {"load_seconds", stats.load_seconds},
        {"build_seconds", stats.build_seconds},
        {"render_seconds", stats.render_seconds},
        {"filter", stats.filter},
        {"texture_filter", stats.texture_filter},
        {"differentials", stats.differentials},
        {"passes", stats.passes},
        {"last_pass_seconds", stats.last_pass_seconds},
        {"time_budget", stats.time_budget > 0.0 ? nlohmann::json(stats.time_budget) : nullptr},
        {"samples", stats.samples},
        {"mean_spp", stats.width > 0 && stats.height > 0
                         ? static_cast<double>(stats.samples) /
                               (static_cast<double>(stats.width) * stats.height)
                         : 0.0},
        {"std_error", stats.std_error ? nlohmann::json(*stats.std_error) : nullptr},
        {"rays", stats.rays.total()},
        {"primary_rays", stats.rays.primary},
        {"secondary_rays", stats.rays.secondary},
        {"shadow_rays", stats.rays.shadow},
        {"rays_per_second", stats.render_seconds > 0.0 ? rays / stats.render_seconds : 0.0},
        {"unique_triangles", stats.unique_triangles},
        {"instanced_triangles", stats.instanced_triangles},
        {"peak_rss_bytes", peak_rss_bytes()},
    };
    write_file_atomically(file, j.dump(2) + "\n", "stats file");
}

}  // namespace mrt
