#!/usr/bin/env python3
"""Tests of the package scripts/mrtrace (run with scripts/ on PYTHONPATH, as ctest does): it
reads mrt-compare's results.json, checks it, draws the plot and writes the pages, printing the
figures mrt-compare computed (tests/trace/compare/ checks those) and computing none. The fixture
is a results.json written by hand: three methods and the derived figures for them."""

import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import unittest

from mrtrace import crops, page, results as mr


def run_entry(method, spec, seconds, rmse, index):
    """One run as mrt-compare writes it; PSNR with peak 1, SSIM a stand-in."""
    import math

    return {"method": method, "spec": spec, "render_seconds": seconds,
            "total_seconds": seconds + 0.1, "rays": int(1e6 * seconds),
            "samples": int(2e5 * seconds), "rmse": rmse, "psnr": -20 * math.log10(rmse),
            "ssim": 1 - rmse, "display_rmse": rmse / 2, "image": f"{index:02d}-{method}.png",
            "error_image": f"{index:02d}-{method}-error.png"}


# whitted RMSE 0.2·t^-1/4, distributed 0.1·t^-1/2 (and a dominated run), cone one run.
RUNS = [
    ("whitted", "whitted:spp=4", 0.25, 0.2 * 0.25 ** -0.25),
    ("whitted", "whitted:spp=16", 1.0, 0.2),
    ("distributed", "distributed:spp-max=16", 1.0, 0.1),
    ("distributed", "distributed:spp-max=64", 4.0, 0.05),
    ("distributed", "distributed:spp-max=256", 16.0, 0.025),
    ("distributed", "distributed:spp-max=999", 8.0, 0.06),
    ("cone", "cone", 0.5, 0.04),
]

# What mrt-compare writes for RUNS (trace/results/derived_figures.h).
DERIVED = {
    "time": "render_seconds",
    "baseline": {"run": 6, "method": "cone", "curve": "cone", "spec": "cone", "seconds": 0.5,
                 "rmse": 0.04, "chosen_as": "first cone run"},
    "levels": [0.05, 0.04],
    "curves": [{"label": "whitted", "runs": [0, 1], "dominated": []},
               {"label": "distributed", "runs": [2, 3, 4], "dominated": [5]},
               {"label": "cone", "runs": [6], "dominated": []}],
    "time_to_error": {
        "whitted": [{"seconds": 1.0, "relation": "at least", "how": "no run reaches it"},
                    {"seconds": 1.0, "relation": "at least", "how": "no run reaches it"}],
        "distributed": [{"seconds": 4.0, "relation": "equal", "how": "measured"},
                        {"seconds": 6.25, "relation": "equal",
                         "how": "interpolated between two runs"}],
        "cone": [{"seconds": 0.5, "relation": "at most",
                  "how": "even its fastest run is more accurate"},
                 {"seconds": 0.5, "relation": "equal", "how": "measured"}]},
    "equal_time": {"whitted": 0.2 * 0.5 ** -0.25, "distributed": None, "cone": 0.04},
    "error_ratio_at_equal_time": {"whitted": 0.2 * 0.5 ** -0.25 / 0.04, "distributed": None,
                                  "cone": 1.0},
    "speedup_at_equal_error": [{"faster": "cone", "slower": "distributed", "error": 0.04,
                                "speedup": 12.5, "faster_seconds": 0.5, "slower_seconds": 6.25}],
    "dominated_runs": [{"method": "distributed", "spec": "distributed:spp-max=999"}],
}


def results_json():
    return {"scene": "data/scenes/two-spheres.json", "width": 512, "height": 384,
            "filter": "box",
            "reference": {"spp": 1024, "seconds": 41.2, "std_error": 0.0012,
                          "image": "reference.exr"},
            "runs": [run_entry(*r, i + 1) for i, r in enumerate(RUNS)],
            "headline": {"cone_over_whitted": {
                "value": 2.0, "relation": "equal", "numerator": "cone",
                "denominator": "whitted:spp=4", "numerator_value": 0.5,
                "denominator_value": 0.25, "how": "measured"}},
            "derived": json.loads(json.dumps(DERIVED))}


def write_dir(tmp, name, data):
    path = os.path.join(tmp, name)
    os.makedirs(path, exist_ok=True)
    with open(os.path.join(path, "results.json"), "w") as f:
        if isinstance(data, str):
            f.write(data)
        else:
            json.dump(data, f)
    return path


def run_module(module, *args):
    return subprocess.run([sys.executable, "-m", f"mrtrace.{module}", *args],
                          capture_output=True, text=True, timeout=60,
                          env=dict(os.environ, MPLBACKEND="Agg"))


