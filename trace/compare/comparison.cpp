#include "trace/compare/comparison.h"

#include "common/image/image.h"
#include "common/image/image_metrics.h"
#include "common/system/error.h"
#include "trace/compare/child_process.h"
#include "trace/compare/montage.h"
#include "trace/compare/reference_cache.h"
#include "trace/render/method.h"
#include "trace/results/comparison_report.h"
#include "trace/results/equal_error.h"
#include "trace/results/headline_ratios.h"
#include "trace/results/method_spec.h"

#include <fmt/format.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <ostream>
#include <system_error>

namespace mrt {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kReferenceExr = "reference.exr";
constexpr const char* kReferencePng = "reference.png";
constexpr const char* kReferenceRecord = "reference.json";
constexpr const char* kReferenceStats = "reference-stats.json";
constexpr std::string_view kReferenceMethod = to_string(Method::Distributed);
// The reference point-samples textures (bilinear at full resolution): with enough samples per
// pixel that converges to the exact pixel integral, where a filter would add its own blur and
// favour the runs that use the same one.
constexpr const char* kReferenceTextureFilter = "none";

/// One entry of the run list: a spec, or a time-budget run (or an equal-error search) of the
/// default set whose spec is known once the run it is measured against has run.
struct PlannedRun {
    std::string spec;
    const DefaultRun* budget = nullptr;
};

/// What the comparison passes to every mrt-trace run, after the scene.
std::vector<std::string> common_arguments(const ComparisonOptions& options,
                                          const std::string& scene, const fs::path& output,
                                          const fs::path& stats) {
    std::vector<std::string> args = {scene,     "--output",     output.string(),
                                     "--stats", stats.string(), "--quiet"};
    if (options.width) {
        args.insert(args.end(), {"--width", std::to_string(*options.width)});
    }
    if (options.height) {
        args.insert(args.end(), {"--height", std::to_string(*options.height)});
    }
    // Always explicit, so that the reference's key never depends on mrt-trace's default.
    args.insert(args.end(), {"--filter", canonical_filter(options.filter.value_or("box"))});
    args.insert(args.end(), {"--seed", std::to_string(options.seed)});
    if (options.threads) {
        args.insert(args.end(), {"--threads", std::to_string(*options.threads)});
    }
    for (const std::string& assignment : options.budget_assignments) {
        args.insert(args.end(), {"--budget", assignment});
    }
    return args;
}

/// Runs mrt-trace; throws naming `what` (a spec, or the reference) and quoting the child's
/// last line on stderr when it fails.
ProcessResult run_trace(const ComparisonOptions& options, const std::vector<std::string>& args,
                        const std::string& what) {
    ProcessResult result = run_process(options.trace_exe, args);
    if (!result.succeeded()) {
        const std::string line = last_line(result.err);
        throw Error(fmt::format("{}: mrt-trace failed ({}){}", what, describe_exit(result),
                                line.empty() ? "" : ": \"" + line + "\""));
    }
    return result;
}

json read_stats(const fs::path& file) {
    std::ifstream in(file);
    if (!in) {
        throw Error(file, "", "mrt-trace wrote no stats file");
    }
    try {
        json j = json::parse(in);
        if (!j.is_object()) {
            throw Error(file, "", "the stats are not a JSON object");
        }
        return j;
    } catch (const json::parse_error& e) {
        throw Error(file, fmt::format("byte {}", e.byte), "the stats are not valid JSON");
    }
}

double stats_number(const fs::path& file, const json& stats, const char* key) {
    const auto it = stats.find(key);
    if (it == stats.end() || !it->is_number()) {
        throw Error(file, fmt::format("/{}", key), "expected a number in mrt-trace's stats");
    }
    return it->get<double>();
}

template <typename T>
std::optional<T> optional_stats_number(const json& stats, const char* key) {
    const auto it = stats.find(key);
    if (it == stats.end() || !it->is_number()) {
        return std::nullopt;
    }
    return it->get<T>();
}

void check_size(const Image& image, const fs::path& file, int width, int height,
                const std::string& expectation) {
    if (image.width() != width || image.height() != height) {
        throw Error(file, "",
                    fmt::format("the image is {}×{}, expected {}×{} ({})", image.width(),
                                image.height(), width, height, expectation));
    }
}

void prepare_out_dir(const fs::path& dir) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (!fs::is_directory(dir, ec)) {
        throw Error(dir, "", "cannot create the output directory");
    }
    if (::access(dir.c_str(), W_OK | X_OK) != 0) {
        throw Error(dir, "", "the output directory is not writable");
    }
}

