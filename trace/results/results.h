#pragma once
// What a comparison measured: the reference it judged against and, per method run, its time
// and its error. mrt-compare's runs (trace/compare/comparison.h) fill these in; everything
// derived from them (equal-error figures, headline ratios, results.json) reads only these.

#include "trace/render/method.h"

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace mrt {

/// What is known about a reference besides its pixels (each empty when unknown).
struct ReferenceInfo {
    std::optional<int> spp;           ///< Samples per pixel.
    std::optional<double> seconds;    ///< Render time of the reference, in seconds.
    std::optional<double> std_error;  ///< mrt-trace's estimate of the reference's standard error.
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
    Method method = Method::Whitted;       ///< The tracer.
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

std::ostream& operator<<(std::ostream& os, const ReferenceInfo& i);
std::ostream& operator<<(std::ostream& os, const RunResult& r);

}  // namespace mrt
