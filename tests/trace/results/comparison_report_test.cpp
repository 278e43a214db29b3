// What results.json and results.csv hold (comparison_report.h), from comparisons made up by
// hand: no run is rendered.

#include "trace/results/comparison_report.h"
#include "tests/support/test_support.h"
#include "trace/render/method.h"
#include "trace/results/method_spec.h"
#include "trace/results/results.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <limits>
#include <sstream>
#include <string>

namespace {

using mrt::testing::contains;
using nlohmann::json;

mrt::Comparison example_comparison() {
    mrt::Comparison c;
    c.scene = "/s.json";
    c.width = 4;
    c.height = 3;
    c.filter = "box";
    c.reference.image = "reference.png";
    c.reference.exr = "/x/reference.exr";
    c.reference.info.spp = 16;
    mrt::RunResult a;
    a.method = mrt::Method::Whitted;
    a.spec = "whitted";
    a.render_seconds = 0.1;
    a.total_seconds = 0.30000000000000004;
    a.rays = 12;
    a.rmse = 0.0;
    a.psnr = std::numeric_limits<double>::infinity();
    a.ssim = 1.0;
    mrt::RunResult b = a;
    b.spec = "distributed:spp-max=4,spp-initial=2";
    b.samples = 99;
    b.psnr = 31.25;
    c.runs = {a, b};
    return c;
}

TEST(ComparisonReport, InfinitePsnrIsNullInJsonAndInfInCsv) {
    const mrt::Comparison c = example_comparison();
    const json j = json::parse(mrt::results_json_text(c));
    EXPECT_TRUE(j["runs"][0]["psnr"].is_null());
    EXPECT_EQ(j["runs"][1]["psnr"], 31.25);
    EXPECT_TRUE(j["runs"][0]["samples"].is_null());
    EXPECT_EQ(j["runs"][1]["samples"], 99);
    EXPECT_EQ(j["runs"][0]["total_seconds"].get<double>(), 0.30000000000000004);
    EXPECT_EQ(j["reference"]["exr"], "reference.exr");

    std::istringstream csv(mrt::results_csv_text(c));
    std::string header;
    std::string row1;
    std::string row2;
    std::getline(csv, header);
    std::getline(csv, row1);
    std::getline(csv, row2);
    EXPECT_EQ(header,
              "method,spec,render_seconds,total_seconds,wall_seconds,rays,samples,rmse,psnr,"
              "ssim,image,error_image,stats,stopped,display_rmse");
    EXPECT_EQ(row1, "whitted,whitted,0.1,0.30000000000000004,0,12,,0,inf,1,,,,false,0");
    EXPECT_TRUE(contains(row2, ",\"distributed:spp-max=4,spp-initial=2\",")) << row2;
    std::ostringstream table;
    mrt::print_results_table(table, c);
    EXPECT_TRUE(contains(table.str(), " inf ")) << table.str();
}

// The derived figures as results.json writes them, for runs whose curves are power laws worked
// out by hand: distributed RMSE = 0.1·t^-1/2 at t = 1, 4 and 16; cone at 0.5 s, RMSE 0.04 (the
// baseline, no distributed run that fast); whitted at 0.25 s, RMSE 0.3 (never as accurate).
TEST(ComparisonReport, DerivedFiguresAreWrittenForThePages) {
    mrt::Comparison c = example_comparison();
    const mrt::RunResult base = c.runs[0];
    const auto with = [&](const std::string& spec, double seconds, double rmse) {
        mrt::RunResult r = base;
        r.spec = spec;
        r.method = mrt::parse_method_spec(spec).method;
        r.render_seconds = seconds;
        r.rmse = rmse;
        return r;
    };
    c.runs = {with("whitted", 0.25, 0.3), with("distributed:spp-max=4", 1.0, 0.1),
              with("distributed:spp-max=16", 4.0, 0.05),
              with("distributed:spp-max=64", 16.0, 0.025), with("cone", 0.5, 0.04)};
    const json d = json::parse(mrt::results_json_text(c))["derived"];
    EXPECT_EQ(d["baseline"]["spec"], "cone");
    EXPECT_EQ(d["baseline"]["run"], 4);
    EXPECT_EQ(d["baseline"]["chosen_as"], "first cone run");
    // The baseline's RMSE and, of the fixed levels, the one within [0.025, 0.3].
    EXPECT_EQ(d["levels"], json::parse("[0.05, 0.04]"));
    EXPECT_EQ(d["curves"][1]["label"], "distributed");
    EXPECT_EQ(d["curves"][1]["runs"], json::parse("[1, 2, 3]"));
    // Distributed reaches 0.05 at its 4 s run and 0.04 at (0.1 / 0.04)² = 6.25 s; cone is
    // below 0.05 already (at most its 0.5 s); whitted never gets there (at least its 0.25 s).
    const json& reach = d["time_to_error"]["distributed"];
    EXPECT_EQ(reach[0]["how"], "measured");
    EXPECT_EQ(reach[0]["seconds"], 4.0);
    EXPECT_NEAR(reach[1]["seconds"].get<double>(), 6.25, 1e-12);
    EXPECT_EQ(reach[1]["relation"], "equal");
    EXPECT_EQ(d["time_to_error"]["cone"][0]["relation"], "at most");
    EXPECT_EQ(d["time_to_error"]["cone"][0]["seconds"], 0.5);
    EXPECT_EQ(d["time_to_error"]["whitted"][1]["relation"], "at least");
    EXPECT_EQ(d["time_to_error"]["whitted"][1]["seconds"], 0.25);
    EXPECT_TRUE(d["equal_time"]["distributed"].is_null());
    EXPECT_EQ(d["error_ratio_at_equal_time"]["cone"], 1.0);
    // Only at 0.04 do two curves both have a time: cone 0.5 s, distributed 6.25 s.
    ASSERT_EQ(d["speedup_at_equal_error"].size(), 1u);
    const json& s = d["speedup_at_equal_error"][0];
    EXPECT_EQ(s["faster"], "cone");
    EXPECT_EQ(s["slower"], "distributed");
    EXPECT_NEAR(s["speedup"].get<double>(), 12.5, 1e-12);
    EXPECT_TRUE(d["dominated_runs"].empty());

    // The console shows the same figures.
    std::ostringstream table;
    mrt::print_results_table(table, c);
    for (const char* line :
         {"baseline: cone (first cone run), 0.5 s, RMSE 0.04\n",
          "RMSE at the baseline's time: cone 0.04 (1×)\n",
          "time to RMSE 0.05: whitted ≥ 0.25 s, distributed 4 s, cone ≤ 0.5 s\n",
          "time to RMSE 0.04: whitted ≥ 0.25 s, distributed 6.25 s, cone 0.5 s\n",
          "at RMSE 0.04: cone is 12.5× faster than distributed (0.5 s against "
          "6.25 s)\n"}) {
        EXPECT_TRUE(contains(table.str(), line)) << line << "\nin\n" << table.str();
    }

    // Runs that equal the reference have nothing to plot.
    EXPECT_TRUE(json::parse(mrt::results_json_text(example_comparison()))["derived"].is_null());
}

}  // namespace
