#pragma once
// mrt-compare's comparison: a reference image and a list of method runs, each rendered by the
// mrt-trace executable as a child process, each judged against the reference (RMSE, PSNR, SSIM,
// an error image) with the time it took. Files in the output directory DIR:
//
//   reference.exr, reference.png, reference.json, reference-stats.json   (see reference_cache.h)
//   NN-SLUG.exr, NN-SLUG.png, NN-SLUG-error.png, NN-SLUG.json             (run NN, its stats)
//   results.json, results.csv, montage.png                                (comparison_report.h)

#include "trace/compare/reference_cache.h"

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace mrt {

struct ComparisonOptions {
    std::filesystem::path scene;            ///< Scene file, handed to mrt-trace.
    std::filesystem::path out_dir;          ///< DIR: created when missing.
    std::vector<std::string> method_specs;  ///< Specs (method_spec.h); empty: the default runs.
    std::optional<int> width;               ///< Image width; empty: the scene camera's.
    std::optional<int> height;              ///< Image height; empty: the scene camera's.
    int reference_spp = 1024;               ///< Samples per pixel of a rendered reference.
    std::filesystem::path reference_image;  ///< A given reference (.exr); empty: render it.
    std::optional<std::string> filter;      ///< Pixel filter spec; empty: box.
    std::uint64_t seed = 0;                 ///< Seed of every run and of the reference.
    std::optional<int> threads;             ///< Worker threads per run; empty: mrt-trace's.
    double error_scale = 0.1;               ///< Mean absolute error shown white in error images.
    bool quiet = false;                     ///< No messages (reference reuse) on the log.
    bool progress = false;                  ///< A line on the log as each render starts.
    std::filesystem::path trace_exe;        ///< The mrt-trace executable.
    /// --budget NAME=VALUE assignments, handed to every mrt-trace run as given.
    std::vector<std::string> budget_assignments;
};

/// Where the reference of a comparison came from.
enum class ReferenceOrigin { Rendered, Cached, Given };

/// The reference a comparison measured against.
struct ReferenceSummary {
    ReferenceOrigin origin = ReferenceOrigin::Rendered;
    std::filesystem::path exr;  ///< The linear image used (DIR/reference.exr or the given one).
    std::string image;          ///< Its PNG, relative to DIR ("reference.png").
    ReferenceInfo info;         ///< spp, seconds, std_error (each possibly unknown).
};

/// One method run and its error against the reference.
struct RunResult {
    std::string method;                    ///< The tracer (the stats' "method").
    std::string spec;                      ///< The method spec as run.
    double render_seconds = 0.0;           ///< The stats' render_seconds.
    double total_seconds = 0.0;            ///< The stats' load + build + render seconds.
    double wall_seconds = 0.0;             ///< The child process's wall time, spawn to exit.
    std::uint64_t rays = 0;                ///< The stats' rays (all kinds).
    std::optional<std::uint64_t> samples;  ///< The stats' samples, when mrt-trace reports it.
    double rmse = 0.0;                     ///< Against the reference, linear RGB.
    double display_rmse = 0.0;             ///< The same, values clamped to [0, 1] first.
    double psnr = 0.0;                     ///< dB, peak 1; +inf for an identical image.
    double ssim = 0.0;                     ///< Mean SSIM of luminance.
    std::string image;                     ///< NN-SLUG.png, relative to DIR.
    std::string error_image;               ///< NN-SLUG-error.png, relative to DIR.
    std::string stats;                     ///< NN-SLUG.json (mrt-trace's stats), relative to DIR.
    std::string exr;                       ///< NN-SLUG.exr (the linear image), relative to DIR.
    /// The run stopped at its time guard before finishing the image (the stats' "stopped":
    /// cone-classic): its error is that of an unfinished image, reported as such.
    bool stopped = false;
};

/// Everything a comparison measured.
struct Comparison {
    std::string scene;  ///< The scene file as the user named it (results are read elsewhere).
    int width = 0;      ///< Image size in pixels (the reference's).
    int height = 0;
    std::string filter;  ///< Canonical pixel filter.
    std::uint64_t seed = 0;
    double error_scale = 0.0;  ///< Error-image scale (mean absolute error shown white).
    ReferenceSummary reference;
    std::vector<RunResult> runs;
};

/// Renders (or reuses, or reads) the reference, renders every run, measures them and writes
/// every file listed above into options.out_dir. Messages and progress lines go to `log`.
/// Throws mrt::Error on bad input or a failed run, naming the file or the spec.
Comparison run_comparison(const ComparisonOptions& options, std::ostream& log);

/// The mrt-trace beside the running executable (through /proc/self/exe), or $MRT_TRACE when
/// set. Throws mrt::Error when it is not an executable file.
std::filesystem::path find_trace_executable();

std::ostream& operator<<(std::ostream& os, const RunResult& r);

}  // namespace mrt
