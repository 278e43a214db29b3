#!/usr/bin/env python3
"""Tests of scripts/make-desk: the committed desk scene under data/ is exactly what the
generator writes (so data/ cannot drift from its generator), its PNGs carry no metadata that
could vary between runs, and the lens it refracts through is a closed, outward-facing mesh."""

import os
import struct
import subprocess
import sys
import tempfile
import unittest

import numpy as np

SOURCE_DIR = os.environ.get("MRT_SOURCE_DIR",
                            os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
MAKE_DESK = os.path.join(SOURCE_DIR, "scripts", "make-desk")
DATA = os.path.join(SOURCE_DIR, "data")


def files_under(root):
    """Paths relative to `root` of every file below it, sorted."""
    found = []
    for directory, _, names in os.walk(root):
        for name in names:
            found.append(os.path.relpath(os.path.join(directory, name), root))
    return sorted(found)


def committed_desk_files():
    """The files of data/ that belong to the desk scene by name."""
    return sorted(path for path in files_under(DATA)
                  if path == os.path.join("scenes", "desk.json")
                  or (os.path.dirname(path) in ("textures", "meshes")
                      and os.path.basename(path).startswith("desk-")))


def png_chunk_types(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    types, pos = [], 8
    while pos < len(data):
        (length,) = struct.unpack_from(">I", data, pos)
        types.append(data[pos + 4:pos + 8].decode("latin-1"))
        pos += 12 + length
    return types


def read_obj(path):
    positions, normals, faces = [], [], []
    with open(path) as f:
        for line in f:
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            if fields[0] == "v":
                positions.append([float(x) for x in fields[1:4]])
            elif fields[0] == "vn":
                normals.append([float(x) for x in fields[1:4]])
            elif fields[0] == "f":
                corners = [field.split("/") for field in fields[1:]]
                faces.append(([int(c[0]) - 1 for c in corners], [int(c[2]) - 1 for c in corners]))
    return np.array(positions), np.array(normals), faces


class MakeDesk(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="make-desk-test-")
        cls.out = cls.tmp.name
        cls.run_result = subprocess.run([sys.executable, MAKE_DESK, "--out", cls.out, "--quiet"],
                                        capture_output=True, text=True, timeout=600)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def setUp(self):
        self.assertEqual(self.run_result.returncode, 0, self.run_result.stderr)

    def test_generator_is_quiet_with_quiet(self):
        self.assertEqual(self.run_result.stdout, "")

    def test_committed_data_is_byte_identical_to_the_generated(self):
        generated = files_under(self.out)
        self.assertIn(os.path.join("scenes", "desk.json"), generated)
        stale = []
        for path in generated:
            committed = os.path.join(DATA, path)
            if not os.path.isfile(committed):
                stale.append(f"data/{path} is missing")
                continue
            with open(committed, "rb") as a, open(os.path.join(self.out, path), "rb") as b:
                if a.read() != b.read():
                    stale.append(f"data/{path} differs")
        self.assertEqual(stale, [], "data/ has drifted from scripts/make-desk; run "
                                    "scripts/make-desk and commit what it writes")

    def test_no_desk_file_in_data_that_the_generator_does_not_write(self):
        self.assertEqual(committed_desk_files(), files_under(self.out))

    def test_pngs_hold_only_pixel_chunks(self):
        # No tIME, tEXt or iTXt: nothing in the files depends on when or where they were made.
        for path in files_under(self.out):
            if path.endswith(".png"):
                with self.subTest(path):
                    types = png_chunk_types(os.path.join(self.out, path))
                    self.assertEqual(types[0], "IHDR")
                    self.assertEqual(types[-1], "IEND")
                    self.assertLessEqual(set(types), {"IHDR", "PLTE", "IDAT", "IEND"})

    def test_lens_is_closed_and_faces_outwards(self):
        positions, normals, faces = read_obj(os.path.join(self.out, "meshes", "desk-lens.obj"))
        self.assertTrue(10000 <= len(faces) <= 20000, len(faces))
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
        # Closed and consistently wound: each directed edge once, and its reverse once. Caps
        # and rim have their own vertices (and normals) at the crease, so corners are matched
        # by position.
        ids = {}
        corner = [ids.setdefault(tuple(p), len(ids)) for p in positions]
        edges = {}
        for vertices, _ in faces:
            for i in range(3):
                edge = (corner[vertices[i]], corner[vertices[(i + 1) % 3]])
                edges[edge] = edges.get(edge, 0) + 1
        self.assertEqual(max(edges.values()), 1)
        self.assertEqual([e for e in edges if (e[1], e[0]) not in edges], [])
        # The winding's normal agrees with the vertex normals and, the lens being convex,
        # points away from its centre: the renderer takes the side the winding faces as the
        # outside, where a ray enters the glass.
        centre = positions.mean(axis=0)
        for vertices, normal_ids in faces:
            p = positions[vertices]
            geometric = np.cross(p[1] - p[0], p[2] - p[0])
            self.assertGreater(float(np.dot(geometric, normals[normal_ids].sum(axis=0))), 0.0)
            self.assertGreater(float(np.dot(geometric, p.mean(axis=0) - centre)), 0.0)


if __name__ == "__main__":
    unittest.main()
