#!/usr/bin/env python3
"""Summarises scripts/bench's raw results (Google Benchmark JSON and mrt-trace --stats files)
into one JSON document on stdout (and into a file when one is named)."""

import glob
import json
import os
import statistics
import sys


def kernels(path):
    with open(path) as f:
        data = json.load(f)
    out = {}
    for b in data["benchmarks"]:
        if b.get("aggregate_name") != "median":
            continue
        name = b["run_name"]
        entry = {"real_time_ms": b["real_time"] if b["time_unit"] == "ms" else
                 b["real_time"] / {"ns": 1e6, "us": 1e3, "s": 1e-3}[b["time_unit"]]}
        for key, value in b.items():
            if key in ("hit_fraction", "triangles", "nodes"):
                entry[key] = value
            elif key == "rays/s":
                entry["rays_per_second"] = value
        out[name] = entry
    return {"context": {k: data["context"].get(k) for k in ("num_cpus", "mhz_per_cpu",
                                                               "library_build_type")},
            "kernels": out}


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
            "median_rays_per_second": statistics.median(r["rays_per_second"] for r in runs),
            "median_samples_per_second": statistics.median(
                r.get("samples", 0) / r["render_seconds"] for r in runs),
        })
    return out


def main():
    work = sys.argv[1]
    report = kernels(os.path.join(work, "kernels.json"))
    report["whitted_renders"] = renders(work, "render")
    report["distributed_renders"] = renders(work, "distributed")
    carried = {r["scene"]: r for r in renders(work, "differentials")}
    if "always" in carried and "when-read" in carried:
        report["differentials_overhead"] = {
            "scene": "desk", "spp": 4, "texture_filter": "none",
            "median_render_seconds_when_read": carried["when-read"]["median_render_seconds"],
            "median_render_seconds_always": carried["always"]["median_render_seconds"],
            "ratio": carried["always"]["median_render_seconds"]
            / carried["when-read"]["median_render_seconds"],
        }
    text = json.dumps(report, indent=2)
    print(text)
    if len(sys.argv) > 2 and sys.argv[2]:
        with open(sys.argv[2], "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
