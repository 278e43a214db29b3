// mrt-trace: renders a scene with one of the project's tracers.

#include "common/cli/tool_main.h"
#include "common/hierarchy/hierarchy_file.h"
#include "common/image/image.h"
#include "common/scene_io/mesh_view.h"
#include "common/scene_io/scene_loader.h"
#include "common/system/atomic_file.h"
#include "common/system/error.h"
#include "common/system/memory_usage.h"
#include "common/system/progress.h"
#include "common/system/stopwatch.h"
#include "preprocess/hierarchy_pack.h"
#include "preprocess/scene_hierarchy.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/cone/cone_tracer.h"
#include "trace/raytrace/distributed.h"
#include "trace/raytrace/whitted.h"
#include "trace/render/method.h"
#include "trace/render/pixel_filter.h"
#include "trace/tools/render_stats.h"

#include <fmt/format.h>
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <thread>

namespace {

using mrt::Clock;
using mrt::seconds_since;

struct Arguments {
    std::filesystem::path scene;
    std::filesystem::path output;
    bool print_scene = false;
    mrt::Method method = mrt::Method::Whitted;
    std::optional<int> spp;
    int spp_initial = 2;
    std::optional<int> spp_max;
    float target_error = 0.005f;
    double time_budget = 0.0;
    bool reference = false;
    std::string filter = "box";
    std::string texture_filter = "anisotropic";
    std::string differentials = "when-read";
    std::optional<int> width;
    std::optional<int> height;
    std::string crop;
    int threads = 0;
    std::optional<int> max_depth;
    std::uint64_t seed = 0;
    std::filesystem::path stats;
    bool quiet = false;
    // The cone tracers.
    float max_anisotropy = 8.0f;
    float highlight_detail = 0.5f;
    float refine = 0.7f;
    int refine_levels = 2;
    bool mean_highlights = false;
    bool mask_every_cone = false;
    bool no_level_blend = false;
    bool node_frames = false;
    bool keep_back_faces = false;
    std::string triangle_weight = "coverage";
    std::string abuffer = "mask";
    mrt::Budgets budgets;
};

/// The four integers of --crop X0,Y0,X1,Y1; a bad command line otherwise.
std::array<int, 4> parse_crop(const std::string& text) {
    std::array<int, 4> v{};
    std::size_t at = 0;
    for (std::size_t i = 0; i < v.size(); ++i) {
        const std::size_t end = i + 1 < v.size() ? text.find(',', at) : text.size();
        bool ok = end != std::string::npos && at <= text.size();
        const std::string field = ok ? text.substr(at, end - at) : std::string();
        std::size_t used = 0;
        ok = ok && !field.empty();
        try {
            v[i] = ok ? std::stoi(field, &used) : 0;
        } catch (const std::exception&) {
            ok = false;
        }
        if (!ok || used != field.size()) {
            throw CLI::ValidationError(
                "--crop", fmt::format("\"{}\": expected X0,Y0,X1,Y1 (four integers)", text));
        }
        at = end + 1;
    }
    return v;
}

/// --crop's window, which must be a non-empty part of the width × height frame.
mrt::PixelWindow crop_window(const std::array<int, 4>& v, int width, int height) {
    const mrt::PixelWindow window{v[0], v[1], v[2], v[3]};
    if (window.x0 < 0 || window.y0 < 0 || window.x1 > width || window.y1 > height ||
        window.x0 >= window.x1 || window.y0 >= window.y1) {
        throw mrt::Error(fmt::format(
            "--crop {},{},{},{}: expected a non-empty window of the {}×{} frame (0 ≤ X0 < X1 ≤ "
            "{}, 0 ≤ Y0 < Y1 ≤ {}; X1 and Y1 exclusive)",
            v[0], v[1], v[2], v[3], width, height, width, height));
    }
    return window;
}

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

constexpr int kDefaultReferenceSpp = 1024;
/// cone-classic stops itself after this many seconds unless given --time-budget.
constexpr double kClassicDefaultBudget = 600.0;
constexpr int kMaxSpp = 65536;

/// Options that only some methods read must not be silently ignored by the others.
void check_method_options(const CLI::App& app, const Arguments& args) {
    if (!args.crop.empty()) {
        parse_crop(args.crop);
    }
    for (const mrt::MethodOnlyOption& option : mrt::method_only_options()) {
        const std::string name = "--" + std::string(option.key);
        if (!option.methods.contains(args.method) && app.count(name) > 0) {
            throw CLI::ValidationError(name, mrt::refusal(option));
        }
    }
    if (args.method != mrt::Method::Distributed) {
        return;
    }
    if (args.reference && args.time_budget > 0.0) {
        throw CLI::ValidationError("--reference",
                                   "a reference has a sample count, not a time budget");
    }
    if (args.spp && (app.count("--spp-initial") + app.count("--spp-max") +
                     app.count("--target-error") + app.count("--time-budget")) > 0) {
        throw CLI::ValidationError("--spp",
                                   "a fixed sample count excludes the adaptive options "
                                   "(--spp-initial, --spp-max, --target-error, --time-budget)");
    }
    if (args.spp_max && *args.spp_max < args.spp_initial) {
        throw CLI::ValidationError("--spp-max", "must be at least --spp-initial");
    }
}

mrt::WhittedOptions whitted_options(const Arguments& args) {
    mrt::WhittedOptions whitted;
    whitted.spp = args.spp.value_or(1);
    return whitted;
}

mrt::DistributedOptions distributed_options(const Arguments& args) {
    using enum mrt::DistributedSampling;
    mrt::DistributedOptions distributed;
    distributed.sampling = args.reference ? Reference : args.spp ? Fixed : Adaptive;
    distributed.spp = args.spp.value_or(args.reference ? kDefaultReferenceSpp : 1);
    distributed.spp_initial = args.spp_initial;
    // A time budget alone decides when to stop, unless a cap was asked for.
    distributed.spp_max = args.spp_max.value_or(args.time_budget > 0.0 ? kMaxSpp : 16);
    distributed.target_error = args.target_error;
    distributed.time_budget = args.time_budget;
    return distributed;
}

mrt::ConeOptions cone_options(const Arguments& args) {
    mrt::ConeOptions cone;
    cone.traversal.points = args.method == mrt::Method::Cone;
    cone.traversal.blend_levels = !args.no_level_blend;
    cone.traversal.node_frames = args.node_frames;
    cone.traversal.cull_closed_back_faces = !args.keep_back_faces;
    // CLI11 checked the name against the same table.
    cone.traversal.triangle_weight = *mrt::kTriangleWeightNames.find(args.triangle_weight);
    cone.traversal.compositing = *mrt::kCompositingNames.find(args.abuffer);
    cone.traversal.mask_every_cone = args.mask_every_cone;
    cone.traversal.max_anisotropy = args.max_anisotropy;
    cone.traversal.highlight_level_scale = args.highlight_detail;
    cone.traversal.highlight_mixture = !args.mean_highlights;
    cone.refine_contrast = args.refine;
    cone.refine_levels = args.refine_levels;
    cone.time_budget =
        args.time_budget > 0.0
            ? args.time_budget
            : (args.method == mrt::Method::ConeClassic ? kClassicDefaultBudget : 0.0);
    return cone;
}

int run(const Arguments& args) {
    if (args.print_scene) {
        std::cout << mrt::printable_scene(args.scene) << '\n';
        return 0;
    }
    if (args.output.empty()) {
        throw mrt::Error("--output is required (an image to write), unless --print-scene");
    }
    mrt::check_image_output(args.output);
    if (!args.stats.empty()) {
        mrt::check_output_file(args.stats, "stats file");
    }
    mrt::set_activity("loading " + args.scene.string());
    const auto load_start = Clock::now();
    if (args.scene.extension() != ".json" && args.scene.extension() != ".mrh" &&
        !mrt::is_mesh_file(args.scene)) {
        throw mrt::Error(args.scene, "",
                         "unsupported scene file type \"" + args.scene.extension().string() +
                             "\" (expected a .json scene file, a .mrh hierarchy file or a mesh "
                             "file: .obj, .ply, .off, .stl)");
    }
    mrt::SceneLoadOptions load_options;
    load_options.warn = [&](const std::string& message) {
        if (!args.quiet) {
            std::cerr << "mrt-trace: warning: " << message << '\n';
        }
    };
    load_options.budgets = args.budgets;
    const mrt::Scene scene = mrt::load_scene(args.scene, load_options);
    const double load_seconds = seconds_since(load_start);

    mrt::RenderOptions options;
    std::tie(options.width, options.height) = image_size(scene.camera, args);
    mrt::check_budget(args.budgets, "pixels",
                      mrt::saturating_mul(static_cast<std::uint64_t>(options.width),
                                          static_cast<std::uint64_t>(options.height)),
                      "pixels (--width x --height)", args.scene, "");
    if (!args.crop.empty()) {
        options.crop = crop_window(parse_crop(args.crop), options.width, options.height);
    }
    options.filter = mrt::parse_pixel_filter(args.filter);
    options.texture_filter = mrt::parse_texture_filter(args.texture_filter);
    options.differentials = mrt::parse_differentials(args.differentials);
    options.seed = args.seed;
    options.threads = args.threads;
    options.max_depth = args.max_depth.value_or(-1);
    options.quiet = args.quiet;

    // Building covers everything prepared before the first ray: the BVH and the mip-mapped
    // textures, so render times compare tracing alone.
    // The cone tracers read the hierarchy file instead of a BVH.
    mrt::set_activity(fmt::format("preparing {} for the {} method", args.scene.string(),
                                  mrt::to_string(args.method)));
    const auto build_start = Clock::now();
    std::optional<mrt::SceneBvh> bvh;
    std::optional<mrt::HierarchyFile> file;
    std::optional<mrt::HierarchyData> built;
    std::optional<mrt::ConeGeometry> geometry;
    const mrt::TextureSampler textures(scene, options.texture_filter, args.budgets);
    if (mrt::is_cone(args.method)) {
        if (args.scene.extension() == ".mrh") {
            file.emplace(mrt::HierarchyFile::open(args.scene));
            geometry.emplace(file->view(), scene, textures);
        } else {
            // A scene file: its hierarchy is built here with mrt-preprocess's defaults, and
            // counted as build time (mrt-preprocess writes it once for many renders).
            const std::unique_ptr<mrt::TextureSampler> prefilter =
                scene.textures.empty() ? nullptr
                                       : std::make_unique<mrt::TextureSampler>(
                                             scene, mrt::TextureFilter::None, args.budgets);
            mrt::Progress progress("hierarchy", mrt::hierarchy_progress_total(scene), args.quiet);
            mrt::PointOctreeOptions octree;
            octree.budgets = args.budgets;
            const mrt::SceneHierarchy hierarchy = mrt::build_scene_hierarchy(
                scene, prefilter.get(), octree, mrt::Instancing::Keep, &progress);
            progress.finish();
            built.emplace(mrt::pack_hierarchy(hierarchy, scene.materials, "{}", "{}"));
            geometry.emplace(built->view(), scene, textures);
        }
    } else {
        bvh.emplace(scene);
    }
    const double build_seconds = seconds_since(build_start);

    mrt::set_activity(fmt::format("rendering {} ({}×{}, {})", args.scene.string(), options.width,
                                  options.height, mrt::to_string(args.method)));
    std::optional<mrt::ConeRenderStats> cone_stats;
    const auto render_start = Clock::now();
    mrt::RenderOutput out;
    // The budget the render was given, for the stats: the distributed tracer's or the cone's.
    double time_budget = 0.0;
    switch (args.method) {
        case mrt::Method::Whitted:
            out = mrt::render_whitted(scene, *bvh, textures, options, whitted_options(args));
            break;
        case mrt::Method::Distributed: {
            const mrt::DistributedOptions distributed = distributed_options(args);
            time_budget = distributed.time_budget;
            out = mrt::render_distributed(scene, *bvh, textures, options, distributed);
            break;
        }
        case mrt::Method::Cone:
        case mrt::Method::ConeClassic: {
            const mrt::ConeOptions cone = cone_options(args);
            time_budget = cone.time_budget;
            mrt::ConeRenderOutput result = mrt::render_cone(*geometry, options, cone);
            out = std::move(result.render);
            cone_stats = result.stats;
            break;
        }
    }
    out.render_seconds = seconds_since(render_start);
    if (cone_stats && cone_stats->stopped && !args.quiet) {
        std::cerr << "mrt-trace: " << args.method << " stopped after its time budget of "
                  << time_budget << " s with " << cone_stats->pixels_done << " of "
                  << cone_stats->pixels << " pixels done; the rest of the image is black\n";
    }

    mrt::set_activity("writing " + args.output.string());
    mrt::write_image(args.output, out.image);

    if (!args.stats.empty()) {
        mrt::RenderStats stats;
        stats.method = args.method;
        stats.scene = args.scene.string();
        stats.width = options.width;
        stats.height = options.height;
        stats.crop = options.crop;
        stats.spp = out.spp;
        stats.filter = mrt::to_string(options.filter);
        stats.texture_filter = mrt::to_string(options.texture_filter);
        stats.differentials = mrt::to_string(options.differentials);
        stats.passes = out.passes;
        stats.last_pass_seconds = out.last_pass_seconds;
        if (time_budget > 0.0) {
            stats.time_budget = time_budget;
        }
        stats.samples = out.samples;
        stats.std_error = out.std_error;
        stats.threads = options.threads > 0 ? options.threads
                                            : static_cast<int>(std::thread::hardware_concurrency());
        stats.load_seconds = load_seconds;
        stats.build_seconds = build_seconds;
        stats.render_seconds = out.render_seconds;
        stats.rays = out.rays;
        stats.unique_triangles = scene.unique_triangle_count();
        stats.instanced_triangles = scene.instanced_triangle_count();
        stats.cone = cone_stats;
        stats.stopped = cone_stats && cone_stats->stopped;
        stats.peak_rss_bytes = mrt::peak_rss_bytes();
        mrt::write_render_stats(args.stats, stats);
    }
    if (!args.quiet && isatty(STDERR_FILENO)) {
        std::cerr << "mrt-trace: " << args.output.string() << ": " << options.width << "×"
                  << options.height << ", " << out.render_seconds << " s, " << out.rays.total()
                  << " rays";
        if (out.std_error) {
            std::cerr << ", standard error " << *out.std_error;
        }
        std::cerr << '\n';
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{
        "mrt-trace: render a scene with the conventional (whitted), the adaptive "
        "distributed ray tracer or the multi-resolution cone tracer",
        "mrt-trace"};
    Arguments args;
    app.add_option("scene", args.scene,
                   "Scene file (.json), hierarchy file (.mrh), or a mesh file (.obj, .ply, .off, "
                   ".stl) to look at in a scene that frames it")
        ->required();
    app.add_option("-o,--output", args.output,
                   "Output image (.exr linear, .png/.jpg sRGB); required unless --print-scene");
    app.add_flag("--print-scene", args.print_scene,
                 "Print the scene JSON the input stands for (a mesh file's framing scene, to "
                 "save and edit) and exit");
    app.add_option_function<std::string>(
           "--method", [&](const std::string& name) { args.method = mrt::parse_method(name); },
           "Tracer: whitted (conventional), distributed (adaptive stochastic), cone "
           "(multi-resolution cone tracing of a .mrh file) or cone-classic (the same "
           "against every triangle, no points)")
        ->check(CLI::IsMember(mrt::method_names()))
        ->default_str(std::string(mrt::to_string(args.method)));
    app.add_option("--spp", args.spp,
                   "Samples per pixel: whitted's fixed jittered grid (default 1, the pixel "
                   "centre); distributed: one stratified batch, no adaptation; with --reference "
                   "the reference's count (default 1024)")
        ->check(CLI::Range(1, kMaxSpp));
    app.add_option("--spp-initial", args.spp_initial,
                   "distributed, pass 1: jittered samples in every pixel")
        ->check(CLI::Range(1, kMaxSpp))
        ->default_val(2);
    app.add_option("--spp-max", args.spp_max,
                   "distributed: most samples any pixel gets (default 16; no cap with "
                   "--time-budget)")
        ->check(CLI::Range(1, kMaxSpp));
    app.add_option("--target-error", args.target_error,
                   "distributed, pass 2: per-pixel standard error of luminance aimed at")
        ->check(CLI::PositiveNumber)
        ->default_val(0.005f);
    app.add_option("--time-budget", args.time_budget,
                   "distributed: refine where the variance is highest until SECONDS of "
                   "rendering are spent; cone methods: stop cleanly after SECONDS with the "
                   "pixels done (cone-classic: 600 unless given)")
        ->check(CLI::PositiveNumber);
    app.add_flag("--reference", args.reference,
                 "distributed: ground truth from --spp samples in independent stratified "
                 "batches; the stats report its standard error");
    app.add_option("--filter", args.filter,
                   "Pixel reconstruction filter: box or gaussian[:SIGMA] (SIGMA in pixels, "
                   "default 0.5)")
        ->check([](const std::string& text) -> std::string {
            try {
                mrt::parse_pixel_filter(text);
            } catch (const mrt::Error& e) {
                return e.what();
            }
            return {};
        })
        ->default_val("box");
    app.add_option("--texture-filter", args.texture_filter,
                   "Texture filtering (Igehy 1999): none (bilinear, full resolution), distance "
                   "(mip level from the distance travelled), trilinear (isotropic, from the ray "
                   "differentials) or anisotropic (from the differentials' parallelogram)")
        ->check(CLI::IsMember(mrt::kTextureFilterNames.names()))
        ->default_val("anisotropic");
    app.add_option("--differentials", args.differentials,
                   "Which rays carry ray differentials: when-read (where a texture filter reads "
                   "them) or always (every ray at every hit; with --texture-filter none this "
                   "measures what carrying them costs)")
        ->check(CLI::IsMember(mrt::kDifferentialsNames.names()))
        ->default_val("when-read");
    app.add_option("--width", args.width, "Image width (default: the scene camera's)")
        ->check(CLI::Range(1, 65536));
    app.add_option("--height", args.height, "Image height (default: the scene camera's)")
        ->check(CLI::Range(1, 65536));
    app.add_option("--crop", args.crop,
                   "X0,Y0,X1,Y1: render only this window of the frame (X1, Y1 exclusive), every "
                   "pixel as in the full render; the image is the window's (for splitting a frame "
                   "across machines: docs/scaling.md)");
    app.add_option("--threads", args.threads, "Worker threads (0 = all cores)")
        ->check(CLI::Range(0, 1024))
        ->default_val(0);
    app.add_option("--max-depth", args.max_depth, "Reflection/refraction depth (default: scene's)")
        ->check(CLI::Range(0, 1000));
    app.add_option("--seed", args.seed, "Seed of the sample patterns")->default_val(0);
    app.add_option("--stats", args.stats, "Write run statistics as JSON to this file");
    app.add_flag("-q,--quiet", args.quiet, "No progress bar or summary");
    app.add_option("--max-anisotropy", args.max_anisotropy,
                   "cone methods: the footprint's minor axis is widened to at least 1/A of its "
                   "major axis (Wand & Strasser 5.1)")
        ->check(CLI::Range(1.0f, 1000.0f))
        ->default_val(8.0f);
    app.add_option("--highlight-detail", args.highlight_detail,
                   "cone: primary and blurred cones use the points of nodes whose normals spread "
                   "wider than their highlight where their spacing is at most this fraction of "
                   "the footprint (1: as any other node's)")
        ->check(CLI::Range(0.05f, 1.0f))
        ->default_val(0.5f);
    app.add_option("--refine", args.refine,
                   "cone methods: trace a pixel again as 2x2 cones of half the width where its "
                   "value differs from a neighbour's by more than this in any channel (0: one "
                   "cone per pixel)")
        ->check(CLI::Range(0.0f, 1e30f))
        ->default_val(0.7f);
    app.add_option("--refine-levels", args.refine_levels,
                   "cone methods: --refine splits a pixel's cone at most this many times, 2x2 "
                   "each, the quarters that still differ from a neighbouring one")
        ->check(CLI::Range(1, 4))
        ->default_val(2);
    app.add_flag("--mean-highlights", args.mean_highlights,
                 "cone: each fragment's highlight from its mean normal alone (Toksvig), not the "
                 "mixture of its points' and triangles' own");
    app.add_flag("--no-level-blend", args.no_level_blend,
                 "cone: use the chosen level's points alone, not blended with the next finer "
                 "level");
    app.add_flag("--node-frames", args.node_frames,
                 "cone methods: weigh a node's triangles with its one footprint decomposition "
                 "(5.2, faster, seams between nodes) instead of the footprint at each vertex");
    app.add_flag("--keep-back-faces", args.keep_back_faces,
                 "cone methods: also composite the back faces of closed surfaces seen from "
                 "outside (doubles the coverage of thin solids where a cone covers part of them)");
    app.add_option("--triangle-weight", args.triangle_weight,
                   "cone methods: coverage (the footprint Gaussian's mass over the triangle) or "
                   "paper (exp(-(d-1/2)^2) of the closest point's distance, 4.5)")
        ->check(CLI::IsMember(mrt::kTriangleWeightNames.names()))
        ->default_val("coverage");
    app.add_option("--abuffer", args.abuffer,
                   "cone methods: mask (sub-pixel coverage masks: each of 64 rays of the cone "
                   "is taken by the nearest fragment that covers it) or alpha (the paper's: "
                   "each fragment's alpha is its weight sum, 4.4)")
        ->check(CLI::IsMember(mrt::kCompositingNames.names()))
        ->default_val("mask");
    app.add_flag("--mask-every-cone", args.mask_every_cone,
                 "cone methods, --abuffer mask: masks also for the secondary cones composited by "
                 "alpha otherwise (inside solids after the first interaction, and those whose "
                 "spread was bounded)");
    mrt::add_budget_option(app, args.budgets);

    return mrt::run_tool(
        app, argc, argv, [&] { check_method_options(app, args); }, [&] { return run(args); });
}
