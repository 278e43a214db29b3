#include "trace/tools/render_stats.h"

#include "common/system/atomic_file.h"
#include "common/system/error.h"
#include "common/system/memory_usage.h"

#include <nlohmann/json.hpp>

#include <fstream>
#include <ostream>
#include <system_error>

namespace mrt {

std::ostream& operator<<(std::ostream& os, const RayCounters& c) {
    return os << "RayCounters{primary " << c.primary << ", secondary " << c.secondary << ", shadow "
              << c.shadow << "}";
}

namespace {

nlohmann::json traversal_json(const ConeTraversalStats& s) {
    return {{"cones", s.rays},
            {"nodes_visited", s.nodes_visited},
            {"spheres_tested", s.spheres_tested},
            {"points_tested", s.points_tested},
            {"points_hit", s.points_hit},
            {"triangles_tested", s.triangles_tested},
            {"triangles_hit", s.triangles_hit},
            {"instances_entered", s.instances_entered},
            {"nodes_culled_by_opacity", s.culled_by_opacity},
            {"back_faces_culled", s.back_faces_culled},
            {"point_nodes", s.point_nodes},
            {"mean_point_level",
             s.level_weight > 0.0 ? nlohmann::json(s.level_sum / s.level_weight) : nullptr},
            {"fragments_inserted", s.abuffer.inserted},
            {"fragments_merged", s.abuffer.merged},
            {"fragments_cascaded", s.abuffer.cascaded},
            {"abuffer_forced_merges", s.abuffer.forced_merges},
            {"abuffer_dropped", s.abuffer.dropped_insertions + s.abuffer.evicted_fragments}};
}

nlohmann::json cone_json(const ConeRenderStats& s) {
    return {{"primary", traversal_json(s.primary)},
            {"secondary", traversal_json(s.secondary)},
            {"shadow", traversal_json(s.shadow)},
            {"primary_traversal_thread_seconds", s.primary_seconds},
            {"secondary_traversal_thread_seconds", s.secondary_seconds},
            {"shadow_traversal_thread_seconds", s.shadow_seconds},
            {"straddled_critical_angle", s.straddled_critical_angle},
            {"pixels_done", s.pixels_done},
            {"pixels", s.pixels}};
}

}  // namespace

void write_render_stats(const std::filesystem::path& file, const RenderStats& stats) {
    const double rays = static_cast<double>(stats.rays.total());
    nlohmann::json j = {
        {"method", stats.method},
        {"scene", stats.scene},
        {"width", stats.width},
        {"height", stats.height},
        {"crop", stats.crop ? nlohmann::json::array(
                                  {stats.crop->x0, stats.crop->y0, stats.crop->x1, stats.crop->y1})
                            : nlohmann::json(nullptr)},
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
        {"stopped", stats.stopped},
    };
    if (stats.cone) {
        j["cone"] = cone_json(*stats.cone);
    }
    write_file_atomically(file, j.dump(2) + "\n", "stats file");
}

}  // namespace mrt
