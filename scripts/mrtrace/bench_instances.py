"""Preprocessing time and peak memory against instance count (scripts/bench's `instances`
section). Writes scenes of N instances of one 8-triangle sphere (segments 4, rings 2) in three
layouts, for N = 1, 2, 4, … up to --max:

  overlapping  N top-level instances at one place (duplicated objects)
  list         N top-level instances side by side on a cubic lattice, none overlapping
  tree         the same N places as a nested binary tree of groups, each instancing the level
               below twice (N a power of two)

and runs `mrt-preprocess --threads 2 --quiet` on each under `/usr/bin/time -v` (CPU time, wall
time and maximum resident set), with a time limit per run; the table shows CPU time, which a
busy machine disturbs less than wall time. Prints JSON (a list of runs) on stdout and a
Markdown table on stderr; --out also writes the JSON to a file.

Usage: PYTHONPATH=scripts python3 -m mrtrace.bench_instances --preprocess build/bin/mrt-preprocess
           [--max 1024] [--layouts overlapping,list,tree] [--timeout 600] [--out FILE]
"""

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

SPHERE = {"shape": "sphere", "radius": 1, "segments": 4, "rings": 2, "material": "white"}
SPACING = 3.0  # lattice step of the non-overlapping layouts: the spheres are 2 wide


def base_scene(extent):
    return {
        "camera": {"eye": [0.5 * extent, 0.5 * extent, 2.5 * extent + 4],
                   "look_at": [0.5 * extent, 0.5 * extent, 0], "resolution": [64, 64]},
        "materials": {"white": {"diffuse": 0.8}},
        "lights": [{"type": "point", "position": [0, 10 + extent, 10 + extent], "power": 1000}],
    }


def lattice_side(n):
    side = 1
    while side ** 3 < n:
        side += 1
    return side


def overlapping(n):
    scene = base_scene(0)
    scene["objects"] = [dict(SPHERE) for _ in range(n)]
    return scene


def listed(n):
    side = lattice_side(n)
    scene = base_scene(SPACING * side)
    scene["groups"] = {"sphere": {"objects": [SPHERE]}}
    scene["objects"] = [
        {"instance": "sphere", "transform": {"translate": [SPACING * (i % side),
                                                           SPACING * (i // side % side),
                                                           SPACING * (i // (side * side))]}}
        for i in range(n)]
    return scene


def tree(n):
    levels = n.bit_length() - 1
    if 1 << levels != n:
        raise ValueError("the tree layout needs a power of two")
    groups = {"level0": {"objects": [SPHERE]}}
    # Level l doubles level l − 1 along axis l mod 3: the same lattice places as `list` when
    # N is a power of eight.
    step = [SPACING, SPACING, SPACING]
    for level in range(1, levels + 1):
        axis = (level - 1) % 3
        offset = [0.0, 0.0, 0.0]
        offset[axis] = step[axis]
        groups[f"level{level}"] = {"objects": [
            {"instance": f"level{level - 1}"},
            {"instance": f"level{level - 1}", "transform": {"translate": offset}}]}
        step[axis] *= 2
    scene = base_scene(max(step))
    scene["groups"] = groups
    scene["objects"] = [{"instance": f"level{levels}"}]
    return scene


LAYOUTS = {"overlapping": overlapping, "list": listed, "tree": tree}


def gnu_time(log):
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", log)
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", log)
    user = re.search(r"User time \(seconds\): ([\d.]+)", log)
    system = re.search(r"System time \(seconds\): ([\d.]+)", log)
    out = {}
    if wall:
        seconds = 0.0
        for part in wall.group(1).split(":"):
            seconds = 60.0 * seconds + float(part)
        out["wall_seconds"] = seconds
    if user and system:
        out["cpu_seconds"] = float(user.group(1)) + float(system.group(1))
    if rss:
        out["peak_memory_mb"] = int(rss.group(1)) * 1024 / 1e6
    return out


def run(preprocess, layout, n, work, timeout):
    path = os.path.join(work, f"{layout}-{n}.json")
    with open(path, "w") as f:
        json.dump(LAYOUTS[layout](n), f)
    command = ["/usr/bin/time", "-v", preprocess, path, "-o", os.path.join(work, "out.mrh"),
               "--threads", "2", "--quiet"]
    start = time.monotonic()
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"layout": layout, "instances": n, "finished": False, "timeout_seconds": timeout}
    result = {"layout": layout, "instances": n, "finished": done.returncode == 0}
    result.update(gnu_time(done.stderr))
    result.setdefault("wall_seconds", time.monotonic() - start)
    if done.returncode != 0:
        result["error"] = done.stderr.strip().splitlines()[0] if done.stderr.strip() else ""
    return result


def table(results):
    counts = sorted({r["instances"] for r in results})
    layouts = [l for l in LAYOUTS if any(r["layout"] == l for r in results)]
    by = {(r["layout"], r["instances"]): r for r in results}
    head = "| instances | " + " | ".join(f"{l} CPU s | {l} MB" for l in layouts) + " |"
    rule = "|--:|" + "--:|--:|" * len(layouts)
    rows = [head, rule]
    for n in counts:
        cells = []
        for l in layouts:
            r = by.get((l, n))
            if r is None:
                cells += ["", ""]
            elif not r["finished"]:
                cells += [f"> {r.get('timeout_seconds', '?')}" if "error" not in r else "error",
                          ""]
            else:
                cells += [f"{r.get('cpu_seconds', r['wall_seconds']):.2f}",
                          f"{r.get('peak_memory_mb', 0):.0f}"]
        rows.append(f"| {n} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--preprocess", required=True, help="the mrt-preprocess binary")
    parser.add_argument("--max", type=int, default=1024, help="largest instance count")
    parser.add_argument("--layouts", default="overlapping,list,tree")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per run")
    parser.add_argument("--out", help="also write the JSON here")
    args = parser.parse_args()
    layouts = args.layouts.split(",")
    for layout in layouts:
        if layout not in LAYOUTS:
            parser.error(f"unknown layout {layout} (expected some of {', '.join(LAYOUTS)})")
    results = []
    with tempfile.TemporaryDirectory() as work:
        for layout in layouts:
            n = 1
            while n <= args.max:
                result = run(args.preprocess, layout, n, work, args.timeout)
                results.append(result)
                print(json.dumps(result), file=sys.stderr, flush=True)
                if not result["finished"]:
                    break  # larger counts only take longer
                n *= 2
    text = json.dumps(results, indent=2)
    print(text)
    print(table(results), file=sys.stderr)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
