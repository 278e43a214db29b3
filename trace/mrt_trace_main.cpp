// mrt-trace: renders a scene with one of the project's tracers.

#include "common/error.h"
#include "common/image.h"
#include "common/scene_loader.h"
#include "trace/render_stats.h"
#include "trace/scene_bvh.h"
#include "trace/whitted.h"

#include <unistd.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

struct Arguments {
    std::filesystem::path scene;
    std::filesystem::path output;
    std::string method = "whitted";
    int spp = 1;
    std::optional<int> width;
    std::optional<int> height;
    int threads = 0;
    std::optional<int> max_depth;
    std::uint64_t seed = 0;
    std::filesystem::path stats;
    bool quiet = false;
};

/// Image size: the camera's, or the requested one; one given side keeps the camera's aspect.
std::pair<int, int> image_size(const mrt::Camera& camera, const Arguments& args) {
    const double aspect = static_cast<double>(camera.width) / static_cast<double>(camera.height);
    int w = camera.width;
    int h = camera.height;
    if (args.width && args.height) {
        w = *args.width;
        h = *args.height;
    } else if (args.width) {
        w = *args.width;
        h = std::max(1, static_cast<int>(std::lround(w / aspect)));
    } else if (args.height) {
        h = *args.height;
        w = std::max(1, static_cast<int>(std::lround(h * aspect)));
    }
    return {w, h};
}

int run(const Arguments& args) {
    mrt::check_image_output(args.output);
    const auto load_start = Clock::now();
    if (args.scene.extension() != ".json") {
        throw mrt::Error(args.scene, "",
                         "unsupported scene file type \"" + args.scene.extension().string() +
                             "\" (expected a .json scene file)");
    }
    mrt::SceneLoadOptions load_options;
    load_options.warn = [&](const std::string& message) {
        if (!args.quiet) {
            std::cerr << "mrt-trace: warning: " << message << '\n';
        }
    };
    const mrt::Scene scene = mrt::load_scene(args.scene, load_options);
    const double load_seconds = seconds_since(load_start);

    const auto build_start = Clock::now();
    const mrt::SceneBvh bvh(scene);
    const double build_seconds = seconds_since(build_start);

    mrt::RenderOptions options;
    std::tie(options.width, options.height) = image_size(scene.camera, args);
    options.spp = args.spp;
    options.seed = args.seed;
    options.threads = args.threads;
    options.max_depth = args.max_depth.value_or(-1);
    options.quiet = args.quiet;

    const auto render_start = Clock::now();
    mrt::RenderOutput out = mrt::render_whitted(scene, bvh, options);
    out.render_seconds = seconds_since(render_start);

    mrt::write_image(args.output, out.image);

    if (!args.stats.empty()) {
        mrt::RenderStats stats;
        stats.method = args.method;
        stats.scene = args.scene.string();
        stats.width = options.width;
        stats.height = options.height;
        stats.spp = options.spp;
        stats.threads = options.threads > 0 ? options.threads
                                            : static_cast<int>(std::thread::hardware_concurrency());
        stats.load_seconds = load_seconds;
        stats.build_seconds = build_seconds;
        stats.render_seconds = out.render_seconds;
        stats.rays = out.rays;
        stats.unique_triangles = scene.unique_triangle_count();
        stats.instanced_triangles = scene.instanced_triangle_count();
        mrt::write_render_stats(args.stats, stats);
    }
    if (!args.quiet && isatty(STDERR_FILENO)) {
        std::cerr << "mrt-trace: " << args.output.string() << ": " << options.width << "×"
                  << options.height << ", " << out.render_seconds << " s, " << out.rays.total()
                  << " rays\n";
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"mrt-trace: render a scene with the conventional (whitted) ray tracer",
                 "mrt-trace"};
    Arguments args;
    app.add_option("scene", args.scene, "Scene file (.json)")->required();
    app.add_option("-o,--output", args.output, "Output image (.exr linear, .png/.jpg sRGB)")
        ->required();
    app.add_option("--method", args.method, "Tracer")
        ->check(CLI::IsMember({"whitted"}))
        ->default_val("whitted");
    app.add_option("--spp", args.spp, "Samples per pixel (fixed jittered grid)")
        ->check(CLI::Range(1, 65536))
        ->default_val(1);
    app.add_option("--width", args.width, "Image width (default: the scene camera's)")
        ->check(CLI::Range(1, 65536));
    app.add_option("--height", args.height, "Image height (default: the scene camera's)")
        ->check(CLI::Range(1, 65536));
    app.add_option("--threads", args.threads, "Worker threads (0 = all cores)")
        ->check(CLI::Range(0, 1024))
        ->default_val(0);
    app.add_option("--max-depth", args.max_depth, "Reflection/refraction depth (default: scene's)")
        ->check(CLI::Range(0, 1000));
    app.add_option("--seed", args.seed, "Seed of the sample patterns")->default_val(0);
    app.add_option("--stats", args.stats, "Write run statistics as JSON to this file");
    app.add_flag("-q,--quiet", args.quiet, "No progress bar or summary");

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "mrt-trace: " << e.what() << " (see --help)\n";
        return 2;
    }
    try {
        return run(args);
    } catch (const mrt::Error& e) {
        std::cerr << "mrt-trace: " << e.what() << '\n';
    } catch (const std::bad_alloc&) {
        std::cerr << "mrt-trace: out of memory\n";
    } catch (const std::exception& e) {
        std::cerr << "mrt-trace: internal error: " << e.what() << '\n';
    }
    return 1;
}
