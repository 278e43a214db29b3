#!/usr/bin/env python3
"""Checks the pages scripts/reproduce --quick wrote for the default scene (ctest runs it after
reproduce_quick, whose directory it is given, with scripts/ on PYTHONPATH): the headline summary
opens the index with a value for every ratio, the index links the scene's page and the
discussion, the scene page prints mrt-compare's derived figures, every image a page links
exists, and the discussion's crop figure is an image of its regions. Also the helpers' own
failures: a malformed region, a missing run, a directory without results."""

import json
import os
import re
import subprocess
import sys
import tempfile
import unittest

from mrtrace import headline

PAGE_DIR = os.environ.get("MRT_REPRODUCE_DIR", "")

RATIO_ROWS = [what for what, _, _ in headline.RATIOS.values()]


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        raise AssertionError(f"{path}: not a PNG")
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


@unittest.skipUnless(PAGE_DIR, "MRT_REPRODUCE_DIR names the quick run's output")
class QuickPage(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        with open(os.path.join(PAGE_DIR, "results.md"), encoding="utf-8") as f:
            cls.page = f.read()
        with open(os.path.join(PAGE_DIR, "results", "two-spheres.md"), encoding="utf-8") as f:
            cls.scene_page = f.read()
        with open(os.path.join(PAGE_DIR, "results", "discussion.md"), encoding="utf-8") as f:
            cls.discussion = f.read()
        with open(os.path.join(PAGE_DIR, "work", "results", "results.json"),
                  encoding="utf-8") as f:
            cls.results = json.load(f)

    def test_the_summary_opens_the_page_with_every_ratio(self):
        self.assertTrue(self.page.startswith("# The papers' experiments, reproduced\n"))
        summary = self.page.split("\n## ", 1)[0]
        for what in RATIO_ROWS:
            row = next((line for line in summary.splitlines() if line.startswith(f"| {what} |")),
                       None)
            self.assertIsNotNone(row, what)
            cells = [c.strip() for c in row.strip("|").split("|")]
            self.assertEqual(len(cells), 3, row)  # ratio, two-spheres, paper
            self.assertRegex(cells[1], r"^(≤ |≥ )?[0-9.]+×$", row)

    def test_the_summary_is_the_comparisons_headline(self):
        ratios = self.results["headline"]
        self.assertEqual(set(ratios), set(headline.RATIOS))
        speed = ratios["cone_over_whitted"]
        seconds = {r["spec"]: r["render_seconds"] for r in self.results["runs"]}
        self.assertAlmostEqual(speed["value"], seconds["cone"] / seconds["whitted"], places=12)
        self.assertIn(f"| {headline.RATIOS['cone_over_whitted'][0]} | "
                      f"{headline.value_text(speed)} |", self.page)
        for ratio in ratios.values():
            if ratio["numerator"]:
                self.assertIn(ratio["numerator"], seconds)
            self.assertIn(ratio["denominator"], seconds)

    def test_the_index_links_the_pages_and_every_link_exists(self):
        pages = {"": self.page, "results": self.scene_page + self.discussion}
        self.assertIn("](results/two-spheres.md)", self.page)
        self.assertIn("](results/discussion.md)", self.page)
        self.assertIn("crops-two-spheres.png", self.discussion)
        for where, text in pages.items():
            for link in re.findall(r"\]\(([^)#]+\.(?:md|png|jpg))\)", text):
                self.assertTrue(os.path.isfile(os.path.join(PAGE_DIR, where, link)), link)

    def test_the_scene_page_prints_the_derived_figures(self):
        derived = self.results["derived"]
        base = derived["baseline"]
        self.assertEqual(base["spec"], "cone")
        self.assertIn(f"The baseline is `cone` ({base['chosen_as']})", self.scene_page)
        for label in derived["equal_time"]:
            self.assertIn(f"\n| {label} |", self.scene_page)
        for s in derived["speedup_at_equal_error"]:
            self.assertIn(f"| {s['faster']} | {s['slower']} |", self.scene_page)
        self.assertEqual(self.page.count("Reading the pages"), 1)
        self.assertNotIn("Reading the pages", self.scene_page)

    def test_the_crops_show_every_region_in_every_column(self):
        width, height = png_size(os.path.join(PAGE_DIR, "results", "crops-two-spheres.png"))
        # Five columns of the widest region (0.38 of a 96-pixel image), enlarged to about 480
        # screen pixels each, and both regions' rows.
        self.assertGreater(width, 5 * 400)
        self.assertGreater(height, 2 * 0.14 * 96 * 3)
        self.assertTrue(self.discussion.startswith("# Where the cone tracer is worse\n"))


class Helpers(unittest.TestCase):
    def run_script(self, name, *args):
        return subprocess.run([sys.executable, "-m", f"mrtrace.{name}", *args],
                              capture_output=True, text=True, timeout=60)

    def test_a_malformed_region_is_refused_with_what_was_expected(self):
        with tempfile.TemporaryDirectory() as d:
            run = self.run_script("crops", os.path.join(d, "x.png"), "--dir", d, "--rect",
                                  "sky:0.5,0.2,0.4,0.9", "--column", "reference")
            self.assertEqual(run.returncode, 2)
            self.assertIn("0 <= X0 < X1 <= 1", run.stderr)

    def test_a_missing_run_is_named(self):
        with tempfile.TemporaryDirectory() as d:
            with open(os.path.join(d, "results.json"), "w", encoding="utf-8") as f:
                json.dump({"reference": {"image": "reference.png"},
                           "runs": [{"spec": "whitted", "image": "01.png",
                                     "error_image": "01-error.png"}]}, f)
            run = self.run_script("crops", os.path.join(d, "x.png"), "--dir", d, "--rect",
                                  "sky:0,0,1,1", "--column", "cone")
            self.assertEqual(run.returncode, 1)
            self.assertIn("no run 'cone' (runs: whitted)", run.stderr)
            self.assertEqual(len(run.stderr.strip().splitlines()), 1, run.stderr)

    def test_headline_needs_results(self):
        with tempfile.TemporaryDirectory() as d:
            run = self.run_script("headline", f"x={d}")
            self.assertEqual(run.returncode, 1)
            self.assertIn("results.json: no such file", run.stderr)
            self.assertEqual(self.run_script("headline", "nodir").returncode, 2)


if __name__ == "__main__":
    unittest.main()
