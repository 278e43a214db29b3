"""The headline ratios of mrt-compare comparisons (results.json's "headline", computed by
trace/results/headline_ratios.cpp from runs of one invocation) as markdown, beside the figures the
paper reports for them: one table per comparison (mrtrace.page), and a summary of several
comparisons for the index (mrtrace.index):

    python3 -m mrtrace.headline NAME=DIR [NAME=DIR ...]     # prints the summary table
"""

import json
import os
import sys

from .results import RELATION_PREFIX, fmt3

# key: (what it measures, the paper's figure, where the paper says it)
RATIOS = {
    "cone_over_whitted": (
        "cone time ÷ whitted time", "≈ 4",
        "Wand & Straßer §6 and §7: \"about 4 times\" the time of non-antialiased rendering, "
        "on both of its scenes"),
    "distributed_to_cone_error": (
        "time distributed needs to reach cone's RMSE ÷ cone time", "≥ 10",
        "§6 and §7, Figure 7: distributed ray tracing needed \"an order of magnitude\" more time "
        "for a noise-free image, judged by eye; RMSE here also counts the cone's bias"),
    "distributed_to_cone_display_error": (
        "the same, RMSE of values clamped to [0, 1] (as displayed)", "≥ 10",
        "as above; the paper judged by eye, and clamping keeps a few highlights far above 1 from "
        "outweighing the rest of the image"),
    "distributed_rmse_at_cone_time": (
        "distributed's RMSE at cone's time ÷ cone's RMSE", "—",
        "not reported (below 1: distributed is more accurate in the same time)"),
    "classic_over_cone_primary": (
        "cone-classic time ÷ cone time, primary rays only", "2.8",
        "§6, Figure 7: classic cone tracing of the triangles, primary rays only"),
}

def value_text(ratio):
    return RELATION_PREFIX.get(ratio.get("relation"), "") + fmt3(ratio.get("value")) + "×"


def load_headline(directory):
    with open(os.path.join(directory, "results.json"), encoding="utf-8") as f:
        return json.load(f).get("headline", {})


def scene_table(headline):
    """One comparison's ratios, with the runs each is the quotient of."""
    rows = []
    for key, (what, paper, _) in RATIOS.items():
        ratio = headline.get(key)
        if ratio is None:
            continue
        unit = "" if key == "distributed_rmse_at_cone_time" else " s"
        numerator = f"`{ratio['numerator']}`" if ratio.get("numerator") else "interpolated"
        rows.append([what, value_text(ratio),
                     f"{numerator} {fmt3(ratio['numerator_value'])}{unit} ÷ "
                     f"`{ratio['denominator']}` {fmt3(ratio['denominator_value'])}{unit}",
                     ratio.get("how", ""), paper])
    if not rows:
        return "No headline ratio: the comparison has none of the runs they need."
    lines = ["| ratio | value | runs | how | paper |", "|---|--:|---|---|--:|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def summary_table(named_dirs, links=None):
    """Every comparison's ratios side by side, one row per ratio; a comparison's name links to
    links[name] when given."""
    links = links or {}
    headlines = [(name, h) for name, h in ((n, load_headline(d)) for n, d in named_dirs) if h]
    if not headlines:
        return "No comparison has the runs the headline ratios need."
    names = [f"[{name}]({links[name]})" if name in links else name for name, _ in headlines]
    lines = ["| ratio | " + " | ".join(names) + " | paper |",
             "|---|" + "--:|" * len(headlines) + "--:|"]
    for key, (what, paper, _) in RATIOS.items():
        cells = [value_text(h[key]) if key in h else "—" for _, h in headlines]
        lines.append(f"| {what} | " + " | ".join(cells) + f" | {paper} |")
    notes = [f"- *{what}*, paper: {where}." for what, _, where in RATIOS.values()]
    return "\n".join(lines) + "\n\n" + "\n".join(notes)


def main(argv):
    named = []
    for arg in argv:
        name, sep, directory = arg.partition("=")
        if not sep or not name or not directory:
            print(f"mrtrace.headline: expected NAME=DIR, got {arg!r}", file=sys.stderr)
            return 2
        if not os.path.exists(os.path.join(directory, "results.json")):
            print(f"mrtrace.headline: {directory}/results.json: no such file", file=sys.stderr)
            return 1
        named.append((name, directory))
    if not named:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    print(summary_table(named))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