/// Deletes the run files an earlier comparison in `dir` listed in its results.json, so that the
/// directory never mixes images of two comparisons (specs and their numbering change between
/// calls). Only plain file names the earlier results named are touched; the cached reference
/// stays. A missing or unreadable results.json means there is nothing to clean.
void remove_previous_runs(const fs::path& dir) {
    std::ifstream in(dir / "results.json");
    if (!in) {
        return;
    }
    const nlohmann::json previous = nlohmann::json::parse(in, nullptr, false);
    if (!previous.is_object() || !previous.contains("runs") || !previous["runs"].is_array()) {
        return;
    }
    std::error_code ignored;
    for (const nlohmann::json& run : previous["runs"]) {
        if (!run.is_object()) {
            continue;
        }
        for (const char* key : {"image", "error_image", "stats"}) {
            if (!run.contains(key) || !run[key].is_string()) {
                continue;
            }
            const fs::path name = run[key].get<std::string>();
            if (name.empty() || name != name.filename()) {
                continue;  // not a file of ours: we only ever write plain names into DIR
            }
            fs::remove(dir / name, ignored);
            if (std::string(key) == "image") {
                fs::remove(dir / fs::path(name).replace_extension(".exr"), ignored);
            }
        }
    }
}

fs::path checked_scene(const fs::path& scene) {
    std::error_code ec;
    if (!fs::exists(scene, ec)) {
        throw Error(scene, "", "no such scene file");
    }
    if (!fs::is_regular_file(scene, ec)) {
        throw Error(scene, "", "the scene is not a regular file");
    }
    return fs::canonical(scene);
}

/// The runs to make: the given specs, or the default runs of every method.
std::vector<PlannedRun> plan_runs(const ComparisonOptions& options) {
    std::vector<PlannedRun> plan;
    if (!options.method_specs.empty()) {
        for (const std::string& spec : options.method_specs) {
            parse_method_spec(spec);  // every spec is checked before anything runs
            plan.push_back({spec, nullptr});
        }
        return plan;
    }
    for (const DefaultRun& run : default_runs()) {
        if (run.budget_factor > 0.0) {
            // Its budget needs the time of a fixed run planned before it.
            const bool base_planned =
                std::any_of(plan.begin(), plan.end(), [&](const PlannedRun& p) {
                    return p.budget == nullptr && p.spec == run.budget_base();
                });
            if (base_planned) {
                plan.push_back({"", &run});
            }
        } else {
            plan.push_back({default_run_spec(run), nullptr});
        }
    }
    return plan;
}

/// A strip showing the error colours from 0 (left) to `error_scale` (right), as tall as a
/// quarter of the image: the key to the error images of the montage.
Image error_legend(int width, int height, double error_scale) {
    const int legend_height = std::max(1, height / 4);
    Image ramp(width, legend_height);
    const Image zero(width, legend_height);
    for (int y = 0; y < legend_height; ++y) {
        for (int x = 0; x < width; ++x) {
            const double t = width > 1 ? static_cast<double>(x) / (width - 1) : 1.0;
            const auto v = static_cast<float>(t * error_scale);
            ramp.set(x, y, Rgb(v, v, v));
        }
    }
    return error_image(ramp, zero, static_cast<float>(error_scale));
}

class ComparisonRun {
  public:
    ComparisonRun(const ComparisonOptions& options, std::ostream& log)
        : m_options(options), m_log(log) {}

