// mrt-compare: renders a scene with several methods (through mrt-trace) and measures each
// against a reference: image error (RMSE, PSNR, SSIM, error images) against run time.

#include "common/cli/tool_main.h"
#include "common/system/error.h"
#include "trace/compare/comparison.h"
#include "trace/results/comparison_report.h"

#include <unistd.h>
#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>
#include <new>
#include <optional>
#include <string>

namespace {

constexpr const char* kDescription =
    "mrt-compare: render a scene with several methods through mrt-trace and report each one's "
    "error against a reference (RMSE, PSNR, SSIM, error images) with the time it took.\n"
    "Writes into DIR: reference.exr/.png/.json, NN-SPEC.exr/.png/-error.png/.json per run, "
    "results.json, results.csv, montage.png.";

constexpr const char* kMethodHelp =
    "Method spec NAME[:key=value,...], keys being mrt-trace long options without dashes, a key "
    "alone a flag (whitted, whitted:spp=4, distributed:spp-max=16, "
    "distributed:time-budget=2). Repeatable, run in order. Default: whitted, whitted:spp=4, "
    "distributed:spp-max=4/16/64, distributed with a time budget of 4x, 16x and 64x whitted's "
    "render time, cone, cone-classic stopped after 64x whitted's time; for the headline ratios "
    "cone:max-depth=0 and cone-classic:max-depth=0 (stopped after 16x that), distributed at "
    "cone's time, and distributed budgets searched until one reaches cone's RMSE (those "
    "mrt-trace offers)";

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{kDescription, "mrt-compare"};
    mrt::ComparisonOptions options;
    std::optional<std::string> filter;
    std::optional<int> threads;
    bool quiet = false;
    app.add_option("scene", options.scene, "Scene file")->required();
    app.add_option("--out", options.out_dir, "Output directory DIR (created when missing)")
        ->required();
    app.add_option("--method", options.method_specs, kMethodHelp);
    app.add_option("--width", options.width, "Image width (default: the scene camera's)")
        ->check(CLI::Range(1, 65536));
    app.add_option("--height", options.height, "Image height (default: the scene camera's)")
        ->check(CLI::Range(1, 65536));
    app.add_option("--reference-spp", options.reference_spp,
                   "Samples per pixel of the rendered reference")
        ->check(CLI::Range(1, 1 << 20))
        ->default_val(1024);
    app.add_option("--reference", options.reference_image,
                   "Use this linear image as the reference instead of rendering one (its .json "
                   "record beside it, if any, gives spp, seconds and std_error)");
    app.add_option("--filter", filter,
                   "Pixel filter of every run and the reference: box, gaussian[:SIGMA] "
                   "(default: box)");
    app.add_option("--seed", options.seed, "Seed of the sample patterns")->default_val(0);
    app.add_option("--threads", threads, "Worker threads per run (0 = all cores)")
        ->check(CLI::Range(0, 1024));
    app.add_option("--error-scale", options.error_scale,
                   "Mean absolute error shown white in the error images")
        ->check(CLI::PositiveNumber)
        ->default_val(0.1);
    app.add_flag("-q,--quiet", quiet, "No progress lines or messages on stderr");
    // Checked here, so a bad assignment is a command-line error of mrt-compare, and handed to
    // every mrt-trace run as written.
    mrt::Budgets budgets;
    mrt::add_budget_option(app, budgets);

    return mrt::run_tool(app, argc, argv, [&] {
        options.filter = filter;
        options.threads = threads;
        options.quiet = quiet;
        options.budget_assignments = app.get_option("--budget")->results();
        options.progress = ::isatty(STDERR_FILENO) == 1;
        options.trace_exe = mrt::find_trace_executable();
        const mrt::Comparison comparison = mrt::run_comparison(options, std::cerr);
        mrt::print_results_table(std::cout, comparison);
        return 0;
    });
}
