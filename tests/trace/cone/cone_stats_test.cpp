// The cone tracer's stats records: += is the sum written out by hand, and << shows every field
// the --stats JSON has.

#include "trace/cone/cone_tracer.h"

#include <gtest/gtest.h>

#include <sstream>
#include <string>

namespace {

using mrt::ConeRenderStats;
using mrt::ConeTraversalStats;

/// A record whose every counter differs (so a field added to the wrong one shows).
ConeTraversalStats numbered(std::uint64_t base) {
    ConeTraversalStats s;
    s.rays = base + 1;
    s.nodes_visited = base + 2;
    s.spheres_tested = base + 3;
    s.points_tested = base + 4;
    s.points_hit = base + 5;
    s.triangles_tested = base + 6;
    s.triangles_hit = base + 7;
    s.instances_entered = base + 8;
    s.culled_by_opacity = base + 9;
    s.back_faces_culled = base + 10;
    s.point_nodes = base + 11;
    s.level_sum = static_cast<double>(base) + 0.5;
    s.level_weight = static_cast<double>(base) + 0.25;
    s.abuffer.inserted = base + 12;
    s.abuffer.ignored = base + 13;
    s.abuffer.merged = base + 14;
    s.abuffer.cascaded = base + 15;
    s.abuffer.forced_merges = base + 16;
    s.abuffer.dropped_insertions = base + 17;
    s.abuffer.evicted_fragments = base + 18;
    s.abuffer.dropped_weight = static_cast<double>(base) + 0.125;
    return s;
}

TEST(ConeStats, TraversalSumIsTheSumByHand) {
    ConeTraversalStats a = numbered(100);
    a += numbered(1000);
    // numbered(100) + numbered(1000): each counter is 1100 + 2k for its k.
    const ConeTraversalStats expected = numbered(1100);
    EXPECT_EQ(a.rays, expected.rays + 1);
    EXPECT_EQ(a.nodes_visited, expected.nodes_visited + 2);
    EXPECT_EQ(a.spheres_tested, expected.spheres_tested + 3);
    EXPECT_EQ(a.points_tested, expected.points_tested + 4);
    EXPECT_EQ(a.points_hit, expected.points_hit + 5);
    EXPECT_EQ(a.triangles_tested, expected.triangles_tested + 6);
    EXPECT_EQ(a.triangles_hit, expected.triangles_hit + 7);
    EXPECT_EQ(a.instances_entered, expected.instances_entered + 8);
    EXPECT_EQ(a.culled_by_opacity, expected.culled_by_opacity + 9);
    EXPECT_EQ(a.back_faces_culled, expected.back_faces_culled + 10);
    EXPECT_EQ(a.point_nodes, expected.point_nodes + 11);
    EXPECT_EQ(a.level_sum, 100.5 + 1000.5);
    EXPECT_EQ(a.level_weight, 100.25 + 1000.25);
    EXPECT_EQ(a.abuffer.inserted, expected.abuffer.inserted + 12);
    EXPECT_EQ(a.abuffer.ignored, expected.abuffer.ignored + 13);
    EXPECT_EQ(a.abuffer.merged, expected.abuffer.merged + 14);
    EXPECT_EQ(a.abuffer.cascaded, expected.abuffer.cascaded + 15);
    EXPECT_EQ(a.abuffer.forced_merges, expected.abuffer.forced_merges + 16);
    EXPECT_EQ(a.abuffer.dropped_insertions, expected.abuffer.dropped_insertions + 17);
    EXPECT_EQ(a.abuffer.evicted_fragments, expected.abuffer.evicted_fragments + 18);
    EXPECT_EQ(a.abuffer.dropped_weight, 100.125 + 1000.125);
    EXPECT_EQ(a.mean_point_level(), (100.5 + 1000.5) / (100.25 + 1000.25));
    EXPECT_EQ(a.abuffer.dropped(), a.abuffer.dropped_insertions + a.abuffer.evicted_fragments);
    EXPECT_FALSE(ConeTraversalStats{}.mean_point_level());
}

TEST(ConeStats, RenderSumAddsEachKindAndAnyStopStops) {
    ConeRenderStats a;
    a.primary = numbered(1);
    a.shadow = numbered(2);
    a.primary_seconds = 1.5;
    a.pixels_done = 3;
    a.pixels = 4;
    ConeRenderStats b;
    b.primary = numbered(10);
    b.secondary = numbered(20);
    b.primary_seconds = 2.25;
    b.secondary_seconds = 0.5;
    b.shadow_seconds = 0.125;
    b.straddled_critical_angle = 7;
    b.inside_cones_retraced = 5;
    b.inside_cones_renormalised = 6;
    b.pixels_done = 30;
    b.pixels = 40;
    b.stopped = true;
    a += b;
    EXPECT_EQ(a.primary.rays, 2u + 11u);
    EXPECT_EQ(a.secondary.rays, 21u);
    EXPECT_EQ(a.shadow.rays, 3u);
    EXPECT_EQ(a.primary.abuffer.merged, 15u + 24u);
    EXPECT_EQ(a.primary_seconds, 3.75);
    EXPECT_EQ(a.secondary_seconds, 0.5);
    EXPECT_EQ(a.shadow_seconds, 0.125);
    EXPECT_EQ(a.straddled_critical_angle, 7u);
    EXPECT_EQ(a.inside_cones_retraced, 5u);
    EXPECT_EQ(a.inside_cones_renormalised, 6u);
    EXPECT_EQ(a.pixels_done, 33u);
    EXPECT_EQ(a.pixels, 44u);
    EXPECT_TRUE(a.stopped);
}

TEST(ConeStats, PrintingShowsEveryCounter) {
    std::ostringstream os;
    os << numbered(0);
    const std::string text = os.str();
    for (const char* field : {"cones 1",
                              "nodes_visited 2",
                              "spheres_tested 3",
                              "points_tested 4",
                              "points_hit 5",
                              "triangles_tested 6",
                              "triangles_hit 7",
                              "instances_entered 8",
                              "nodes_culled_by_opacity 9",
                              "back_faces_culled 10",
                              "point_nodes 11",
                              "level_sum 0.5",
                              "level_weight 0.25",
                              "mean_point_level 2",
                              "fragments_inserted 12",
                              "fragments_ignored 13",
                              "fragments_merged 14",
                              "fragments_cascaded 15",
                              "abuffer_forced_merges 16",
                              "abuffer_dropped_insertions 17",
                              "abuffer_evicted_fragments 18",
                              "abuffer_dropped_weight 0.125",
                              "abuffer_dropped 35"}) {
        EXPECT_NE(text.find(field), std::string::npos) << field << " in " << text;
    }
    std::ostringstream render;
    render << ConeRenderStats{};
    for (const char* field : {"primary ConeTraversalStats{", "secondary ConeTraversalStats{",
                              "shadow ConeTraversalStats{", "primary_traversal_thread_seconds",
                              "straddled_critical_angle", "inside_cones_retraced",
                              "inside_cones_renormalised", "pixels_done", "stopped false"}) {
        EXPECT_NE(render.str().find(field), std::string::npos) << field << " in " << render.str();
    }
}

}  // namespace