    Comparison run() {
        const fs::path scene = checked_scene(m_options.scene);
        if (!(m_options.error_scale > 0.0) || !std::isfinite(m_options.error_scale)) {
            throw Error(fmt::format("--error-scale must be a positive number, got {}",
                                    m_options.error_scale));
        }
        m_result.scene = m_options.scene.string();
        m_result.filter = canonical_filter(m_options.filter.value_or("box"));
        m_result.seed = m_options.seed;
        m_result.error_scale = m_options.error_scale;
        const std::vector<PlannedRun> plan = plan_runs(m_options);
        prepare_out_dir(m_options.out_dir);
        remove_previous_runs(m_options.out_dir);

        m_total_renders = 0;
        for (const PlannedRun& planned : plan) {
            const bool search = planned.budget != nullptr && planned.budget->to_equal_error;
            m_total_renders += search ? kMaxEqualErrorRenders : 1;
        }
        prepare_reference(scene);
        m_result.width = m_reference.width();
        m_result.height = m_reference.height();
        m_cells.push_back({m_reference, reference_label(m_result.reference)});
        m_cells.push_back(
            {error_legend(m_reference.width(), m_reference.height(), m_options.error_scale),
             fmt::format("error 0 to {} (mean |difference|)", m_options.error_scale)});

        for (const PlannedRun& planned : plan) {
            if (planned.budget == nullptr) {
                render_run(planned.spec, scene);
            } else if (planned.budget->to_equal_error) {
                search_equal_error(*planned.budget, scene);
            } else {
                const RunResult* base = first_run(planned.budget->budget_base());
                const std::string spec =
                    budget_run_spec(*planned.budget, base != nullptr ? base->render_seconds : 0.0);
                // Budgets floored at the minimum can coincide (distributed at 4× a fast
                // whitted's time and at a fast cone's): that run has been measured already.
                if (first_run(spec) == nullptr) {
                    render_run(spec, scene);
                }
            }
        }

        write_results(m_result, m_options.out_dir);
        write_montage();
        return m_result;
    }

  private:
    const RunResult* first_run(const std::string& spec) const {
        const auto it = std::find_if(m_result.runs.begin(), m_result.runs.end(),
                                     [&](const RunResult& r) { return r.spec == spec; });
        return it != m_result.runs.end() ? &*it : nullptr;
    }

    /// Renders `search.method` with time budgets until one reaches the RMSE of the run
    /// `search.budget_base()` (equal_error.h), starting from the curve of the runs of the same
    /// kind already made, so that the time to equal error is measured rather than read off a
    /// line between runs far apart.
    void search_equal_error(const DefaultRun& search, const fs::path& scene) {
        const RunResult* base = first_run(search.budget_base());
        if (base == nullptr) {
            return;
        }
        const double target = error_of(*base, search.measure);
        const double max_budget =
            search.budget_factor * std::max(base->render_seconds, kMinimumBudgetBaseSeconds);
        for (int i = 0; i < kMaxEqualErrorRenders; ++i) {
            const BudgetCurve curve = budget_curve(m_result.runs, search, search.measure);
            const std::optional<double> budget =
                next_equal_error_budget(curve.points, target, kMinimumBudgetSeconds, max_budget);
            if (!budget) {
                return;
            }
            render_run(spec_with_budget(search, *budget), scene);
        }
    }

    void progress_line(const std::string& text) {
        if (m_options.progress && !m_options.quiet) {
            m_log << text << std::endl;
        }
    }

    void message(const std::string& text) {
        if (!m_options.quiet) {
            m_log << "mrt-compare: " << text << std::endl;
        }
    }

    ReferenceKey reference_key(const fs::path& scene) const {
        ReferenceKey key;
        key.scene = scene.string();
        key.scene_hash = scene_file_hash(scene);
        key.width = m_options.width;
        key.height = m_options.height;
        key.filter = m_result.filter;
        key.texture_filter = kReferenceTextureFilter;
        key.spp = m_options.reference_spp;
        key.seed = m_options.seed;
        return key;
    }

