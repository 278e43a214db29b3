#pragma once
// mrt-compare's comparison: a reference image and a list of method runs, each rendered by the
// mrt-trace executable as a child process, each judged against the reference (RMSE, PSNR, SSIM,
// an error image) with the time it took. Files in the output directory DIR:
//
//   reference.exr, reference.png, reference.json, reference-stats.json   (see reference_cache.h)
//   NN-SLUG.exr, NN-SLUG.png, NN-SLUG-error.png, NN-SLUG.json             (run NN, its stats)
//   results.json, results.csv (trace/results/comparison_report.h), montage.png

#include "trace/results/results.h"

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

/// Renders (or reuses, or reads) the reference, renders every run, measures them and writes
/// every file listed above into options.out_dir. Messages and progress lines go to `log`.
/// Throws mrt::Error on bad input or a failed run, naming the file or the spec.
Comparison run_comparison(const ComparisonOptions& options, std::ostream& log);

/// The mrt-trace beside the running executable (through /proc/self/exe), or $MRT_TRACE when
/// set. Throws mrt::Error when it is not an executable file.
std::filesystem::path find_trace_executable();

}  // namespace mrt
