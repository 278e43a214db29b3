"""Summarises scripts/bench's raw results (Google Benchmark JSON, mrt-trace --stats files and
mrt-preprocess runs) into one JSON document on stdout (and into a file when one is named).
Sections that scripts/bench did not run are left out."""

import glob
import json
import os
import re
import statistics
import sys

# Wand & Straßer 2003, preprocessing on a 2 GHz Pentium 4: seconds and megabytes of memory.
PAPER_PREPROCESSING = {
    "machine": "2 GHz Pentium 4",
    "scenes": [
        {"triangles": 7440, "seconds": 5.7, "memory_mb": 2.3, "compare_with": "two-spheres"},
        {"unique_triangles": 110231, "instanced_triangles": 8700000, "seconds": 443,
         "memory_mb": 106, "compare_with": "field"},
    ],
}


def kernels(paths):
    """The medians of Google Benchmark JSON files, by benchmark name: the BVH kernels (in ms)
    and the cone block tests (ns per block, with the instruction set the SIMD kernels ran on)."""
    out = {}
    context = None
    for path in paths:
        with open(path) as f:
            data = json.load(f)
        if context is None:
            context = {k: data["context"].get(k)
                       for k in ("num_cpus", "mhz_per_cpu", "library_build_type")}
        for b in data["benchmarks"]:
            if b.get("aggregate_name") != "median":
                continue
            name = b["run_name"]
            to_ms = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}[b["time_unit"]]
            entry = {"real_time_ms": b["real_time"] * to_ms}
            if b["time_unit"] == "ns":
                entry["real_time_ns"] = b["real_time"]
            if b.get("label"):
                entry["instruction_set"] = b["label"]
            for key, value in b.items():
                if key in ("hit_fraction", "triangles", "nodes", "kept_fraction"):
                    entry[key] = value
                elif key == "rays/s":
                    entry["rays_per_second"] = value
            out[name] = entry
    return {"context": context, "kernels": out}


def renders(work, prefix):
    groups = {}
    for path in sorted(glob.glob(os.path.join(work, prefix + "-*.json"))):
        name = os.path.basename(path)[len(prefix) + 1:-len(".json")]
        scene, threads, _ = name.rsplit("-", 2)
        with open(path) as f:
            groups.setdefault((scene, int(threads)), []).append(json.load(f))
    out = []
    for (scene, threads), runs in sorted(groups.items()):
        out.append({
            "scene": scene, "threads": threads, "runs": len(runs),
            "width": runs[0]["width"], "height": runs[0]["height"],
            "rays": runs[0]["rays"], "primary_rays": runs[0]["primary_rays"],
            "median_build_seconds": statistics.median(r["build_seconds"] for r in runs),
            "median_render_seconds": statistics.median(r["render_seconds"] for r in runs),
            # Contention on a shared machine only slows a run: the fastest is the steadier figure
            # where the medians of a few runs drift.
            "min_render_seconds": min(r["render_seconds"] for r in runs),
            "median_rays_per_second": statistics.median(r["rays_per_second"] for r in runs),
            "median_samples_per_second": statistics.median(
                r.get("samples", 0) / r["render_seconds"] for r in runs),
        })
        if all("cone" in r for r in runs):
            # Thread time per cone of each kind (the traversal's own clock), in microseconds.
            out[-1]["median_microseconds_per_cone"] = {
                kind: statistics.median(
                    1e6 * r["cone"][kind + "_traversal_thread_seconds"]
                    / max(1, r["cone"][kind]["cones"]) for r in runs)
                for kind in ("primary", "secondary", "shadow")}
    return out


def gnu_time_fields(log):
    """Wall time and maximum resident set of a `/usr/bin/time -v` report, when there is one."""
    out = {}
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", log)
    if wall:
        seconds = 0.0
        for part in wall.group(1).split(":"):
            seconds = 60.0 * seconds + float(part)
        out["time_wall_seconds"] = seconds
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", log)
    if rss:
        out["max_rss_mb"] = int(rss.group(1)) * 1024 / 1e6
    return out


def summary_fields(log):
    """What mrt-preprocess's summary (its first lines on stderr) says, as far as it says it:
    "N triangles" or "N unique / M instanced triangles", times, peak memory, nodes, points."""
    lines = log.splitlines()
    start = next((i for i, l in enumerate(lines) if l.startswith("mrt-preprocess: ")
                  and "peak memory" in l), None)
    if start is None:
        return {}
    summary = "\n".join(lines[start:start + 2])
    out = {}
    for key, pattern in (("unique_triangles", r"(\d+) unique / \d+ instanced triangles"),
                         ("instanced_triangles", r"(\d+) instanced triangles"),
                         ("triangles", r"(\d+) triangles"), ("nodes", r"(\d+) nodes"),
                         ("points", r"(\d+) points"), ("load_seconds", r"load ([\d.]+) s"),
                         ("build_seconds", r"build ([\d.]+) s"),
                         ("write_seconds", r"quantize\+write ([\d.]+) s"),
                         ("peak_memory_mb", r"peak memory ([\d.]+) MB")):
        match = re.search(pattern, summary)
        if match:
            out[key] = float(match.group(1)) if "." in match.group(1) else int(match.group(1))
    return out