    /// Whether `image` may be the reference of this comparison (a size given in full must match;
    /// otherwise every run's image is checked against the reference's size).
    bool has_requested_size(const Image& image) const {
        return (!m_options.width || image.width() == *m_options.width) &&
               (!m_options.height || image.height() == *m_options.height);
    }

    void check_requested_size(const Image& image, const fs::path& file) const {
        if (has_requested_size(image)) {
            return;
        }
        std::string requested;
        if (m_options.width && m_options.height) {
            requested = fmt::format("{}×{}", *m_options.width, *m_options.height);
        } else if (m_options.width) {
            requested = fmt::format("width {}", *m_options.width);
        } else {
            requested = fmt::format("height {}", m_options.height.value_or(0));
        }
        throw Error(file, "",
                    fmt::format("the reference is {}×{}, but this comparison is {}", image.width(),
                                image.height(), requested));
    }

    void prepare_reference(const fs::path& scene) {
        ReferenceSummary& summary = m_result.reference;
        const fs::path dir = m_options.out_dir;
        summary.image = kReferencePng;
        if (!m_options.reference_image.empty()) {
            summary.origin = ReferenceOrigin::Given;
            summary.exr = m_options.reference_image;
            m_reference = read_image(m_options.reference_image);
            check_requested_size(m_reference, m_options.reference_image);
            fs::path record = m_options.reference_image;
            record.replace_extension(".json");
            std::error_code ec;
            if (fs::exists(record, ec)) {
                summary.info = read_reference_info(record);
            }
        } else {
            const ReferenceKey key = reference_key(scene);
            summary.exr = dir / kReferenceExr;
            if (const auto cached = cached_reference(key)) {
                summary.origin = ReferenceOrigin::Cached;
                summary.info = *cached;
                message(
                    fmt::format("reusing the cached reference {} (same scene, size, filter, "
                                "spp and seed)",
                                summary.exr.string()));
            } else {
                summary.origin = ReferenceOrigin::Rendered;
                render_reference(scene, key);
            }
        }
        write_image(dir / kReferencePng, m_reference);
    }

    std::optional<ReferenceInfo> cached_reference(const ReferenceKey& key) {
        const fs::path dir = m_options.out_dir;
        auto info = cached_reference_info(dir / kReferenceRecord, key);
        if (!info) {
            return std::nullopt;
        }
        try {
            Image image = read_image(dir / kReferenceExr);
            if (image.empty() || !has_requested_size(image)) {
                return std::nullopt;
            }
            m_reference = std::move(image);
        } catch (const Error&) {
            return std::nullopt;
        }
        return info;
    }

    void render_reference(const fs::path& scene, const ReferenceKey& key) {
        const fs::path dir = m_options.out_dir;
        // Without a record, a render that fails half-way can never be taken for a cached one.
        std::error_code ec;
        fs::remove(dir / kReferenceRecord, ec);
        std::vector<std::string> args =
            common_arguments(m_options, scene.string(), dir / kReferenceExr, dir / kReferenceStats);
        args.insert(args.end(), {"--method", std::string(kReferenceMethod), "--reference", "--spp",
                                 std::to_string(m_options.reference_spp), "--texture-filter",
                                 kReferenceTextureFilter});
        const std::string what =
            fmt::format("reference ({} --reference --spp {} --texture-filter {})", kReferenceMethod,
                        m_options.reference_spp, kReferenceTextureFilter);
        progress_line(fmt::format("[ref] {} ...", what));
        run_trace(m_options, args, what);

        const json stats = read_stats(dir / kReferenceStats);
        ReferenceInfo& info = m_result.reference.info;
        info.spp = optional_stats_number<int>(stats, "spp").value_or(m_options.reference_spp);
        info.seconds = stats_number(dir / kReferenceStats, stats, "render_seconds");
        info.std_error = optional_stats_number<double>(stats, "std_error");
        m_reference = read_image(dir / kReferenceExr);
        check_requested_size(m_reference, dir / kReferenceExr);
        write_reference_record(dir / kReferenceRecord, key, info);
    }

