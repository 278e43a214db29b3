"""Writes the markdown page of one comparison (docs/results/SCENE.md) from mrt-compare's
DIR/results.json: the scene and reference, the plot and montage, the runs, the headline ratios
and the equal-time and equal-error figures — every figure as mrt-compare computed it. What the
figures mean, the same for every comparison, is said once on the index (mrtrace.index), which
this page links. Images are linked, not embedded: --image-dir is where they are, relative to the
page (default: DIR as seen from the page).

    python3 -m mrtrace.page DIR PAGE.md [--title T] [--index ../results.md] [--notes FILE]
        [--image-dir D] [--plot NAME] [--montage NAME]"""

import argparse
import os
import sys

from .headline import scene_table
from .results import RELATION_PREFIX, fmt3, fmt_count, load_results, run_reporting_errors


def md_table(header, rows, align=None):
    align = align or ["---"] * len(header)
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(align) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def seconds_text(x):
    return "—" if x is None else fmt3(x) + " s"


def time_to_text(reach):
    """A time-to-error cell: the time, or the bound mrt-compare gave ("≤ 0.5": the fastest run
    is already more accurate; "≥ 16.0": no run is)."""
    if reach is None:
        return "—"
    return RELATION_PREFIX[reach["relation"]] + fmt3(reach["seconds"])


def report(results, image_dir, plot, montage, title, index=None):
    ref = results.reference
    derived = results.derived
    base = derived["baseline"]
    img = (lambda name: f"{image_dir}/{name}") if image_dir not in ("", ".") else (lambda n: n)
    out = [f"# {title}", ""]
    if index:
        out += [f"Part of [the papers' experiments, reproduced]({index}), which says how these "
                "figures are measured and read.", ""]
    out += [f"- Scene: `{results.scene}`, {results.width}×{results.height} pixels, "
            f"{results.filter} pixel filter.",
            f"- Reference: {ref.spp} samples per pixel, {fmt3(ref.seconds)} s"
            + (f", standard error {fmt3(ref.std_error)} (errors near it are the reference's own "
               "noise, not the method's)." if ref.std_error is not None else
               ", standard error not measured."), ""]
    out += [f"![RMSE against render time, one curve per method]({img(plot)})", "",
            f"![The runs' images and error images side by side]({img(montage)})", ""]

    out += ["## Runs", ""]
    rows = [[run.method, f"`{run.spec}`", fmt3(run.render_seconds), fmt3(run.total_seconds),
             fmt_count(run.rays), fmt3(run.rmse), fmt3(run.display_rmse), fmt3(run.psnr),
             fmt3(run.ssim)]
            for run in results.runs]
    out.append(md_table(["method", "spec", "render s", "total s", "rays", "RMSE",
                         "display RMSE", "PSNR dB", "SSIM"], rows, ["---", "---"] + ["--:"] * 7))
    if derived["dominated_runs"]:
        out += ["", "Dominated runs, left out of the curves: "
                + ", ".join(f"`{d['spec']}`" for d in derived["dominated_runs"]) + "."]

    if results.headline:
        out += ["", "## Headline ratios", "", scene_table(results.headline)]

    out += ["", "## Equal time and equal error", "",
            f"The baseline is `{base['spec']}` ({base['chosen_as']}): {fmt3(base['seconds'])} s, "
            f"RMSE {fmt3(base['rmse'])}."]
    out += ["", f"### RMSE at equal time ({fmt3(base['seconds'])} s)", ""]
    ratios = derived["error_ratio_at_equal_time"]
    rows = [[m, fmt3(v), fmt3(ratios[m])] for m, v in derived["equal_time"].items()]
    out.append(md_table(["method", "RMSE", "÷ baseline RMSE"], rows, ["---", "--:", "--:"]))
    others = [f"{m} reaches RMSE {fmt3(v)} ({fmt3(ratios[m])}× the baseline's)"
              for m, v in derived["equal_time"].items() if v is not None and m != base["curve"]]
    if others:
        out += ["", f"In the baseline's {fmt3(base['seconds'])} s, " + "; ".join(others) + "."]

    levels = derived["levels"]
    out += ["", "### Time to reach an RMSE", ""]
    header = ["method"] + [f"RMSE {fmt3(e)}" + (" (baseline)" if e == base["rmse"] else "")
                           for e in levels]
    rows = [[m] + [time_to_text(t) for t in times] for m, times in derived["time_to_error"].items()]
    out.append(md_table(header, rows, ["---"] + ["--:"] * len(levels)))

    out += ["", "### Speed-up at equal error", ""]
    speedups = derived["speedup_at_equal_error"]
    if speedups:
        rows = [[s["faster"], s["slower"], fmt3(s["error"]), f"{fmt3(s['speedup'])}×",
                 seconds_text(s["faster_seconds"]), seconds_text(s["slower_seconds"])]
                for s in speedups]
        out.append(md_table(["faster", "slower", "RMSE", "speed-up", "faster's time",
                             "slower's time"], rows, ["---", "---"] + ["--:"] * 4))
        at_base = [s for s in speedups if s["error"] == base["rmse"]]
        if at_base:
            out += [""] + [f"At the baseline's RMSE of {fmt3(s['error'])}, {s['faster']} is "
                           f"{fmt3(s['speedup'])}× faster than {s['slower']}." for s in at_base]
    else:
        out.append("No two methods reach a common RMSE within their measured runs.")
    return "\n".join(out) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="mrtrace.page",
        description="Writes the markdown page of one comparison from DIR/results.json.")
    parser.add_argument("dir", metavar="DIR", help="directory holding results.json")
    parser.add_argument("markdown", metavar="PAGE", help="page to write (docs/results/SCENE.md)")
    parser.add_argument("--image-dir", metavar="DIR",
                        help="where the plot and montage are, relative to PAGE's directory "
                             "(default: DIR relative to it)")
    parser.add_argument("--plot", default="error_time.png", help="plot file name in --image-dir")
    parser.add_argument("--montage", default="montage.png", help="montage file name in --image-dir")
    parser.add_argument("--title", default="Error against run time", help="the page's heading")
    parser.add_argument("--index", metavar="LINK",
                        help="the index page, relative to PAGE, linked at the top")
    parser.add_argument("--notes", metavar="FILE",
                        help="hand-written markdown appended under \"Reading the results\" "
                             "(what the numbers mean, which stays true when they are "
                             "regenerated)")
    args = parser.parse_args(argv)
    markdown_dir = os.path.dirname(os.path.abspath(args.markdown))
    image_dir = args.image_dir
    if image_dir is None:
        image_dir = os.path.relpath(os.path.abspath(args.dir), markdown_dir)
    image_dir = image_dir.replace(os.sep, "/").rstrip("/")

    def work():
        results = load_results(os.path.join(args.dir, "results.json"))
        text = report(results, image_dir, args.plot, args.montage, args.title, args.index)
        if args.notes:
            with open(args.notes, encoding="utf-8") as f:
                text += "\n## Reading the results\n\n" + f.read().strip() + "\n"
        with open(args.markdown, "w", encoding="utf-8") as f:
            f.write(text)
        return True

    if run_reporting_errors(parser.prog, work) is None:
        return 1
    for name in (args.plot, args.montage):
        if not os.path.exists(os.path.join(markdown_dir, image_dir, name)):
            print(f"{parser.prog}: warning: {args.markdown} links {image_dir}/{name}, which does "
                  "not exist (yet)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