class Pages(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.dir = write_dir(cls.tmp.name, "cone", results_json())
        cls.plot = run_module("plot", cls.dir)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def assert_png(self, path):
        with open(path, "rb") as f:
            self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")

    def test_writes_the_plot(self):
        self.assertEqual(self.plot.returncode, 0, self.plot.stderr)
        self.assert_png(os.path.join(self.dir, "error_time.png"))

    def test_psnr_plot_to_a_named_file(self):
        out = os.path.join(self.tmp.name, "psnr.png")
        result = run_module("plot", self.dir, "--metric", "psnr", "--output", out)
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assert_png(out)

    def test_the_page_prints_mrt_compares_figures(self):
        text = page.report(mr.load_results(os.path.join(self.dir, "results.json")), "images",
                           "error_time.png", "montage.png", "Two spheres", "../results.md")
        for row in [
            "# Two spheres",
            "](../results.md)",
            "| method | spec | render s | total s | rays | RMSE | display RMSE | PSNR dB | SSIM |",
            "| whitted | `whitted:spp=16` | 1.00 | 1.10 | 1.00 M | 0.200 | 0.100 | 14.0 | 0.800 |",
            "| cone | `cone` | 0.500 | 0.600 | 500 k | 0.0400 | 0.0200 | 28.0 | 0.960 |",
            "Dominated runs, left out of the curves: `distributed:spp-max=999`.",
            "| cone time ÷ whitted time | 2.00× |",
            "The baseline is `cone` (first cone run): 0.500 s, RMSE 0.0400.",
            "| whitted | 0.238 | 5.95 |",  # 0.2·0.5^-1/4 and its ratio to 0.04
            "| distributed | — | — |",
            "| method | RMSE 0.0500 | RMSE 0.0400 (baseline) |",
            "| whitted | ≥ 1.00 | ≥ 1.00 |",
            "| distributed | 4.00 | 6.25 |",
            "| cone | ≤ 0.500 | 0.500 |",
            "| cone | distributed | 0.0400 | 12.5× | 0.500 s | 6.25 s |",
            "At the baseline's RMSE of 0.0400, cone is 12.5× faster than distributed.",
            "](images/error_time.png)",
            "](images/montage.png)",
            "512×384 pixels, box pixel filter",
            "1024 samples per pixel, 41.2 s, standard error 0.00120",
        ]:
            self.assertIn(row, text)

    def test_the_page_command_writes_its_notes(self):
        notes = os.path.join(self.tmp.name, "notes.md")
        with open(notes, "w") as f:
            f.write("The cone is biased.\n")
        markdown = os.path.join(self.tmp.name, "docs", "results", "two-spheres.md")
        os.makedirs(os.path.dirname(markdown), exist_ok=True)
        result = run_module("page", self.dir, markdown, "--notes", notes, "--image-dir", ".")
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(markdown) as f:
            text = f.read()
        self.assertIn("## Reading the results\n\nThe cone is biased.\n", text)
        self.assertIn("which does not exist (yet)", result.stderr)  # the plot is elsewhere

    def test_the_index_links_every_page(self):
        markdown = os.path.join(self.tmp.name, "results.md")
        table1 = os.path.join(self.tmp.name, "table1.md")
        with open(table1, "w") as f:
            f.write("# Table 1: preprocessing time and memory\n\n| scene |\n")
        result = run_module("index", markdown, "--command", "scripts/reproduce",
                            "--pages-dir", "results", "--scene", f"two-spheres={self.dir}=Two",
                            "--table1", table1, "--discussion", "results/discussion.md")
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(markdown) as f:
            text = f.read()
        self.assertTrue(text.startswith("# The papers' experiments, reproduced\n"))
        self.assertIn("| ratio | [two-spheres](results/two-spheres.md) | paper |", text)
        self.assertIn("| cone time ÷ whitted time | 2.00× | ≈ 4 |", text)
        self.assertIn("- [Two](results/two-spheres.md)", text)
        self.assertIn("](results/discussion.md)", text)
        self.assertIn("\n## Table 1: preprocessing time and memory\n", text)
        self.assertEqual(text.count("## Reading the pages"), 1)

    def assert_fails_in_one_line(self, name, data, expected, module="plot", *args):
        d = write_dir(self.tmp.name, name, data)
        result = run_module(module, d, *args)
        self.assertEqual(result.returncode, 1, result.stderr)
        self.assertNotIn("Traceback", result.stderr)
        self.assertEqual(len(result.stderr.strip().splitlines()), 1, result.stderr)
        self.assertIn(expected, result.stderr)

    def test_malformed_results_fail_with_one_line(self):
        def edited(edit):
            data = results_json()
            edit(data)
            return data

        cases = {
            "not-json": ('{"runs": [', "not valid JSON"),
            "missing-key": (edited(lambda d: d["runs"][1].pop("rmse")), "/runs/1/rmse: missing"),
            "zero-time": (edited(lambda d: d["runs"][2].update(render_seconds=0)),
                          "/runs/2/render_seconds"),
            "zero-rmse": (edited(lambda d: d["runs"][3].update(rmse=0, psnr=None)),
                          "/runs/3/rmse: is 0"),
            "no-runs": (edited(lambda d: d.update(runs=[])), "/runs"),
            "no-reference": (edited(lambda d: d.pop("reference")), "/reference: missing"),
            "string-width": (edited(lambda d: d.update(width="512")), "/width"),
            "no-derived": (edited(lambda d: d.pop("derived")), "/derived: missing"),
            "null-derived": (edited(lambda d: d.update(derived=None)), "/derived: is null"),
            "curve-run": (edited(lambda d: d["derived"]["curves"][0].update(runs=[0, 9])),
                          "/derived/curves/0/runs: expected indices of runs"),
            "level-count": (edited(lambda d: d["derived"]["time_to_error"]["cone"].pop()),
                            "/derived/time_to_error/cone: expected one entry per level"),
            "equal-time-curves": (edited(lambda d: d["derived"]["equal_time"].pop("cone")),
                                  "/derived/equal_time: expected one entry per curve"),
            "speedup-curve": (edited(lambda d: d["derived"]["speedup_at_equal_error"][0].update(
                faster="path")), "/derived/speedup_at_equal_error/0/faster"),
        }
        for name, (data, expected) in cases.items():
            with self.subTest(name):
                self.assert_fails_in_one_line(name, data, expected)
        with self.subTest("null-psnr"):
            self.assert_fails_in_one_line(
                "null-psnr", edited(lambda d: d["runs"][4].update(psnr=None)), "/runs/4/psnr",
                "plot", "--metric", "psnr")
        with self.subTest("page"):
            self.assert_fails_in_one_line("page", edited(lambda d: d.pop("derived")),
                                          "/derived: missing", "page",
                                          os.path.join(self.tmp.name, "x.md"))

    def test_missing_directory_fails_with_one_line(self):
        result = run_module("plot", os.path.join(self.tmp.name, "absent"))
        self.assertEqual(result.returncode, 1)
        self.assertEqual(len(result.stderr.strip().splitlines()), 1, result.stderr)
        self.assertIn("no such file", result.stderr)

    def test_three_significant_digits(self):
        self.assertEqual([mr.fmt3(x) for x in (0.0412345, 41.23, 1234, 999.7, 0.91, 12.5, None)],
                         ["0.0412", "41.2", "1230", "1000", "0.910", "12.5", "—"])

    def test_the_crops_equal_time_column_is_the_named_run_or_the_nearest_budget_run(self):
        # On a busy machine the budget runs' times scatter, cone's time falls between two of
        # them and the headline interpolates, naming no run: the crops take the nearer one.
        runs = [{"spec": "cone", "render_seconds": 2.0},
                {"spec": "distributed:time-budget=1", "render_seconds": 1.1},
                {"spec": "distributed:time-budget=2", "render_seconds": 2.9},
                {"spec": "whitted", "render_seconds": 1.9}]
        named = {"distributed_rmse_at_cone_time": {"numerator": "distributed:time-budget=1",
                                                   "denominator": "cone"}}
        self.assertEqual(crops.equal_time_spec({"runs": runs, "headline": named}),
                         "distributed:time-budget=1")
        interpolated = {"distributed_rmse_at_cone_time": {"numerator": "", "denominator": "cone"}}
        self.assertEqual(crops.equal_time_spec({"runs": runs, "headline": interpolated}),
                         "distributed:time-budget=2")  # log(2.9/2) < log(2/1.1)
        self.assertIsNone(crops.equal_time_spec({"runs": runs, "headline": {}}))
        self.assertIsNone(crops.equal_time_spec({"runs": runs[:1], "headline": interpolated}))


if __name__ == "__main__":
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(f"mrtrace_test: {sys.executable} has no matplotlib; run scripts/setup "
                 "(Debian's python3-matplotlib) or point CMake at that Python with "
                 "-DPython3_EXECUTABLE=/usr/bin/python3")
    unittest.main()
