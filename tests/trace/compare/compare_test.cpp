// mrt-compare: method specs, the child process runner, the reference cache, the results files
// and the tool end to end (files, numbers recomputed from the written images, cache reuse and
// invalidation, one-line errors).

#include "common/image/image.h"
#include "common/image/image_metrics.h"
#include "common/system/error.h"
#include "tests/support/test_support.h"
#include "trace/compare/child_process.h"
#include "trace/compare/comparison.h"
#include "trace/compare/reference_cache.h"
#include "trace/render/method.h"
#include "trace/results/method_spec.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using mrt::testing::contains;
using mrt::testing::error_message;
using nlohmann::json;
using Args = std::vector<std::string>;

int count_lines(const std::string& s) {
    return static_cast<int>(std::count(s.begin(), s.end(), '\n'));
}

/// The console's lines before the derived figures (the runs, the reference, the headline
/// ratios), after checking that the derived figures follow them.
int lines_before_derived_figures(const std::string& out) {
    const std::size_t at = out.find("\nbaseline: ");
    EXPECT_NE(at, std::string::npos) << out;
    EXPECT_TRUE(contains(out, "\ntime to RMSE ")) << out;
    return at == std::string::npos ? count_lines(out) : count_lines(out.substr(0, at + 1));
}

/// A fresh directory for the running test, with a space in its name so that every path handed
/// between mrt-compare and mrt-trace has one.
fs::path temp_dir() {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    const fs::path dir =
        fs::temp_directory_path() / ("mrt compare " + std::to_string(::getpid()) + " " +
                                     test->test_suite_name() + "." + test->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

json read_json(const fs::path& file) {
    std::ifstream in(file);
    return json::parse(in);
}

std::string read_text(const fs::path& file) {
    std::ifstream in(file);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// ---------------------------------------------------------------------------------------------
// Child processes

TEST(ChildProcess, CapturesBothStreamsAndTheExitStatus) {
    const mrt::ProcessResult r = mrt::run_process(
        "/bin/sh", {"-c", "printf out; printf 'first line\\nlast line\\n\\n' >&2; exit 3"});
    EXPECT_EQ(r.exit_code, 3);
    EXPECT_EQ(r.signal, 0);
    EXPECT_FALSE(r.succeeded());
    EXPECT_EQ(r.out, "out");
    EXPECT_EQ(mrt::last_line(r.err), "last line");
    EXPECT_EQ(mrt::describe_exit(r), "exit status 3");
    EXPECT_GE(r.wall_seconds, 0.0);
}

TEST(ChildProcess, ArgumentsReachTheChildUnchangedWithoutAShell) {
    const fs::path dir = temp_dir();
    const fs::path script = dir / "print args.sh";
    { std::ofstream(script) << "#!/bin/sh\nfor a in \"$@\"; do printf '[%s]\\n' \"$a\"; done\n"; }
    fs::permissions(script, fs::perms::owner_all);
    const mrt::ProcessResult r = mrt::run_process(script, {"a b", "$HOME", "'q'", "*", "x;y", ""});
    ASSERT_TRUE(r.succeeded()) << r;
    EXPECT_EQ(r.out, "[a b]\n[$HOME]\n['q']\n[*]\n[x;y]\n[]\n");
    fs::remove_all(dir);
}

TEST(ChildProcess, LargeOutputOnBothStreamsDoesNotDeadlock) {
    const mrt::ProcessResult r = mrt::run_process(
        "/bin/sh", {"-c",
                    "i=0; while [ $i -lt 3000 ]; do echo 0123456789012345678901234567890123"
                    "456789; echo e0123456789012345678901234567890123456789 >&2; "
                    "i=$((i+1)); done"});
    ASSERT_TRUE(r.succeeded()) << r;
    EXPECT_EQ(count_lines(r.out), 3000);
    EXPECT_EQ(count_lines(r.err), 3000);
}

TEST(ChildProcess, ASignalIsReported) {
    const mrt::ProcessResult r = mrt::run_process("/bin/sh", {"-c", "kill -9 $$"});
    EXPECT_EQ(r.signal, 9);
    EXPECT_TRUE(contains(mrt::describe_exit(r), "signal 9")) << mrt::describe_exit(r);
}

TEST(ChildProcess, AMissingProgramIsAnErrorNamingIt) {
    const std::string message =
        error_message([] { mrt::run_process("/nonexistent dir/mrt-trace", {}); });
    EXPECT_TRUE(contains(message, "/nonexistent dir/mrt-trace: cannot run")) << message;
}

TEST(ChildProcess, LastLineSkipsTrailingBlankLines) {
    EXPECT_EQ(mrt::last_line(""), "");
    EXPECT_EQ(mrt::last_line("\n \n"), "");
    EXPECT_EQ(mrt::last_line("only"), "only");
    EXPECT_EQ(mrt::last_line("a\nb\r\n\n"), "b");
}

// ---------------------------------------------------------------------------------------------
// Reference cache

mrt::ReferenceKey example_key() {
    mrt::ReferenceKey key;
    key.scene = "/scenes/a.json";
    key.scene_hash = "0123456789abcdef";
    key.width = 32;
    key.height = std::nullopt;
    key.filter = "box";
    key.texture_filter = "none";
    key.spp = 16;
    key.seed = 7;
    return key;
}

TEST(ReferenceCache, RecordIsReusedOnlyForAnIdenticalKey) {
    const fs::path dir = temp_dir();
    const fs::path record = dir / "reference.json";
    const mrt::ReferenceKey key = example_key();
    mrt::write_reference_record(record, key, {16, 1.5, std::nullopt});

    const json j = read_json(record);
    EXPECT_EQ(j["key"]["width"], 32);
    EXPECT_TRUE(j["key"]["height"].is_null());
    EXPECT_EQ(j["spp"], 16);
    EXPECT_EQ(j["seconds"], 1.5);
    EXPECT_TRUE(j["std_error"].is_null());

    const auto same = mrt::cached_reference_info(record, key);
    ASSERT_TRUE(same.has_value());
    EXPECT_EQ(same->spp, 16);
    EXPECT_EQ(same->seconds, 1.5);
    EXPECT_FALSE(same->std_error.has_value());

    auto changed = [&](auto change) {
        mrt::ReferenceKey other = key;
        change(other);
        return mrt::cached_reference_info(record, other).has_value();
    };
    EXPECT_FALSE(changed([](mrt::ReferenceKey& k) { k.filter = "gaussian:0.5"; }));
    EXPECT_FALSE(changed([](mrt::ReferenceKey& k) { k.scene_hash = "fedcba9876543210"; }));
    EXPECT_FALSE(changed([](mrt::ReferenceKey& k) { k.height = 24; }));
    EXPECT_FALSE(changed([](mrt::ReferenceKey& k) { k.spp = 17; }));
    EXPECT_FALSE(changed([](mrt::ReferenceKey& k) { k.seed = 8; }));
    EXPECT_FALSE(changed([](mrt::ReferenceKey& k) { k.texture_filter = "anisotropic"; }));
    EXPECT_FALSE(changed([](mrt::ReferenceKey& k) { k.scene = "/scenes/b.json"; }));

    { std::ofstream(record) << "{\"key\": "; }
    EXPECT_FALSE(mrt::cached_reference_info(record, key).has_value());
    EXPECT_FALSE(mrt::cached_reference_info(dir / "missing.json", key).has_value());
    fs::remove_all(dir);
}

TEST(ReferenceCache, SceneHashFollowsTheBytes) {
    const fs::path dir = temp_dir();
    { std::ofstream(dir / "a.json") << "{}"; }
    { std::ofstream(dir / "b.json") << "{ }"; }
    { std::ofstream(dir / "empty.json"); }
    EXPECT_EQ(mrt::scene_file_hash(dir / "a.json"), mrt::scene_file_hash(dir / "a.json"));
    EXPECT_NE(mrt::scene_file_hash(dir / "a.json"), mrt::scene_file_hash(dir / "b.json"));
    // FNV-1a 64 of no bytes is its offset basis.
    EXPECT_EQ(mrt::scene_file_hash(dir / "empty.json"), "cbf29ce484222325");
    EXPECT_TRUE(
        contains(error_message([&] { mrt::scene_file_hash(dir / "none.json"); }), "none.json"));
    fs::remove_all(dir);
}

TEST(ReferenceCache, FiltersAreCanonical) {
    EXPECT_EQ(mrt::canonical_filter("box"), "box");
    EXPECT_EQ(mrt::canonical_filter("gaussian"), "gaussian:0.5");
    EXPECT_EQ(mrt::canonical_filter("gaussian:1.25"), "gaussian:1.25");
    EXPECT_TRUE(contains(error_message([] { mrt::canonical_filter("tent"); }), "tent"));
}

TEST(ReferenceCache, InfoOfAGivenRecordMayBeUnknown) {
    const fs::path dir = temp_dir();
    { std::ofstream(dir / "r.json") << R"({"spp": 64, "seconds": null})"; }
    const mrt::ReferenceInfo info = mrt::read_reference_info(dir / "r.json");
    EXPECT_EQ(info.spp, 64);
    EXPECT_FALSE(info.seconds.has_value());
    EXPECT_FALSE(info.std_error.has_value());
    { std::ofstream(dir / "bad.json") << R"({"spp": "many"})"; }
    const std::string message = error_message([&] { mrt::read_reference_info(dir / "bad.json"); });
    EXPECT_TRUE(contains(message, "bad.json: /spp: expected a number")) << message;
    fs::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------
// mrt-compare end to end

const char* const kTraceExe = MRT_TRACE_EXE;
const char* const kCompareExe = MRT_COMPARE_EXE;

std::string scene_path() {
    return std::string(MRT_SOURCE_DIR) + "/data/scenes/two-spheres.json";
}

/// A copy of the default scene in `dir`, under a name with a space.
fs::path scene_copy(const fs::path& dir) {
    const fs::path scene = dir / "two spheres.json";
    fs::copy_file(scene_path(), scene, fs::copy_options::overwrite_existing);
    return scene;
}

mrt::ProcessResult run_compare(const Args& args) {
    return mrt::run_process(kCompareExe, args);
}

/// The methods mrt-trace offers.
Args offered_methods() {
    return mrt::method_names();
}

Args small(Args args) {
    args.insert(args.end(), {"--width", "32", "--height", "24", "--threads", "2"});
    return args;
}

/// Checks every file of a finished comparison in `out` and every number of results.json
/// against a recomputation from the written images and stats; returns results.json.
/// The stdout table's rows agree with results.json (to the digits printed): columns are
/// #, spec, render s, total s, rays, RMSE, display RMSE, PSNR, SSIM.
void check_table(const std::string& table, const json& results) {
    std::map<std::string, std::vector<std::string>> rows;
    std::istringstream in(table);
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream fields(line);
        std::vector<std::string> f;
        for (std::string w; fields >> w;) {
            f.push_back(w);
        }
        // A run's row: nine fields, the first its number.
        if (f.size() == 9 && std::all_of(f[0].begin(), f[0].end(), ::isdigit)) {
            rows[f[1]] = f;
        }
    }
    for (const json& run : results["runs"]) {
        const std::string spec = run["spec"];
        ASSERT_TRUE(rows.count(spec) > 0) << spec << " not in\n" << table;
        const std::vector<std::string>& f = rows[spec];
        EXPECT_NEAR(std::stod(f[5]), run["rmse"].get<double>(),
                    5e-7 + 1e-5 * run["rmse"].get<double>())
            << spec;
        EXPECT_NEAR(std::stod(f[6]), run["display_rmse"].get<double>(),
                    5e-7 + 1e-5 * run["display_rmse"].get<double>())
            << spec;
        EXPECT_NEAR(std::stod(f[8]), run["ssim"].get<double>(), 5e-5) << spec;
        EXPECT_EQ(f[4], std::to_string(run["rays"].get<std::uint64_t>())) << spec;
        if (run["psnr"].is_null()) {
            EXPECT_EQ(f[7], "inf") << spec;
        } else {
            EXPECT_NEAR(std::stod(f[7]), run["psnr"].get<double>(), 0.005) << spec;
        }
    }
}

json check_comparison(const fs::path& out, const fs::path& reference_exr,
                      const Args& expected_specs) {
    const json results = read_json(out / "results.json");
    EXPECT_EQ(results["width"], 32);
    EXPECT_EQ(results["height"], 24);
    EXPECT_TRUE(fs::exists(out / "montage.png"));
    EXPECT_TRUE(fs::exists(out / results["reference"]["image"].get<std::string>()));
    const mrt::Image montage = mrt::read_image(out / "montage.png");
    EXPECT_GT(montage.width(), 2 * 32);
    const mrt::Image reference = mrt::read_image(reference_exr);

    std::vector<std::string> csv_rows;
    {
        std::istringstream csv(read_text(out / "results.csv"));
        std::string line;
        std::getline(csv, line);  // header
        while (std::getline(csv, line)) {
            csv_rows.push_back(line);
        }
    }
    const json& runs = results["runs"];
    EXPECT_EQ(runs.size(), expected_specs.size());
    EXPECT_EQ(csv_rows.size(), runs.size());
    for (std::size_t i = 0; i < runs.size() && i < expected_specs.size(); ++i) {
        const json& run = runs[i];
        const std::string spec = expected_specs[i];
        SCOPED_TRACE(spec);
        EXPECT_EQ(run["spec"], spec);
        EXPECT_EQ(run["method"], std::string(mrt::to_string(mrt::parse_method_spec(spec).method)));
        const std::string base =
            (i + 1 < 10 ? "0" : "") + std::to_string(i + 1) + "-" + mrt::spec_slug(spec);
        EXPECT_EQ(run["image"], base + ".png");
        EXPECT_EQ(run["error_image"], base + "-error.png");
        EXPECT_EQ(run["stats"], base + ".json");
        for (const char* suffix : {".exr", ".png", "-error.png", ".json"}) {
            EXPECT_TRUE(fs::exists(out / (base + suffix))) << base + suffix;
        }

        const json stats = read_json(out / (base + ".json"));
        EXPECT_EQ(run["render_seconds"], stats["render_seconds"]);
        EXPECT_DOUBLE_EQ(run["total_seconds"].get<double>(),
                         stats["load_seconds"].get<double>() +
                             stats["build_seconds"].get<double>() +
                             stats["render_seconds"].get<double>());
        EXPECT_GE(run["wall_seconds"].get<double>(), run["total_seconds"].get<double>());
        EXPECT_EQ(run["rays"], stats["rays"]);

        const mrt::Image image = mrt::read_image(out / (base + ".exr"));
        EXPECT_DOUBLE_EQ(run["rmse"].get<double>(), mrt::rmse(image, reference));
        EXPECT_DOUBLE_EQ(run["display_rmse"].get<double>(), mrt::display_rmse(image, reference));
        EXPECT_DOUBLE_EQ(run["ssim"].get<double>(), mrt::ssim(image, reference));
        const double psnr = mrt::psnr(image, reference);
        if (std::isinf(psnr)) {
            EXPECT_TRUE(run["psnr"].is_null());
        } else {
            EXPECT_DOUBLE_EQ(run["psnr"].get<double>(), psnr);
        }
        const mrt::Image error = mrt::read_image(out / (base + "-error.png"));
        EXPECT_EQ(error.width(), 32);
        EXPECT_EQ(error.height(), 24);

        // The CSV row holds the same numbers (round-trip text), psnr "inf" when infinite.
        if (i < csv_rows.size()) {
            const std::string row = csv_rows[i];
            EXPECT_EQ(row.rfind(run["method"].get<std::string>() + ",", 0), 0u) << row;
            // RFC 4180: a spec with a comma is quoted (and holds no quote itself).
            std::vector<std::string> fields;
            std::string field;
            bool quoted = false;
            for (const char c : row + ',') {
                if (c == '"') {
                    quoted = !quoted;
                } else if (c == ',' && !quoted) {
                    fields.push_back(field);
                    field.clear();
                } else {
                    field += c;
                }
            }
            if (fields.size() >= 10 && fields[1] == spec) {
                EXPECT_EQ(std::stod(fields[2]), run["render_seconds"].get<double>());
                EXPECT_EQ(std::stod(fields[3]), run["total_seconds"].get<double>());
                EXPECT_EQ(std::stod(fields[4]), run["wall_seconds"].get<double>());
                EXPECT_EQ(std::stoull(fields[5]), run["rays"].get<std::uint64_t>());
                EXPECT_EQ(std::stod(fields[7]), run["rmse"].get<double>());
                if (run["psnr"].is_null()) {
                    EXPECT_EQ(fields[8], "inf");
                } else {
                    EXPECT_EQ(std::stod(fields[8]), run["psnr"].get<double>());
                }
                EXPECT_EQ(std::stod(fields[9]), run["ssim"].get<double>());
                EXPECT_EQ(fields.size(), 15u) << row;
                if (fields.size() == 15) {
                    EXPECT_EQ(std::stod(fields[14]), run["display_rmse"].get<double>());
                }
            } else {
                ADD_FAILURE() << "unexpected CSV row " << row;
            }
        }
    }
    return results;
}

TEST(MrtCompare, GivenReferenceRunsEverySpecAndRecomputes) {
    const fs::path dir = temp_dir();
    const fs::path scene = scene_copy(dir);
    const fs::path reference = dir / "given ref.exr";
    const mrt::ProcessResult ref = mrt::run_process(
        kTraceExe, small({scene.string(), "-o", reference.string(), "--spp", "4", "-q"}));
    ASSERT_TRUE(ref.succeeded()) << ref;
    { std::ofstream(dir / "given ref.json") << R"({"spp": 4, "seconds": 0.5, "std_error": null})"; }

    const fs::path out = dir / "out dir";
    const mrt::ProcessResult run = run_compare(
        small({scene.string(), "--out", out.string(), "--reference", reference.string(), "--method",
               "whitted", "--method", "whitted:spp=4", "--error-scale", "0.05"}));
    ASSERT_TRUE(run.succeeded()) << run;
    EXPECT_TRUE(run.err.empty()) << "not a terminal: no progress lines: " << run.err;
    const json results = check_comparison(out, reference, {"whitted", "whitted:spp=4"});
    EXPECT_EQ(results["scene"], scene.string());  // as the user named it
    EXPECT_EQ(results["filter"], "box");
    EXPECT_EQ(results["seed"], 0);
    EXPECT_EQ(results["reference"]["spp"], 4);
    EXPECT_EQ(results["reference"]["seconds"], 0.5);
    EXPECT_TRUE(results["reference"]["std_error"].is_null());
    EXPECT_EQ(results["reference"]["image"], "reference.png");
    // The same render as the reference: identical, so PSNR is infinite (null) and SSIM 1.
    EXPECT_TRUE(results["runs"][1]["psnr"].is_null());
    EXPECT_EQ(results["runs"][1]["rmse"], 0.0);
    EXPECT_GT(results["runs"][0]["rmse"].get<double>(), 0.0);
    EXPECT_FALSE(fs::exists(out / "reference.json")) << "a given reference is not cached";

    // The table: a header, one row per run, the reference line, then the derived figures.
    EXPECT_EQ(lines_before_derived_figures(run.out), 4) << run.out;
    EXPECT_TRUE(contains(run.out, "RMSE")) << run.out;
    EXPECT_TRUE(contains(run.out, "whitted:spp=4")) << run.out;
    EXPECT_TRUE(contains(run.out, " inf ")) << run.out;
    EXPECT_TRUE(contains(run.out, "reference: 32×24")) << run.out;
    check_table(run.out, results);

    // Again in the same directory with other specs: the earlier runs' files go, nothing else.
    { std::ofstream(out / "notes.txt") << "mine"; }
    const mrt::ProcessResult again =
        run_compare(small({scene.string(), "--out", out.string(), "--reference", reference.string(),
                           "--method", "whitted:spp=4"}));
    ASSERT_TRUE(again.succeeded()) << again;
    for (const char* stale : {"01-whitted.png", "01-whitted.exr", "01-whitted-error.png",
                              "01-whitted.json", "02-whitted-spp-4.png", "02-whitted-spp-4.exr"}) {
        EXPECT_FALSE(fs::exists(out / stale)) << stale;
    }
    EXPECT_TRUE(fs::exists(out / "01-whitted-spp-4.exr"));
    EXPECT_TRUE(fs::exists(out / "notes.txt"));
    fs::remove_all(dir);
}

TEST(MrtCompare, DefaultSetWithRenderedReferenceThenCacheReuseAndInvalidation) {
    const fs::path dir = temp_dir();
    const fs::path scene = scene_copy(dir);
    const fs::path out = dir / "out";

    // No --method: the default set, every method mrt-trace offers, budgets from whitted.
    const mrt::ProcessResult first =
        run_compare(small({scene.string(), "--out", out.string(), "--reference-spp", "16"}));
    ASSERT_TRUE(first.succeeded()) << first;
    EXPECT_TRUE(first.err.empty()) << "not a terminal, nothing reused: " << first.err;
    const json results = read_json(out / "results.json");
    Args specs;
    for (const json& r : results["runs"]) {
        specs.push_back(r["spec"]);
    }
    ASSERT_GE(specs.size(), 8u);
    const Args fixed = {"whitted", "whitted:spp=4", "distributed:spp-max=4",
                        "distributed:spp-max=16", "distributed:spp-max=64"};
    EXPECT_EQ(Args(specs.begin(), specs.begin() + 5), fixed);
    const double whitted_seconds = results["runs"][0]["render_seconds"];
    for (const int i : {0, 1, 2}) {
        EXPECT_EQ(specs[static_cast<std::size_t>(5 + i)],
                  "distributed:time-budget=" +
                      mrt::format_budget_seconds(
                          std::pow(4.0, i + 1) *
                          std::max(whitted_seconds, mrt::kMinimumBudgetBaseSeconds)));
    }
    const Args offered = offered_methods();
    const auto is_offered = [&](const std::string& method) {
        return std::find(offered.begin(), offered.end(), method) != offered.end();
    };
    const auto count_of = [&](const std::string& method, const std::string& options) {
        // A spec of the method with these options, with or without a time budget after them.
        const std::string bare = options.empty() ? method : method + ":" + options;
        const std::string budget = bare + (options.empty() ? ":" : ",") + "time-budget=";
        return std::count_if(specs.begin(), specs.end(), [&](const std::string& s) {
            return s == bare ||
                   (s.rfind(budget, 0) == 0 && s.find(',', budget.size()) == std::string::npos);
        });
    };
    // cone-classic runs with a time budget of 64× whitted's, its primary rays with 16× cone's
    // primary rays': their specs carry it.
    for (const std::string options : {"", "max-depth=0"}) {
        EXPECT_EQ(count_of("cone", options), is_offered("cone") ? 1 : 0) << options;
        EXPECT_EQ(count_of("cone-classic", options), is_offered("cone-classic") ? 1 : 0) << options;
    }
    // Every run of this small scene finishes; none is reported stopped.
    for (const json& r : results["runs"]) {
        EXPECT_FALSE(r["stopped"].get<bool>()) << r;
    }
    check_comparison(out, out / "reference.exr", specs);
    check_table(first.out, results);
    const json& headline = results["headline"];
    EXPECT_EQ(lines_before_derived_figures(first.out),
              static_cast<int>(specs.size() + headline.size()) + 2)
        << first.out;
    if (is_offered("cone")) {
        // Each headline ratio is a quotient of the runs it names (each interpolated or bounded
        // one says so), and the search left a distributed run at cone's RMSE or bounded it.
        const auto run_named = [&](const std::string& spec) {
            const auto it = std::find(specs.begin(), specs.end(), spec);
            EXPECT_NE(it, specs.end()) << spec;
            return results["runs"][static_cast<std::size_t>(it - specs.begin())];
        };
        const json cone = run_named("cone");
        const json whitted = run_named("whitted");
        const json& speed = headline["cone_over_whitted"];
        EXPECT_DOUBLE_EQ(speed["value"].get<double>(), cone["render_seconds"].get<double>() /
                                                           whitted["render_seconds"].get<double>());
        EXPECT_EQ(speed["relation"], "equal");
        const json& reach = headline["distributed_to_cone_error"];
        ASSERT_TRUE(reach.is_object()) << headline;
        EXPECT_EQ(reach["denominator"], "cone");
        if (reach["how"] == "measured") {
            const json distributed = run_named(reach["numerator"]);
            EXPECT_LE(
                std::abs(std::log(distributed["rmse"].get<double>() / cone["rmse"].get<double>())),
                std::log(1.05) + 1e-12);
            EXPECT_DOUBLE_EQ(
                reach["value"].get<double>(),
                distributed["render_seconds"].get<double>() / cone["render_seconds"].get<double>());
        } else if (reach["how"] == "interpolated between two runs") {
            // Four renders did not land within 5 %: the time lies between two distributed
            // time-budget runs, one either side of cone's RMSE.
            EXPECT_EQ(reach["relation"], "equal");
            EXPECT_EQ(reach["numerator"], "");
            const double seconds = reach["numerator_value"].get<double>();
            bool below = false;
            bool above = false;
            for (const json& r : results["runs"]) {
                const std::string spec = r["spec"];
                if (spec.rfind("distributed:time-budget=", 0) != 0) {
                    continue;
                }
                const double t = r["render_seconds"].get<double>();
                const double e = r["rmse"].get<double>();
                below = below || (t <= seconds && e > cone["rmse"].get<double>());
                above = above || (t >= seconds && e <= cone["rmse"].get<double>());
            }
            EXPECT_TRUE(below && above) << reach;
        } else {
            // A bound: no run reaches cone's RMSE, or the fastest is already better.
            EXPECT_NE(reach["relation"], "equal") << reach;
            EXPECT_TRUE(specs.end() != std::find(specs.begin(), specs.end(), reach["numerator"]))
                << reach;
        }
        const auto equal_time =
            std::find(specs.begin(), specs.end(),
                      "distributed:time-budget=" +
                          mrt::format_budget_seconds(std::max(cone["render_seconds"].get<double>(),
                                                              mrt::kMinimumBudgetBaseSeconds)));
        EXPECT_NE(equal_time, specs.end()) << "distributed at cone's time";
        // Unless cone is faster than the smallest budget, a run near its time gives the RMSE.
        if (cone["render_seconds"].get<double>() > 1.1 * mrt::kMinimumBudgetSeconds) {
            EXPECT_TRUE(headline["distributed_rmse_at_cone_time"].is_object()) << headline;
        }
        // No spec runs twice (budgets floored to the same one are measured once).
        Args sorted = specs;
        std::sort(sorted.begin(), sorted.end());
        EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
        if (is_offered("cone-classic")) {
            const json& primary = headline["classic_over_cone_primary"];
            EXPECT_EQ(primary["denominator"], "cone:max-depth=0");
            EXPECT_DOUBLE_EQ(primary["value"].get<double>(),
                             run_named(primary["numerator"])["render_seconds"].get<double>() /
                                 run_named("cone:max-depth=0")["render_seconds"].get<double>());
        }
    }

    // The reference and its record.
    const json record = read_json(out / "reference.json");
    EXPECT_EQ(record["key"]["scene"], fs::canonical(scene).string());
    EXPECT_EQ(record["key"]["scene_hash"], mrt::scene_file_hash(scene));
    EXPECT_EQ(record["key"]["width"], 32);
    EXPECT_EQ(record["key"]["height"], 24);
    EXPECT_EQ(record["key"]["filter"], "box");
    EXPECT_EQ(record["key"]["spp"], 16);
    EXPECT_EQ(record["key"]["seed"], 0);
    EXPECT_TRUE(record["seconds"].is_number()) << record;
    EXPECT_TRUE(record["std_error"].is_number()) << record;
    EXPECT_EQ(results["reference"]["spp"], record["spp"]);
    EXPECT_EQ(results["reference"]["seconds"], record["seconds"]);
    EXPECT_EQ(results["reference"]["std_error"], record["std_error"]);
    EXPECT_EQ(results["reference"]["origin"], "rendered");
    EXPECT_EQ(results["reference"]["image"], "reference.png");
    const json reference_stats = read_json(out / "reference-stats.json");
    EXPECT_EQ(reference_stats["method"], "distributed");
    EXPECT_EQ(reference_stats["spp"], 16);
    const auto rendered_at = fs::last_write_time(out / "reference.exr");

    // Same key (the methods are not part of it): reused, said on stderr, the EXR untouched.
    const Args whitted_only = small(
        {scene.string(), "--out", out.string(), "--reference-spp", "16", "--method", "whitted"});
    const mrt::ProcessResult second = run_compare(whitted_only);
    ASSERT_TRUE(second.succeeded()) << second;
    EXPECT_TRUE(contains(second.err, "reusing the cached reference")) << second.err;
    EXPECT_EQ(count_lines(second.err), 1) << second.err;
    EXPECT_EQ(fs::last_write_time(out / "reference.exr"), rendered_at);
    const json reused = check_comparison(out, out / "reference.exr", {"whitted"});
    EXPECT_EQ(reused["reference"]["origin"], "cached");
    EXPECT_EQ(reused["reference"]["std_error"], record["std_error"]);
    EXPECT_EQ(reused["runs"][0]["rmse"], results["runs"][0]["rmse"]);

    // -q keeps the reuse quiet.
    Args quiet = whitted_only;
    quiet.push_back("-q");
    const mrt::ProcessResult third = run_compare(quiet);
    ASSERT_TRUE(third.succeeded()) << third;
    EXPECT_TRUE(third.err.empty()) << third.err;

    // Another filter: another key, so the reference is rendered again.
    Args gaussian = whitted_only;
    gaussian.insert(gaussian.end(), {"--filter", "gaussian"});
    const mrt::ProcessResult fourth = run_compare(gaussian);
    ASSERT_TRUE(fourth.succeeded()) << fourth;
    EXPECT_FALSE(contains(fourth.err, "reusing")) << fourth.err;
    EXPECT_NE(fs::last_write_time(out / "reference.exr"), rendered_at);
    EXPECT_EQ(read_json(out / "reference.json")["key"]["filter"], "gaussian:0.5");
    const json refiltered = check_comparison(out, out / "reference.exr", {"whitted"});
    EXPECT_EQ(refiltered["filter"], "gaussian:0.5");
    EXPECT_EQ(refiltered["reference"]["origin"], "rendered");
    EXPECT_EQ(read_json(out / "01-whitted.json")["filter"], "gaussian:0.5");
    fs::remove_all(dir);
}

/// The mrt::Error message of an in-process comparison (checks made before anything renders).
std::string comparison_error(const fs::path& dir,
                             const std::function<void(mrt::ComparisonOptions&)>& change) {
    mrt::ComparisonOptions options;
    options.scene = scene_path();
    options.out_dir = dir / "out";
    options.method_specs = {"whitted"};
    options.width = 32;
    options.height = 24;
    options.reference_image = dir / "ref.exr";
    options.trace_exe = kTraceExe;
    change(options);
    std::ostringstream log;
    return error_message([&] { mrt::run_comparison(options, log); });
}

TEST(Comparison, BadInputsAreRefusedBeforeAnythingRenders) {
    const fs::path dir = temp_dir();
    mrt::write_image(dir / "ref.exr", mrt::Image(32, 24));
    { std::ofstream(dir / "a file") << "x"; }
    const std::vector<std::pair<std::function<void(mrt::ComparisonOptions&)>, std::string>> cases =
        {
            {[&](auto& o) { o.scene = dir / "missing.json"; }, "missing.json: no such scene file"},
            {[&](auto& o) { o.scene = dir; }, ": the scene is not a regular file"},
            {[](auto& o) {
                 o.method_specs = {"whitted", "distributed:"};
             },
             "method spec \"distributed:\": nothing follows ':'"},
            {[](auto& o) { o.method_specs = {"whitted:width=8"}; },
             "\"width\" is set by mrt-compare"},
            {[&](auto& o) { o.out_dir = dir / "a file" / "sub"; },
             "sub: cannot create the output directory"},
            {[](auto& o) { o.width = 40; },
             "ref.exr: the reference is 32×24, but this comparison is 40×24"},
            {[](auto& o) {
                 o.width.reset();
                 o.height = 12;
             },
             "ref.exr: the reference is 32×24, but this comparison is height 12"},
            {[&](auto& o) { o.reference_image = dir / "none.exr"; }, "none.exr: cannot read image"},
            {[](auto& o) { o.filter = "tent"; }, "pixel filter: found \"tent\""},
            {[](auto& o) { o.error_scale = -1.0; }, "--error-scale must be a positive number"},
        };
    for (const auto& [change, part] : cases) {
        const std::string message = comparison_error(dir, change);
        EXPECT_TRUE(contains(message, part)) << "expected \"" << part << "\" in: " << message;
    }
    EXPECT_FALSE(fs::exists(dir / "out" / "results.json"));
    fs::remove_all(dir);
}

/// A failed mrt-compare: exit status 1 and exactly one line on stderr, containing `part`.
void expect_one_line_failure(const Args& args, const std::string& part) {
    const mrt::ProcessResult r = run_compare(args);
    EXPECT_EQ(r.exit_code, 1) << r;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_TRUE(contains(r.err, part)) << "expected \"" << part << "\" in: " << r.err;
    EXPECT_EQ(r.err.rfind("mrt-compare: ", 0), 0u) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(MrtCompare, BadInputsFailWithOneLine) {
    const fs::path dir = temp_dir();
    const fs::path reference = dir / "ref.exr";
    mrt::write_image(reference, mrt::Image(32, 24));
    auto args = [&](Args a) {
        a = small(std::move(a));
        a.insert(a.end(), {"--reference", reference.string()});
        return a;
    };
    expect_one_line_failure(args({(dir / "missing.json").string(), "--out", (dir / "o1").string(),
                                  "--method", "whitted"}),
                            "missing.json: no such scene file");
    expect_one_line_failure(
        args({scene_path(), "--out", (dir / "o2").string(), "--method", "a:b="}),
        "method spec \"a:b=\": option \"b\" has an empty value");
    { std::ofstream(dir / "a file") << "x"; }
    expect_one_line_failure(
        args({scene_path(), "--out", (dir / "a file" / "sub").string(), "--method", "whitted"}),
        "cannot create the output directory");
    expect_one_line_failure(
        Args{scene_path(), "--out", (dir / "o3").string(), "--method", "whitted", "--reference",
             reference.string(), "--width", "40", "--height", "24"},
        "ref.exr: the reference is 32×24, but this comparison is 40×24");
    // An option mrt-trace does not know: mrt-trace's own message is quoted, with the spec.
    expect_one_line_failure(
        args({scene_path(), "--out", (dir / "o4").string(), "--method", "whitted:bogus=1"}),
        "whitted:bogus=1: mrt-trace failed (exit status 2): \"mrt-trace: ");

    // Command-line errors exit with 2.
    EXPECT_EQ(run_compare({scene_path()}).exit_code, 2);
    EXPECT_EQ(run_compare({scene_path(), "--out", "x", "--error-scale", "0"}).exit_code, 2);
    const mrt::ProcessResult help = run_compare({"--help"});
    EXPECT_EQ(help.exit_code, 0);
    EXPECT_TRUE(contains(help.out, "--reference-spp")) << help.out;
    fs::remove_all(dir);
}

TEST(MrtCompare, AFailingTracerIsNamedWithItsLastLine) {
    const fs::path dir = temp_dir();
    const fs::path fake = dir / "fake trace";
    {
        std::ofstream(fake) << "#!/bin/sh\necho 'working...' >&2\n"
                               "echo 'mrt-trace: scene.json: something broke' >&2\nexit 1\n";
    }
    fs::permissions(fake, fs::perms::owner_all);
    const fs::path reference = dir / "ref.exr";
    mrt::write_image(reference, mrt::Image(32, 24));
    ::setenv("MRT_TRACE", fake.c_str(), 1);
    expect_one_line_failure(small({scene_path(), "--out", (dir / "out").string(), "--method",
                                   "whitted:spp=2", "--reference", reference.string()}),
                            "whitted:spp=2: mrt-trace failed (exit status 1): \"mrt-trace: "
                            "scene.json: something broke\"");
    ::setenv("MRT_TRACE", (dir / "absent").c_str(), 1);
    expect_one_line_failure(small({scene_path(), "--out", (dir / "out").string(), "--method",
                                   "whitted", "--reference", reference.string()}),
                            "absent: mrt-trace is not an executable file");
    ::unsetenv("MRT_TRACE");
    fs::remove_all(dir);
}

}  // namespace
