#pragma once
// What a comparison reports: DIR/results.json and DIR/results.csv (their names are a contract
// scripts read), the table mrt-compare prints, and the labels of the montage.
//
// results.json:
//   {"scene", "width", "height", "filter", "seed", "error_scale",
//    "reference": {"spp", "seconds", "std_error", "image", "exr", "origin"},
//    "runs": [{"method", "spec", "render_seconds", "total_seconds", "wall_seconds", "rays",
//              "samples", "rmse", "psnr", "ssim", "image", "error_image", "stats", "stopped",
//              "display_rmse"}],
//    "headline": {KEY: {"value", "relation", "numerator", "denominator", "numerator_value",
//                       "denominator_value", "how"}},
//    "derived": {"time": "render_seconds",
//                "baseline": {"run", "method", "curve", "spec", "seconds", "rmse", "chosen_as"},
//                "levels": [RMSE, ...],
//                "curves": [{"label", "runs": [INDEX, ...], "dominated": [INDEX, ...]}],
//                "time_to_error": {LABEL: [{"seconds", "relation", "how"} | null per level]},
//                "equal_time": {LABEL: RMSE | null},
//                "error_ratio_at_equal_time": {LABEL: RATIO | null},
//                "speedup_at_equal_error": [{"faster", "slower", "error", "speedup",
//                                            "faster_seconds", "slower_seconds"}],
//                "dominated_runs": [{"method", "spec"}]} | null}
// (the headline ratios the runs allow, headline_ratios.h; "relation" is "equal", "at most" or
// "at least". "derived" holds the equal-time and equal-error figures, derived_figures.h: the
// curves' runs are indices into "runs", kept ones in order of time; a time to an error "at
// most" is the fastest run's, which is already more accurate, "at least" the slowest's, which
// is not; null where a curve says nothing. The pages and plots print these, computing none.)
// Unknown values (an infinite PSNR, a reference's unknown spp) are null. results.csv has a
// header and one row per run with the scalar fields of "runs" in the same order; there an
// infinite PSNR is "inf" and an unknown value an empty field.

#include "trace/results/results.h"

#include <filesystem>
#include <iosfwd>
#include <string>

namespace mrt {

/// The text of results.json.
std::string results_json_text(const Comparison& comparison);

/// The text of results.csv.
std::string results_csv_text(const Comparison& comparison);

/// Writes DIR/results.json and DIR/results.csv atomically. Throws mrt::Error.
void write_results(const Comparison& comparison, const std::filesystem::path& dir);

/// The aligned table of runs (#, spec, render s, total s, rays, RMSE, display RMSE, PSNR, SSIM)
/// followed by the reference line, one line per headline ratio and the derived figures (the
/// baseline, every curve's RMSE at its time and time to each error level, the baseline curve's
/// speed-ups at equal error).
void print_results_table(std::ostream& os, const Comparison& comparison);

/// "reference: 1024 spp, 12.3 s, std error 0.0012 (rendered, reference.exr)".
std::string reference_line(const Comparison& comparison);

/// PSNR in dB with two decimals, "inf" for identical images.
std::string format_psnr(double psnr);

/// Montage labels, short enough for a 256-pixel cell: the spec under a run's image, its render
/// time and errors under its error image ("0.84 s  RMSE 0.0123  SSIM 0.981").
std::string run_label(const RunResult& run);
std::string error_label(const RunResult& run);
std::string reference_label(const ReferenceSummary& reference);

}  // namespace mrt
