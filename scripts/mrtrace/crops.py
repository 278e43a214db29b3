"""Enlarged crops of an mrt-compare comparison, side by side: one row per region of the image,
one column per image (the reference, a run, a run's error image), pixels shown as squares. The
discussion of docs/results.md points at its failures with these.

    python3 -m mrtrace.crops OUT.png --dir DIR --rect "LABEL:X0,Y0,X1,Y1" [--rect ...]
             --column reference --column cone --column cone~error --column @equal-time ...

A region is given in fractions of the image's width and height (so that the quick run's smaller
images crop the same place). A column is "reference", a run's spec (its image), a spec followed
by "~error" (its error image), or "@equal-time" (the distributed run at cone's time that the
headline ratios name; where they interpolate between two runs, the one of the two nearer to
cone's time; left out, with a warning, when there is none)."""

import argparse
import json
import math
import os
import sys

from .results import ResultsError, run_reporting_errors


def parse_rect(text):
    label, sep, numbers = text.rpartition(":")
    try:
        x0, y0, x1, y1 = (float(v) for v in numbers.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected LABEL:X0,Y0,X1,Y1 in fractions of the image, got {text!r}") from None
    if not (sep and label and 0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1):
        raise argparse.ArgumentTypeError(
            f"expected LABEL:X0,Y0,X1,Y1 with 0 <= X0 < X1 <= 1 and 0 <= Y0 < Y1 <= 1, got {text!r}")
    return label, (x0, y0, x1, y1)


def equal_time_spec(results):
    """The distributed run at cone's time: the one the headline names, or, where it interpolates
    between two time-budget runs (their times scatter around their budgets on a busy machine),
    the budget run nearest cone's time on the log scale; None without either."""
    ratio = results.get("headline", {}).get("distributed_rmse_at_cone_time")
    if not ratio:
        return None
    if ratio.get("numerator"):
        return ratio["numerator"]
    runs = results["runs"]
    cone = next((r for r in runs if r["spec"] == ratio.get("denominator")), None)
    budgeted = [r for r in runs if r["spec"].startswith("distributed:") and "time-budget=" in
                r["spec"] and r.get("render_seconds", 0) > 0]
    if cone is None or not cone.get("render_seconds", 0) > 0 or not budgeted:
        return None
    return min(budgeted, key=lambda r: abs(math.log(r["render_seconds"] / cone["render_seconds"]))
               )["spec"]


def column_image(results, directory, column):
    """(title, image file) of a column."""
    if column == "reference":
        return "reference", os.path.join(directory, results["reference"]["image"])
    if column == "@equal-time":
        column = equal_time_spec(results)
        if column is None:
            raise ResultsError(f"{directory}/results.json: no distributed run at cone's time "
                               "(its headline has no distributed_rmse_at_cone_time run)")
    spec, _, kind = column.partition("~")
    if kind not in ("", "error"):
        raise ResultsError(f"column {column!r}: expected SPEC or SPEC~error")
    for run in results["runs"]:
        if run["spec"] == spec:
            name = run["error_image"] if kind else run["image"]
            title = f"{spec} error" if kind else spec
            return title, os.path.join(directory, name)
    raise ResultsError(f"{directory}/results.json: no run {spec!r} (runs: "
                       + ", ".join(r["spec"] for r in results["runs"]) + ")")


def draw(output, directory, rects, columns, scale):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.image as mpimg
        import matplotlib.pyplot as plt
    except ImportError:
        raise ResultsError(f"{sys.executable} has no matplotlib (Debian's python3-matplotlib)") \
            from None
    with open(os.path.join(directory, "results.json"), encoding="utf-8") as f:
        results = json.load(f)
    images = []
    for column in columns:
        if column == "@equal-time" and equal_time_spec(results) is None:
            # A cone faster than the smallest budget has no distributed run at its time.
            print(f"mrtrace.crops: {directory}: no distributed run at cone's time; column left out",
                  file=sys.stderr)
            continue
        title, path = column_image(results, directory, column)
        images.append((title, mpimg.imread(path)))
    height, width = images[0][1].shape[:2]
    boxes = []
    for label, (x0, y0, x1, y1) in rects:
        px = (int(x0 * width), int(y0 * height), max(int(x0 * width) + 1, int(x1 * width)),
              max(int(y0 * height) + 1, int(y1 * height)))
        boxes.append((label, px))
    if scale <= 0:
        # About 480 screen pixels for the widest region, whole pixels per image pixel, and at
        # least two so that pixels show as squares.
        scale = max(2, round(480 / max(b[2] - b[0] for _, b in boxes)))
    dpi = 100
    cell_w = max(b[2] - b[0] for _, b in boxes) * scale / dpi
    cell_h = max(b[3] - b[1] for _, b in boxes) * scale / dpi
    fig, axes = plt.subplots(len(boxes), len(images), squeeze=False,
                             figsize=(cell_w * len(images), (cell_h + 0.6) * len(boxes)), dpi=dpi)
    for r, (label, (x0, y0, x1, y1)) in enumerate(boxes):
        for c, (title, image) in enumerate(images):
            ax = axes[r][c]
            ax.imshow(image[y0:y1, x0:x1], interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(title if r == 0 else "", fontsize=8)
            if c == 0:
                ax.set_xlabel(f"{label}: pixels ({x0}, {y0})–({x1}, {y1})", fontsize=8,
                              loc="left")
    fig.tight_layout()
    fig.savefig(output)
    plt.close(fig)
    return True


def main(argv=None):
    parser = argparse.ArgumentParser(prog="mrtrace.crops", description=__doc__.split("\n\n")[0])
    parser.add_argument("output", metavar="OUT.png")
    parser.add_argument("--dir", required=True, help="the comparison's directory (results.json)")
    parser.add_argument("--rect", type=parse_rect, action="append", required=True,
                        help="LABEL:X0,Y0,X1,Y1 in fractions of the image (repeatable: one row each)")
    parser.add_argument("--column", action="append", required=True,
                        help="reference, SPEC, SPEC~error or @equal-time (repeatable)")
    parser.add_argument("--scale", type=int, default=0,
                        help="screen pixels per image pixel (default: about 480 for the widest "
                             "region, at least 2)")
    args = parser.parse_args(argv)
    ok = run_reporting_errors(
        parser.prog, lambda: draw(args.output, args.dir, args.rect, args.column, args.scale))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
