"""Plots image error against render time from mrt-compare's DIR/results.json: one curve per
method, as mrt-compare grouped the runs ("derived"/"curves", trace/results/derived_figures.h):
a curve's kept runs joined by lines, its dominated runs (no faster than another of the curve
and no more accurate) hollow. The baseline's time and RMSE are lines, and where each other
curve stands at them — mrt-compare's equal-time RMSE and time to reach the baseline's RMSE —
is a square. Nothing is computed here beyond placing those numbers.

    python3 -m mrtrace.plot DIR [--metric rmse|psnr|ssim] [-o FILE]

--metric only changes what is plotted; the equal-time and equal-error squares are RMSE figures
and are drawn on the RMSE plot only."""

import argparse
import math
import os
import sys

from .results import ResultsError, fmt3, load_results, run_reporting_errors

METRICS = {
    # name: (axis label, lower is better)
    "rmse": ("RMSE against the reference", True),
    "psnr": ("PSNR against the reference (dB)", False),
    "ssim": ("SSIM against the reference", False),
}


def _noise_level(results, metric, baseline):
    """The reference's noise floor in the plotted metric, None when unknown: its standard error
    in RMSE, and in PSNR through the peak of the baseline's own PSNR–RMSE pair."""
    s = results.reference.std_error
    if s is None or s <= 0:
        return None
    if metric == "rmse":
        return s
    if metric == "psnr" and baseline.psnr is not None:
        peak = baseline.rmse * 10 ** (baseline.psnr / 20)
        return 20 * math.log10(peak / s)
    return None  # SSIM has no mapping from a pixel standard error


def draw(results, metric, output):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ResultsError(f"{sys.executable} has no matplotlib (Debian's python3-matplotlib; "
                           "scripts/setup installs it)") from None
    derived = results.derived
    runs = results.runs
    for run in runs:
        if run.metric(metric) is None:
            raise ResultsError(f"{results.path}: /runs/{run.index}/{metric}: is null, which "
                               "cannot be plotted")
    base = derived["baseline"]
    baseline = runs[base["run"]]
    t_base, v_base = baseline.render_seconds, baseline.metric(metric)
    level = derived["levels"].index(base["rmse"]) if base["rmse"] in derived["levels"] else None
    label, lower_is_better = METRICS[metric]

    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=150)
    ax.set_xscale("log")
    if lower_is_better:
        ax.set_yscale("log")
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    markers = "osD^vP*X"
    for k, curve in enumerate(derived["curves"]):
        name = curve["label"]
        colour, marker = colours[k % len(colours)], markers[k % len(markers)]
        kept = [runs[i] for i in curve["runs"]]
        dominated = [runs[i] for i in curve["dominated"]]
        ax.plot([r.render_seconds for r in kept], [r.metric(metric) for r in kept],
                marker=marker, color=colour, label=name,
                linestyle="-" if len(kept) > 1 else "none")
        if dominated:
            ax.plot([r.render_seconds for r in dominated], [r.metric(metric) for r in dominated],
                    marker=marker, color=colour, markerfacecolor="none", linestyle="none")
        for run in kept + dominated:
            option = run.spec.split(":", 1)[1] if ":" in run.spec else ""
            if option:
                ax.annotate(option, (run.render_seconds, run.metric(metric)), xytext=(4, 4),
                            textcoords="offset points", fontsize=6, color=colour)
        if metric != "rmse" or name == base["curve"]:
            continue
        # Where this curve stands at the baseline's time and at the baseline's error.
        points = [(t_base, derived["equal_time"][name])]
        if level is not None:
            reach = derived["time_to_error"][name][level]
            if reach is not None and reach["relation"] == "equal":
                points.append((reach["seconds"], v_base))
        for point in points:
            if None not in point:
                ax.plot(*point, marker="s", markersize=9, markerfacecolor="none",
                        markeredgecolor=colour, linestyle="none")

    ax.axvline(t_base, color="0.35", linestyle=":", linewidth=1,
               label=f"equal time ({baseline.spec}, {fmt3(t_base)} s)")
    ax.axhline(v_base, color="0.35", linestyle="-.", linewidth=1,
               label=f"equal {metric.upper()} ({baseline.spec}, {fmt3(v_base)})")
    if metric == "rmse":
        ax.plot([], [], marker="s", markerfacecolor="none", markeredgecolor="0.2",
                linestyle="none", markersize=9, label="interpolated at equal time / error")
    if derived["dominated_runs"]:
        ax.plot([], [], marker="o", markerfacecolor="none", color="0.2", linestyle="none",
                label="dominated run (not interpolated)")
    noise = _noise_level(results, metric, baseline)
    if noise is not None:
        ax.axhline(noise, color="0.5", linestyle="--", linewidth=1, label="reference noise")

    ref = results.reference
    ax.set_title(f"{os.path.basename(results.scene)}, {results.width}×{results.height}, "
                 f"{results.filter} filter; reference {ref.spp} spp", fontsize=10)
    ax.set_xlabel("render time (s)")
    ax.set_ylabel(label)
    ax.grid(True, which="both", color="0.9", linewidth=0.6)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(output)
    plt.close(fig)
    return True


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="mrtrace.plot",
        description="Plots error against render time from DIR/results.json (written by "
                    "mrt-compare) into DIR/error_time.png.")
    parser.add_argument("dir", metavar="DIR", help="directory holding results.json")
    parser.add_argument("--metric", choices=sorted(METRICS), default="rmse",
                        help="plotted error metric (default rmse, the only one with the "
                             "equal-time and equal-error squares)")
    parser.add_argument("-o", "--output", metavar="FILE", help="plot (default DIR/error_time.png)")
    args = parser.parse_args(argv)
    output = args.output or os.path.join(args.dir, "error_time.png")

    def work():
        return draw(load_results(os.path.join(args.dir, "results.json")), args.metric, output)

    return 0 if run_reporting_errors(parser.prog, work) else 1


if __name__ == "__main__":
    sys.exit(main())