def preprocessing(work):
    groups = {}
    for path in sorted(glob.glob(os.path.join(work, "preprocess-*.json"))):
        with open(path) as f:
            run = json.load(f)
        with open(path[:-len(".json")] + ".log") as f:
            log = f.read()
        run.update(summary_fields(log))
        run.update(gnu_time_fields(log))
        groups.setdefault(run["scene"], []).append(run)
    out = []
    for scene, runs in sorted(groups.items()):
        entry = {"scene": scene, "threads": runs[0]["threads"], "runs": len(runs)}
        for key in ("unique_triangles", "instanced_triangles", "triangles", "nodes", "points"):
            if key in runs[0]:
                entry[key] = runs[0][key]
        entry["file_mb"] = runs[0]["file_bytes"] / 1e6
        entry["median_wall_seconds"] = statistics.median(r["wall_seconds"] for r in runs)
        entry["wall_seconds"] = [r["wall_seconds"] for r in runs]
        if all("max_rss_mb" in r for r in runs):
            entry["median_peak_memory_mb"] = statistics.median(r["max_rss_mb"] for r in runs)
            entry["peak_memory_from"] = "/usr/bin/time -v (maximum resident set)"
        elif all("peak_memory_mb" in r for r in runs):
            entry["median_peak_memory_mb"] = statistics.median(r["peak_memory_mb"] for r in runs)
            entry["peak_memory_from"] = "mrt-preprocess summary"
        for key in ("load_seconds", "build_seconds", "write_seconds"):
            if all(key in r for r in runs):
                entry["median_" + key] = statistics.median(r[key] for r in runs)
        out.append(entry)
    return out


def main():
    work = sys.argv[1]
    report = {}
    kernel_files = [os.path.join(work, name)
                    for name in ("kernels.json", "kernels-cone-block.json")
                    if os.path.isfile(os.path.join(work, name))]
    if kernel_files:
        report.update(kernels(kernel_files))
    for key, prefix in (("whitted_renders", "render"), ("distributed_renders", "distributed")):
        if glob.glob(os.path.join(work, prefix + "-*.json")):
            report[key] = renders(work, prefix)
    carried = {r["scene"]: r for r in renders(work, "differentials")}
    if "always" in carried and "when-read" in carried:
        report["differentials_overhead"] = {
            "scene": "desk", "spp": 4, "texture_filter": "none",
            "median_render_seconds_when_read": carried["when-read"]["median_render_seconds"],
            "median_render_seconds_always": carried["always"]["median_render_seconds"],
            "ratio": carried["always"]["median_render_seconds"]
            / carried["when-read"]["median_render_seconds"],
        }
    cone = {r["scene"]: r for r in renders(work, "cone_cone")}
    cone_whitted = {r["scene"]: r for r in renders(work, "cone_whitted")}
    if cone:
        report["cone_over_whitted"] = [{
            "scene": scene, "width": cone[scene]["width"], "height": cone[scene]["height"],
            "threads": cone[scene]["threads"], "runs": cone[scene]["runs"],
            "median_render_seconds_cone": cone[scene]["median_render_seconds"],
            "median_render_seconds_whitted": cone_whitted[scene]["median_render_seconds"],
            "ratio": cone[scene]["median_render_seconds"]
            / cone_whitted[scene]["median_render_seconds"],
            "min_render_seconds_cone": cone[scene]["min_render_seconds"],
            "min_render_seconds_whitted": cone_whitted[scene]["min_render_seconds"],
            "ratio_of_minima": cone[scene]["min_render_seconds"]
            / cone_whitted[scene]["min_render_seconds"],
            "median_microseconds_per_cone": cone[scene].get("median_microseconds_per_cone"),
            "paper_ratio": 4.0,
        } for scene in sorted(cone) if scene in cone_whitted]
    alpha = {r["scene"]: r for r in renders(work, "cone_alpha")}
    if alpha:
        # The budget for coverage masks: at most 1.3x the alpha A-buffer's time.
        report["cone_masks_over_alpha"] = [{
            "scene": scene, "width": cone[scene]["width"], "height": cone[scene]["height"],
            "runs": cone[scene]["runs"],
            "median_render_seconds_mask": cone[scene]["median_render_seconds"],
            "median_render_seconds_alpha": alpha[scene]["median_render_seconds"],
            "ratio": cone[scene]["median_render_seconds"] / alpha[scene]["median_render_seconds"],
            "ratio_of_minima": cone[scene]["min_render_seconds"]
            / alpha[scene]["min_render_seconds"],
        } for scene in sorted(alpha) if scene in cone]
    if glob.glob(os.path.join(work, "preprocess-*.json")):
        report["preprocessing"] = preprocessing(work)
        report["paper_preprocessing"] = PAPER_PREPROCESSING
    if os.path.isfile(os.path.join(work, "instances.json")):
        with open(os.path.join(work, "instances.json")) as f:
            report["preprocessing_against_instances"] = json.load(f)
    text = json.dumps(report, indent=2)
    print(text)
    if len(sys.argv) > 2 and sys.argv[2]:
        with open(sys.argv[2], "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