    const RunResult& render_run(const std::string& spec_text, const fs::path& scene) {
        const MethodSpec spec = parse_method_spec(spec_text);
        const int index = static_cast<int>(m_result.runs.size()) + 1;
        const fs::path dir = m_options.out_dir;
        const std::string base = fmt::format("{:02}-{}", index, spec_slug(spec_text));
        RunResult run;
        run.spec = spec_text;
        run.exr = base + ".exr";
        run.image = base + ".png";
        run.error_image = base + "-error.png";
        run.stats = base + ".json";

        std::vector<std::string> args =
            common_arguments(m_options, scene.string(), dir / run.exr, dir / run.stats);
        const std::vector<std::string> method_args = trace_arguments(spec);
        args.insert(args.end(), method_args.begin(), method_args.end());
        progress_line(fmt::format("[{}/{}] {} ...", index, m_total_renders, spec_text));
        const ProcessResult process = run_trace(m_options, args, spec_text);
        run.wall_seconds = process.wall_seconds;

        const fs::path stats_file = dir / run.stats;
        const json stats = read_stats(stats_file);
        run.method = spec.method;
        run.render_seconds = stats_number(stats_file, stats, "render_seconds");
        run.total_seconds = stats_number(stats_file, stats, "load_seconds") +
                            stats_number(stats_file, stats, "build_seconds") + run.render_seconds;
        run.rays = static_cast<std::uint64_t>(stats_number(stats_file, stats, "rays"));
        run.samples = optional_stats_number<std::uint64_t>(stats, "samples");
        run.stopped = stats.contains("stopped") && stats["stopped"].is_boolean() &&
                      stats["stopped"].get<bool>();

        const Image image = read_image(dir / run.exr);
        check_size(image, dir / run.exr, m_reference.width(), m_reference.height(),
                   fmt::format("the size of the reference {}", m_result.reference.exr.string()));
        run.rmse = rmse(image, m_reference);
        run.display_rmse = display_rmse(image, m_reference);
        run.psnr = psnr(image, m_reference);
        run.ssim = ssim(image, m_reference);
        const Image error =
            error_image(image, m_reference, static_cast<float>(m_options.error_scale));
        write_image(dir / run.image, image);
        write_image(dir / run.error_image, error);

        m_result.runs.push_back(run);
        m_cells.push_back({image, run_label(run)});
        m_cells.push_back({error, error_label(run)});
        return m_result.runs.back();
    }

    void write_montage() {
        MontageOptions montage_options;
        // Two columns (image | error image); cells wide enough for a spec or an error line.
        montage_options.cell_width = 320;
        montage_options.warn = [this](const std::string& text) { message(text); };
        write_image(m_options.out_dir / "montage.png", make_montage(m_cells, 2, montage_options));
    }

    const ComparisonOptions& m_options;
    std::ostream& m_log;
    Comparison m_result;
    Image m_reference;
    std::vector<MontageCell> m_cells;
    int m_total_renders = 0;
};

}  // namespace

Comparison run_comparison(const ComparisonOptions& options, std::ostream& log) {
    return ComparisonRun(options, log).run();
}

fs::path find_trace_executable() {
    fs::path exe;
    if (const char* env = std::getenv("MRT_TRACE"); env != nullptr && *env != '\0') {
        exe = env;
    } else {
        std::error_code ec;
        const fs::path self = fs::read_symlink("/proc/self/exe", ec);
        if (ec) {
            throw Error(fs::path("/proc/self/exe"), "",
                        "cannot find this executable to find mrt-trace beside it; set MRT_TRACE");
        }
        exe = self.parent_path() / "mrt-trace";
    }
    std::error_code ec;
    if (!fs::is_regular_file(exe, ec) || ::access(exe.c_str(), X_OK) != 0) {
        throw Error(exe, "",
                    "mrt-trace is not an executable file here (it is looked for beside "
                    "mrt-compare; set MRT_TRACE to use another)");
    }
    return exe;
}

}  // namespace mrt
