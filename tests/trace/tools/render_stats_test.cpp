// The --stats JSON written from the records' field lists keeps every key other tools read (the
// keys before the lists, written out here by hand), with absent values null and an absent cone
// record left out.

#include "trace/tools/render_stats.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <set>
#include <string>

namespace {

using Keys = std::set<std::string>;

Keys keys_of(const nlohmann::json& j) {
    Keys keys;
    for (const auto& item : j.items()) {
        keys.insert(item.key());
    }
    return keys;
}

const Keys kTopKeys = {"build_seconds",
                       "crop",
                       "differentials",
                       "filter",
                       "height",
                       "instanced_triangles",
                       "last_pass_seconds",
                       "load_seconds",
                       "mean_spp",
                       "method",
                       "passes",
                       "peak_rss_bytes",
                       "primary_rays",
                       "rays",
                       "rays_per_second",
                       "render_seconds",
                       "samples",
                       "scene",
                       "secondary_rays",
                       "shadow_rays",
                       "spp",
                       "std_error",
                       "stopped",
                       "texture_filter",
                       "threads",
                       "time_budget",
                       "unique_triangles",
                       "width"};

TEST(RenderStatsJson, KeepsEveryKeyAndLeavesOutAnAbsentConeRecord) {
    mrt::RenderStats stats;
    stats.method = mrt::Method::Distributed;
    stats.width = 4;
    stats.height = 2;
    stats.samples = 12;
    stats.render_seconds = 2.0;
    stats.rays = {10, 20, 30};
    const nlohmann::json j = nlohmann::json::parse(mrt::render_stats_json(stats));
    EXPECT_EQ(keys_of(j), kTopKeys);
    EXPECT_EQ(j["method"], "distributed");
    EXPECT_TRUE(j["crop"].is_null());
    EXPECT_TRUE(j["time_budget"].is_null());
    EXPECT_TRUE(j["std_error"].is_null());
    EXPECT_EQ(j["rays"], 60);
    EXPECT_EQ(j["primary_rays"], 10);
    EXPECT_EQ(j["secondary_rays"], 20);
    EXPECT_EQ(j["shadow_rays"], 30);
    EXPECT_EQ(j["rays_per_second"], 30.0);
    EXPECT_EQ(j["mean_spp"], 1.5);
    EXPECT_EQ(j["stopped"], false);
}

TEST(RenderStatsJson, WritesTheConeRecordWithItsOldKeysAndTheCountersItKept) {
    mrt::RenderStats stats;
    stats.method = mrt::Method::ConeClassic;
    stats.crop = mrt::PixelWindow{1, 2, 3, 4};
    stats.time_budget = 0.5;
    stats.std_error = 0.25;
    stats.cone.emplace();
    stats.cone->primary.rays = 7;
    stats.cone->primary.level_sum = 3.0;
    stats.cone->primary.level_weight = 2.0;
    stats.cone->shadow.abuffer.dropped_insertions = 1;
    stats.cone->shadow.abuffer.evicted_fragments = 2;
    const nlohmann::json j = nlohmann::json::parse(mrt::render_stats_json(stats));
    Keys top = kTopKeys;
    top.insert("cone");
    EXPECT_EQ(keys_of(j), top);
    EXPECT_EQ(j["method"], "cone-classic");
    EXPECT_EQ(j["crop"], nlohmann::json::array({1, 2, 3, 4}));
    EXPECT_EQ(j["time_budget"], 0.5);
    EXPECT_EQ(j["std_error"], 0.25);
    const nlohmann::json& cone = j["cone"];
    EXPECT_EQ(keys_of(cone),
              (Keys{"inside_cones_renormalised", "inside_cones_retraced", "pixels", "pixels_done",
                    "primary", "primary_traversal_thread_seconds", "refined_pixels", "secondary",
                    "secondary_traversal_thread_seconds", "shadow",
                    "shadow_traversal_thread_seconds", "straddled_critical_angle", "stopped"}));
    const Keys traversal = {
        "abuffer_dropped", "abuffer_forced_merges", "back_faces_culled", "cones",
        "fragments_cascaded", "fragments_inserted", "fragments_merged", "instances_entered",
        "mean_point_level", "nodes_culled_by_opacity", "nodes_visited", "point_nodes", "points_hit",
        "points_tested", "spheres_tested", "triangles_hit", "triangles_tested",
        // Kept before but not written:
        "fragments_ignored", "abuffer_dropped_insertions", "abuffer_evicted_fragments",
        "abuffer_dropped_weight", "level_sum", "level_weight"};
    for (const char* kind : {"primary", "secondary", "shadow"}) {
        EXPECT_EQ(keys_of(cone[kind]), traversal) << kind;
    }
    EXPECT_EQ(cone["primary"]["cones"], 7);
    EXPECT_EQ(cone["primary"]["mean_point_level"], 1.5);
    EXPECT_TRUE(cone["secondary"]["mean_point_level"].is_null());
    EXPECT_EQ(cone["shadow"]["abuffer_dropped"], 3);
}

}  // namespace
