#!/usr/bin/env python3
"""Tests of scripts/make-field: the committed field scenes under data/scenes are exactly what
the generator writes (so data/ cannot drift from its generator), with and without --scale-up.
Their triangle counts are checked by loading them (mrt_scene_tests, SceneLoader.FieldScene*)."""

import json
import os
import subprocess
import sys
import tempfile
import unittest

SOURCE_DIR = os.environ.get("MRT_SOURCE_DIR",
                            os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
MAKE_FIELD = os.path.join(SOURCE_DIR, "scripts", "make-field")
SCENES = os.path.join(SOURCE_DIR, "data", "scenes")
OUTPUTS = {(): "field.json", ("--scale-up",): "field-100m.json"}


class MakeField(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="make-field-test-")
        cls.runs = {flags: subprocess.run([sys.executable, MAKE_FIELD, "--out", cls.tmp.name,
                                           "--quiet", *flags],
                                          capture_output=True, text=True, timeout=300)
                    for flags in OUTPUTS}

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def setUp(self):
        for run in self.runs.values():
            self.assertEqual(run.returncode, 0, run.stderr)

    def test_generator_is_quiet_with_quiet(self):
        for run in self.runs.values():
            self.assertEqual(run.stdout, "")

    def test_writes_only_the_scene_its_flags_name(self):
        self.assertEqual(sorted(os.listdir(self.tmp.name)), ["scenes"])
        self.assertEqual(sorted(os.listdir(os.path.join(self.tmp.name, "scenes"))),
                         sorted(OUTPUTS.values()))

    def test_committed_scenes_are_byte_identical_to_the_generated(self):
        stale = []
        for name in OUTPUTS.values():
            committed = os.path.join(SCENES, name)
            if not os.path.isfile(committed):
                stale.append(f"data/scenes/{name} is missing")
                continue
            with open(committed, "rb") as a, open(os.path.join(self.tmp.name, "scenes", name),
                                                  "rb") as b:
                if a.read() != b.read():
                    stale.append(f"data/scenes/{name} differs")
        self.assertEqual(stale, [], "data/scenes has drifted from scripts/make-field; run "
                                    "scripts/make-field and scripts/make-field --scale-up and "
                                    "commit what they write")

    def test_scaled_up_scene_differs_only_in_its_top_level_objects(self):
        scenes = {}
        for name in OUTPUTS.values():
            with open(os.path.join(self.tmp.name, "scenes", name)) as f:
                scenes[name] = json.load(f)
        small, large = scenes["field.json"], scenes["field-100m.json"]
        self.assertGreater(len(large["objects"]), len(small["objects"]))
        self.assertEqual(large["objects"][:len(small["objects"])], small["objects"])
        del small["objects"], large["objects"]
        self.assertEqual(small, large)


if __name__ == "__main__":
    unittest.main()
