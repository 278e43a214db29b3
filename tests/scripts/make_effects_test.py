#!/usr/bin/env python3
"""Tests of scripts/make-effects: the committed Figure 8 scenes under data/scenes are exactly
what the generator writes, so data/ cannot drift from it. What the scenes hold is checked by
loading them (mrt_scene_tests, SceneLoader.EffectsScenes*)."""

import os
import subprocess
import sys
import tempfile
import unittest

SOURCE_DIR = os.environ.get("MRT_SOURCE_DIR",
                            os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
NAMES = ["effects-depth-of-field.json", "effects-glossy.json", "effects-soft-shadows.json"]


class MakeEffects(unittest.TestCase):
    def test_committed_scenes_are_what_the_generator_writes(self):
        with tempfile.TemporaryDirectory(prefix="make-effects-test-") as out:
            run = subprocess.run([sys.executable, os.path.join(SOURCE_DIR, "scripts",
                                                               "make-effects"),
                                  "--out", out, "--quiet"],
                                 capture_output=True, text=True, timeout=60)
            self.assertEqual(run.returncode, 0, run.stderr)
            self.assertEqual(run.stdout, "")
            self.assertEqual(sorted(os.listdir(os.path.join(out, "scenes"))), NAMES)
            for name in NAMES:
                with open(os.path.join(SOURCE_DIR, "data", "scenes", name), "rb") as a, \
                        open(os.path.join(out, "scenes", name), "rb") as b:
                    self.assertEqual(a.read(), b.read(),
                                     f"data/scenes/{name} has drifted from scripts/make-effects;"
                                     " run it and commit what it writes")


if __name__ == "__main__":
    unittest.main()
