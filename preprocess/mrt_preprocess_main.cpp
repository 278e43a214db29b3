// mrt-preprocess: builds the multi-resolution point hierarchy of a scene (Wand & Straßer §3) and
// writes it to one .mrh file.

#include "common/cli/tool_main.h"
#include "common/hierarchy/hierarchy_file.h"
#include "common/hierarchy/hierarchy_summary.h"
#include "common/scene_io/mesh_view.h"
#include "common/scene_io/scene_loader.h"
#include "common/scene_io/scene_record.h"
#include "common/system/atomic_file.h"
#include "common/system/error.h"
#include "common/system/memory_usage.h"
#include "common/system/progress.h"
#include "common/system/stopwatch.h"
#include "common/texture/texture.h"
#include "preprocess/hierarchy_pack.h"
#include "preprocess/octree/point_octree.h"
#include "preprocess/scene_hierarchy.h"

#include <fmt/format.h>
#include <tbb/global_control.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <exception>
#include <filesystem>
#include <iostream>
#include <memory>
#include <new>
#include <string>

namespace {

using mrt::Clock;
using mrt::seconds_since;

struct Arguments {
    std::filesystem::path scene;
    std::filesystem::path output;
    bool print_scene = false;
    mrt::PointOctreeOptions octree;
    std::string sampling;  ///< As given; sets octree.sampling.
    int threads = 0;
    bool flatten = false;
    bool quiet = false;
    mrt::Budgets budgets;
};

int run(Arguments args) {
    if (args.print_scene) {
        std::cout << mrt::printable_scene(args.scene) << '\n';
        return 0;
    }
    if (args.output.empty()) {
        // The scene's name in the working directory: `mrt-preprocess bunny.obj` writes
        // bunny.mrh.
        args.output = args.scene.stem().string() + ".mrh";
    }
    mrt::check_output_file(args.output, "hierarchy file");
    mrt::set_activity("loading " + args.scene.string());
    const auto load_start = Clock::now();
    mrt::SceneLoadOptions load_options;
    load_options.warn = [&](const std::string& message) {
        if (!args.quiet) {
            std::cerr << "mrt-preprocess: warning: " << message << '\n';
        }
    };
    load_options.budgets = args.budgets;
    const mrt::Scene scene = mrt::load_scene(args.scene, load_options);
    const std::string scene_record = mrt::scene_record_json(scene);
    const std::unique_ptr<mrt::TextureSampler> textures =
        scene.textures.empty()
            ? nullptr
            : std::make_unique<mrt::TextureSampler>(scene, mrt::TextureFilter::None, args.budgets);
    const double load_seconds = seconds_since(load_start);

    mrt::set_activity("building the hierarchy of " + args.scene.string());
    const auto build_start = Clock::now();
    const mrt::Instancing instancing =
        args.flatten ? mrt::Instancing::Flatten : mrt::Instancing::Keep;
    mrt::Progress progress("hierarchy", mrt::hierarchy_progress_total(scene, instancing),
                           args.quiet);
    mrt::PointOctreeOptions octree = args.octree;
    octree.budgets = args.budgets;
    const mrt::SceneHierarchy hierarchy =
        mrt::build_scene_hierarchy(scene, textures.get(), octree, instancing, &progress);
    progress.finish();
    const double build_seconds = seconds_since(build_start);

    // Parameters only: timings would make every build's file differ, and the file must be
    // byte-identical for the same scene, options and seed whatever the thread count.
    const nlohmann::json build = {
        {"scene", args.scene.string()},
        {"grid", args.octree.grid},
        {"max_representatives", args.octree.max_representatives},
        {"oversampling", args.octree.oversampling},
        {"sampling", args.sampling},
        {"seed", args.octree.seed},
        {"flatten", args.flatten},
    };
    mrt::set_activity("writing " + args.output.string());
    const auto write_start = Clock::now();
    const mrt::HierarchyData data =
        mrt::pack_hierarchy(hierarchy, scene.materials, scene_record, build.dump());
    mrt::write_hierarchy_file(args.output, data);
    const double write_seconds = seconds_since(write_start);

    if (!args.quiet) {
        std::cerr << fmt::format(
            "mrt-preprocess: {}: {} unique / {} instanced triangles; load {:.2f} s, build {:.2f} "
            "s, quantize+write {:.2f} s; {:.1f} MB written, peak memory {:.1f} MB\n",
            args.output.string(), scene.unique_triangle_count(), scene.instanced_triangle_count(),
            load_seconds, build_seconds, write_seconds,
            static_cast<double>(std::filesystem::file_size(args.output)) / 1e6,
            static_cast<double>(mrt::peak_rss_bytes()) / 1e6);
        // Read back through the reader: what is summarised is what a tracer will accept.
        std::cerr << mrt::hierarchy_summary(mrt::HierarchyFile::open(args.output), "  ");
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{
        "mrt-preprocess: build the multi-resolution point hierarchy of a scene "
        "(Wand & Straßer 2003, §3) and write it to a .mrh file",
        "mrt-preprocess"};
    Arguments args;
    app.add_option("scene", args.scene,
                   "Scene file (.json), or a mesh file (.obj, .ply, .off, .stl) in a scene that "
                   "frames it")
        ->required();
    app.add_option("-o,--output", args.output,
                   "Hierarchy file to write (.mrh; default: the scene's name with .mrh, in the "
                   "working directory)");
    app.add_flag("--print-scene", args.print_scene,
                 "Print the scene JSON the input stands for (a mesh file's framing scene, to "
                 "save and edit) and exit");
    app.add_option("--grid", args.octree.grid, "Voxels per node side (k of the k³ grid)")
        ->check(CLI::Range(1, 256))
        ->default_val(16);
    app.add_option("--max-reps", args.octree.max_representatives,
                   "A triangle with more representatives stays in its node as a triangle")
        ->check(CLI::Range(1, 1000))
        ->default_val(3);
    app.add_option("--oversampling", args.octree.oversampling,
                   "Prefiltering samples per voxel face of surface")
        ->check(CLI::Range(1, 100000))
        ->default_val(100);
    app.add_option("--sampling", args.sampling,
                   "Placement of the prefiltering samples on each triangle")
        ->check(CLI::IsMember(mrt::kTriangleSamplingNames.names()))
        ->default_val("low-discrepancy");
    app.add_option("--seed", args.octree.seed, "Seed of the sample sequences")->default_val(0);
    app.add_option("--threads", args.threads, "Worker threads (0 = all cores)")
        ->check(CLI::Range(0, 1024))
        ->default_val(0);
    app.add_flag("--flatten", args.flatten,
                 "One octree over every triangle in world space (instances expanded) instead of "
                 "one per unique mesh under instance trees");
    app.add_flag("-q,--quiet", args.quiet, "No summary");
    mrt::add_budget_option(app, args.budgets);
    return mrt::run_tool(app, argc, argv, [&] {
        std::optional<tbb::global_control> limit;
        if (args.threads > 0) {
            limit.emplace(tbb::global_control::max_allowed_parallelism,
                          static_cast<std::size_t>(args.threads));
        }
        args.octree.sampling = *mrt::kTriangleSamplingNames.find(args.sampling);
        return run(args);
    });
}
