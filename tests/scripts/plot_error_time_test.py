#!/usr/bin/env python3
"""Tests of scripts/plot_error_time.py and scripts/results_report.py on synthetic results.json
files whose curves are known power laws, so every interpolated figure has a closed form."""

import importlib.util
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest

SOURCE_DIR = os.environ.get("MRT_SOURCE_DIR",
                            os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
PLOT = os.path.join(SOURCE_DIR, "scripts", "plot_error_time.py")
REPORT = os.path.join(SOURCE_DIR, "scripts", "results_report.py")

sys.path.insert(0, os.path.join(SOURCE_DIR, "scripts"))
import plot_error_time as pet  # noqa: E402

REL = 1e-6


def run_entry(method, spec, seconds, rmse, index):
    """One run as mrt-compare writes it; PSNR with peak 1, SSIM a stand-in."""
    return {"method": method, "spec": spec, "render_seconds": seconds,
            "total_seconds": seconds + 0.1, "rays": int(1e6 * seconds),
            "samples": int(2e5 * seconds), "rmse": rmse, "psnr": -20 * math.log10(rmse),
            "ssim": 1 - rmse, "image": f"{index:02d}-{method}.png",
            "error_image": f"{index:02d}-{method}-error.png"}


def results_json(runs, std_error=0.0012):
    return {"scene": "data/scenes/two-spheres.json", "width": 512, "height": 384,
            "filter": "box",
            "reference": {"spp": 1024, "seconds": 41.2, "std_error": std_error,
                          "image": "reference.exr"},
            "runs": [run_entry(*r, i + 1) for i, r in enumerate(runs)]}


# Three methods with closed-form curves:
#   whitted      rmse = 0.2·t^-1/4 at t = 0.25, 1
#   distributed  rmse = 0.1·t^-1/2 at t = 1, 4, 16, plus a dominated run (t = 8, rmse 0.06)
#   cone         one run, t = 0.5, rmse 0.04 (the baseline)
CONE_SCENARIO = [
    ("whitted", "whitted:spp=4", 0.25, 0.2 * 0.25 ** -0.25),
    ("whitted", "whitted:spp=16", 1.0, 0.2),
    ("distributed", "distributed:spp-max=16", 1.0, 0.1),
    ("distributed", "distributed:spp-max=64", 4.0, 0.05),
    ("distributed", "distributed:spp-max=256", 16.0, 0.025),
    ("distributed", "distributed:spp-max=999", 8.0, 0.06),
    ("cone", "cone", 0.5, 0.04),
]

# No cone run:  whitted rmse = 0.4·t^-1/2 at t = 1, 4, 16, 64;  distributed as above.
WHITTED_SCENARIO = [
    ("distributed", "distributed:spp-max=16", 1.0, 0.1),
    ("distributed", "distributed:spp-max=64", 4.0, 0.05),
    ("distributed", "distributed:spp-max=256", 16.0, 0.025),
    ("whitted", "whitted:spp=64", 64.0, 0.05),
    ("whitted", "whitted:spp=16", 16.0, 0.1),
    ("whitted", "whitted:spp=4", 4.0, 0.2),
    ("whitted", "whitted:spp=1", 1.0, 0.4),
]


def write_dir(tmp, name, data):
    path = os.path.join(tmp, name)
    os.makedirs(path, exist_ok=True)
    with open(os.path.join(path, "results.json"), "w") as f:
        if isinstance(data, str):
            f.write(data)
        else:
            json.dump(data, f)
    return path


def run_script(script, *args):
    return subprocess.run([sys.executable, script, *args], capture_output=True, text=True,
                          timeout=60, env=dict(os.environ, MPLBACKEND="Agg"))


def load(tmp, name, runs):
    return pet.load_results(os.path.join(write_dir(tmp, name, results_json(runs)),
                                         "results.json"))


class Interpolation(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.results = load(cls.tmp.name, "cone", CONE_SCENARIO)
        cls.curves = pet.build_curves(cls.results, "rmse", "render_seconds")

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_time_to_error_follows_the_power_law_between_runs(self):
        # 0.1·t^-1/2 = 0.03  ⇔  t = (0.1/0.03)² = 100/9
        self.assertAlmostEqual(self.curves["distributed"].time_to(0.03) / (100 / 9), 1, delta=REL)

    def test_time_to_error_at_a_run_is_its_time(self):
        self.assertAlmostEqual(self.curves["distributed"].time_to(0.05), 4.0, delta=4 * REL)
        self.assertEqual(self.curves["cone"].time_to(0.04), 0.5)

    def test_error_at_time_follows_the_power_law_between_runs(self):
        self.assertAlmostEqual(self.curves["distributed"].value_at(2.0) / (0.1 / math.sqrt(2)),
                               1, delta=REL)
        self.assertAlmostEqual(self.curves["whitted"].value_at(0.5) / (0.2 * 0.5 ** -0.25), 1,
                               delta=REL)

    def test_dominated_run_is_ignored(self):
        # The run at t = 8 has rmse 0.06 > 0.05 at t = 4: the curve passes 0.1/√8 there.
        distributed = self.curves["distributed"]
        self.assertEqual([r.spec for r in distributed.dominated], ["distributed:spp-max=999"])
        self.assertAlmostEqual(distributed.value_at(8.0) / (0.1 / math.sqrt(8)), 1, delta=REL)

    def test_interpolation_is_linear_in_log_time_and_log_error(self):
        # Runs (1 s, 0.08) and (3 s, 0.02): 0.04 is halfway in log error, so t = √3.
        results = load(self.tmp.name, "two", [("distributed", "d:spp=2", 1.0, 0.08),
                                              ("distributed", "d:spp=8", 3.0, 0.02)])
        curve = pet.build_curves(results, "rmse", "render_seconds")["distributed"]
        self.assertAlmostEqual(curve.time_to(0.04) / math.sqrt(3), 1, delta=REL)
        # And halfway in log time, t = √3, the error is √(0.08·0.02) = 0.04.
        self.assertAlmostEqual(curve.value_at(math.sqrt(3)) / 0.04, 1, delta=REL)

    def test_options_that_change_the_computation_make_their_own_curve(self):
        with tempfile.TemporaryDirectory() as tmp:
            results = load(tmp, "filters", [
                ("whitted", "whitted:texture-filter=none", 1.0, 0.2),
                ("whitted", "whitted:texture-filter=none,spp=4", 4.0, 0.1),
                ("whitted", "whitted:spp=4,texture-filter=trilinear", 4.0, 0.08),
                ("whitted", "whitted", 1.0, 0.05),
                ("distributed", "distributed:time-budget=2,texture-filter=none", 2.0, 0.1),
                ("distributed", "distributed:spp-max=16,spp-initial=4", 3.0, 0.1),
            ])
            self.assertEqual([r.curve for r in results.runs], [
                "whitted (texture-filter=none)", "whitted (texture-filter=none)",
                "whitted (texture-filter=trilinear)", "whitted",
                "distributed (time budget, texture-filter=none)", "distributed"])
            curves = pet.build_curves(results, "rmse", "render_seconds")
            self.assertEqual(len(curves["whitted (texture-filter=none)"].times()), 2)

    def test_no_extrapolation_outside_the_runs(self):
        distributed, cone = self.curves["distributed"], self.curves["cone"]
        self.assertIsNone(distributed.time_to(0.02))  # better than its best run (0.025)
        self.assertIsNone(distributed.time_to(0.2))  # worse than its fastest run (0.1)
        self.assertIsNone(distributed.value_at(0.5))
        self.assertIsNone(distributed.value_at(20.0))
        self.assertIsNone(cone.time_to(0.041))
        self.assertIsNone(cone.value_at(0.6))

    def test_psnr_curve_is_the_rmse_curve(self):
        # PSNR = -20·log10(rmse) is linear in log rmse, so both interpolations agree.
        psnr = pet.build_curves(self.results, "psnr", "render_seconds")["distributed"]
        self.assertAlmostEqual(psnr.value_at(2.0), -20 * math.log10(0.1 / math.sqrt(2)),
                               delta=1e-9)
        self.assertAlmostEqual(psnr.time_to(-20 * math.log10(0.03)) / (100 / 9), 1, delta=REL)


class Derived(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.cone = pet.derive(load(cls.tmp.name, "cone", CONE_SCENARIO))
        cls.whitted = pet.derive(load(cls.tmp.name, "whitted", WHITTED_SCENARIO))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_baseline_is_the_first_cone_run(self):
        self.assertEqual(self.cone["baseline"]["spec"], "cone")
        self.assertEqual(self.cone["baseline"]["seconds"], 0.5)
        self.assertEqual(self.cone["baseline"]["rmse"], 0.04)

    def test_baseline_without_cone_is_the_fastest_whitted_run(self):
        self.assertEqual(self.whitted["baseline"]["spec"], "whitted:spp=1")

    def test_levels_are_the_baseline_and_the_fixed_levels_in_range(self):
        # Curves span [0.025, 0.283]: of 0.05, 0.02, 0.01, 0.005 only 0.05 lies inside.
        self.assertEqual(self.cone["levels"], [0.05, 0.04])
        self.assertEqual(set(self.cone["time_to_error"]["distributed"]), {"0.05", "0.04"})

    def test_time_to_error(self):
        t = self.cone["time_to_error"]
        self.assertAlmostEqual(t["distributed"]["0.04"] / 6.25, 1, delta=REL)  # (0.1/0.04)²
        self.assertAlmostEqual(t["distributed"]["0.05"] / 4.0, 1, delta=REL)
        self.assertEqual(t["cone"]["0.04"], 0.5)
        self.assertIsNone(t["cone"]["0.05"])
        self.assertIsNone(t["whitted"]["0.04"])

    def test_equal_time(self):
        e = self.cone["equal_time"]
        self.assertAlmostEqual(e["whitted"] / (0.2 * 0.5 ** -0.25), 1, delta=REL)
        self.assertIsNone(e["distributed"])
        self.assertEqual(e["cone"], 0.04)
        ratio = self.cone["error_ratio_at_equal_time"]["whitted"]
        self.assertAlmostEqual(ratio / (0.2 * 0.5 ** -0.25 / 0.04), 1, delta=REL)

    def test_speedup_at_equal_error(self):
        (s,) = self.cone["speedup_at_equal_error"]
        self.assertEqual((s["faster"], s["slower"], s["error"]), ("cone", "distributed", 0.04))
        self.assertAlmostEqual(s["speedup"] / 12.5, 1, delta=REL)  # 6.25 s / 0.5 s
        # Whitted needs (0.4/0.05)² = 64 s for RMSE 0.05, distributed (0.1/0.05)² = 4 s.
        (s,) = self.whitted["speedup_at_equal_error"]
        self.assertEqual((s["faster"], s["slower"], s["error"]), ("distributed", "whitted", 0.05))
        self.assertAlmostEqual(s["speedup"] / 16, 1, delta=REL)
        self.assertAlmostEqual(self.whitted["equal_time"]["distributed"] / 0.1, 1, delta=REL)

    def test_three_significant_digits(self):
        self.assertEqual([pet.fmt3(x) for x in (0.0412345, 41.23, 1234, 999.7, 0.91, 12.5, None)],
                         ["0.0412", "41.2", "1230", "1000", "0.910", "12.5", "—"])


class CommandLine(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.dir = write_dir(cls.tmp.name, "cone", results_json(CONE_SCENARIO))
        cls.plot = run_script(PLOT, cls.dir)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def assert_png(self, path):
        with open(path, "rb") as f:
            self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")

    def test_writes_the_plot_and_derived_json(self):
        self.assertEqual(self.plot.returncode, 0, self.plot.stderr)
        self.assert_png(os.path.join(self.dir, "error_time.png"))
        with open(os.path.join(self.dir, "derived.json")) as f:
            derived = json.load(f)
        self.assertEqual(derived["baseline"]["method"], "cone")
        self.assertAlmostEqual(derived["time_to_error"]["distributed"]["0.04"] / 6.25, 1,
                               delta=REL)
        self.assertIsNone(derived["equal_time"]["distributed"])
        self.assertIn("12.5×", self.plot.stdout)

    def test_psnr_plot_to_a_named_file(self):
        d = write_dir(self.tmp.name, "psnr", results_json(WHITTED_SCENARIO))
        out = os.path.join(self.tmp.name, "psnr.png")
        result = run_script(PLOT, d, "--metric", "psnr", "--output", out, "--quiet")
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertEqual(result.stdout, "")
        self.assert_png(out)
        self.assertTrue(os.path.exists(os.path.join(d, "derived.json")))

    def test_a_single_run_is_a_plot_of_one_point(self):
        d = write_dir(self.tmp.name, "single",
                      results_json([("whitted", "whitted", 0.2, 0.04)], std_error=None))
        result = run_script(PLOT, d, "--quiet")
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(os.path.join(d, "derived.json")) as f:
            derived = json.load(f)
        self.assertEqual(derived["time_to_error"], {"whitted": {"0.04": 0.2}})
        self.assertEqual(derived["speedup_at_equal_error"], [])

    def assert_fails_in_one_line(self, name, data, expected, *args):
        d = write_dir(self.tmp.name, name, data)
        result = run_script(PLOT, d, *args)
        self.assertEqual(result.returncode, 1, result.stderr)
        self.assertNotIn("Traceback", result.stderr)
        self.assertEqual(len(result.stderr.strip().splitlines()), 1, result.stderr)
        self.assertIn(expected, result.stderr)
        self.assertFalse(os.path.exists(os.path.join(d, "derived.json")))

    def test_malformed_results_fail_with_one_line(self):
        good = results_json(CONE_SCENARIO)

        def edited(edit):
            data = json.loads(json.dumps(good))
            edit(data)
            return data

        cases = {
            "not-json": ('{"runs": [', "not valid JSON"),
            "missing-key": (edited(lambda d: d["runs"][1].pop("rmse")), "/runs/1/rmse: missing"),
            "zero-time": (edited(lambda d: d["runs"][2].update(render_seconds=0)),
                          "/runs/2/render_seconds"),
            "negative-time": (edited(lambda d: d["runs"][0].update(render_seconds=-1.5)),
                              "/runs/0/render_seconds"),
            "zero-rmse": (edited(lambda d: d["runs"][3].update(rmse=0, psnr=None)),
                          "/runs/3/rmse: is 0"),
            "no-runs": (edited(lambda d: d.update(runs=[])), "/runs"),
            "no-reference": (edited(lambda d: d.pop("reference")), "/reference: missing"),
            "string-width": (edited(lambda d: d.update(width="512")), "/width"),
        }
        for name, (data, expected) in cases.items():
            with self.subTest(name):
                self.assert_fails_in_one_line(name, data, expected)
        with self.subTest("null-psnr"):
            self.assert_fails_in_one_line(
                "null-psnr", edited(lambda d: d["runs"][4].update(psnr=None)), "/runs/4/psnr",
                "--metric", "psnr")

    def test_missing_directory_fails_with_one_line(self):
        result = run_script(PLOT, os.path.join(self.tmp.name, "absent"))
        self.assertEqual(result.returncode, 1)
        self.assertEqual(len(result.stderr.strip().splitlines()), 1, result.stderr)
        self.assertIn("no such file", result.stderr)

    def test_report_has_the_run_table_and_derived_figures(self):
        self.assertEqual(self.plot.returncode, 0, self.plot.stderr)
        markdown = os.path.join(self.tmp.name, "docs", "results.md")
        os.makedirs(os.path.dirname(markdown), exist_ok=True)
        result = run_script(REPORT, self.dir, markdown, "--command", "scripts/compare out/cmp",
                            "--image-dir", "images")
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(markdown) as f:
            text = f.read()
        for row in [
            "| method | spec | render s | total s | rays | RMSE | display RMSE | PSNR dB | SSIM |",
            # The fixture is an older results.json without display RMSE: shown as unknown.
            "| whitted | `whitted:spp=16` | 1.00 | 1.10 | 1.00 M | 0.200 | — | 14.0 | 0.800 |",
            "| distributed | `distributed:spp-max=64` | 4.00 | 4.10 | 4.00 M | 0.0500 | — | 26.0 "
            "| 0.950 |",
            "| cone | `cone` | 0.500 | 0.600 | 500 k | 0.0400 | — | 28.0 | 0.960 |",
            "| distributed | 4.00 | 6.25 |",
            "| cone | distributed | 0.0400 | 12.5× | 0.500 s | 6.25 s |",
            "`scripts/compare out/cmp`",
            "](images/error_time.png)",
            "](images/montage.png)",
            "512×384 pixels, box pixel filter",
            "1024 samples per pixel, 41.2 s, standard error 0.00120",
        ]:
            self.assertIn(row, text)

    def test_report_without_derived_json_fails_with_one_line(self):
        d = write_dir(self.tmp.name, "underived", results_json(CONE_SCENARIO))
        result = run_script(REPORT, d, os.path.join(self.tmp.name, "r.md"))
        self.assertEqual(result.returncode, 1)
        self.assertEqual(len(result.stderr.strip().splitlines()), 1, result.stderr)
        self.assertIn("derived.json", result.stderr)


if __name__ == "__main__":
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(f"plot_error_time_test: {sys.executable} has no matplotlib; run scripts/setup "
                 "(Debian's python3-matplotlib) or point CMake at that Python with "
                 "-DPython3_EXECUTABLE=/usr/bin/python3")
    unittest.main()
