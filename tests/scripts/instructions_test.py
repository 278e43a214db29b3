#!/usr/bin/env python3
"""Tests of scripts/instructions' reading of callgrind_annotate's listing and of the anatomy it
computes from it and --stats (the callgrind run itself needs valgrind, which the suite does not
install). The listings are written by hand in the format valgrind 3.19 prints."""

import importlib.machinery
import importlib.util
import os
import unittest

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts",
                      "instructions")


def load_script():
    loader = importlib.machinery.SourceFileLoader("instructions", SCRIPT)
    spec = importlib.util.spec_from_loader("instructions", loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


instructions = load_script()

SURFACE = "mrt::(anonymous namespace)::Walk<mrt::ABuffer<mrt::ConeSurface, 16> >"
OPACITY = "mrt::(anonymous namespace)::Walk<mrt::ABuffer<mrt::ConeOpacity, 16> >"
LISTING = f"""--------------------------------------------------------------------------------
Ir
--------------------------------------------------------------------------------
1,000,000 (100.0%)  PROGRAM TOTALS

--------------------------------------------------------------------------------
Ir                   file:function
--------------------------------------------------------------------------------
3,600,000 (360.0%)  ???:{SURFACE}::visit(mrt::(anonymous namespace)::ConeSpace const&, unsigned int, float) [/build/bin/mrt-trace]
  600,000 (60.00%)  ???:void mrt::ConeTraversal::traverse<mrt::ABuffer<mrt::ConeSurface, 16> >(mrt::ConeRay const&, float, float, mrt::ABuffer<mrt::ConeSurface, 16>&, mrt::ConeTraversalStats&) const [/build/bin/mrt-trace]
  300,000 (30.00%)  ???:void mrt::ConeTraversal::traverse<mrt::ABuffer<mrt::ConeOpacity, 16> >(mrt::ConeRay const&, float, float, mrt::ABuffer<mrt::ConeOpacity, 16>&, mrt::ConeTraversalStats&) const [/build/bin/mrt-trace]
  250,000 (25.00%)  ???:{SURFACE}::points(mrt::(anonymous namespace)::ConeSpace const&, unsigned int, float) [/build/bin/mrt-trace]
   50,000 ( 5.00%)  ???:{OPACITY}::points(mrt::(anonymous namespace)::ConeSpace const&, unsigned int, float) [/build/bin/mrt-trace]
  120,000 (12.00%)  ???:{SURFACE}::triangles(mrt::(anonymous namespace)::ConeSpace const&, unsigned int, float) [/build/bin/mrt-trace]
   30,000 ( 3.00%)  ???:{OPACITY}::triangles(mrt::(anonymous namespace)::ConeSpace const&, unsigned int, float) [/build/bin/mrt-trace]
   40,000 ( 4.00%)  ???:mrt::ConeSphereTest::rectangle_may_touch(mrt::SphereInRayFrame const&, float, float, float, Eigen::Matrix<float, 2, 1, 0, 2, 1> const&) const [/build/bin/mrt-trace]
   25,000           /src/trace/cone/cone_triangle.cpp:mrt::intersect_cone_triangle(std::array<mrt::VertexInRayFrame, 3ul> const&) [/build/bin/mrt-trace]
   15,000           /src/trace/cone/cone_triangle.cpp:mrt::intersect_cone_triangle_mapped(std::array<mrt::VertexInRayFrame, 3ul> const&) [/build/bin/mrt-trace]
    5,000 ( 0.50%)  ./math/../sysdeps/ieee754/flt-32/math_config.h:__expf_fma [/usr/lib/x86_64-linux-gnu/libm.so.6]
"""


def stats(cones, visits, points, triangles):
    return {"cones": cones, "nodes_visited": visits, "points_tested": points,
            "triangles_tested": triangles}


class ParseAnnotate(unittest.TestCase):
    def test_reads_the_totals_and_every_function_with_or_without_a_percentage(self):
        total, counts = instructions.parse_annotate(LISTING)
        self.assertEqual(total, 1_000_000)
        self.assertEqual(counts[f"{SURFACE}::points(mrt::(anonymous namespace)::ConeSpace const&,"
                                " unsigned int, float)"], 250_000)
        self.assertEqual(counts["__expf_fma"], 5_000)
        self.assertEqual(counts["mrt::intersect_cone_triangle_mapped(std::array<mrt::"
                                "VertexInRayFrame, 3ul> const&)"], 15_000)
        self.assertEqual(len(counts), 11)
        self.assertNotIn("PROGRAM TOTALS", counts)

    def test_a_listing_without_totals_is_an_error(self):
        with self.assertRaises(ValueError):
            instructions.parse_annotate("  5,000  ???:main [/bin/x]\n")


class Anatomy(unittest.TestCase):
    def setUp(self):
        _, self.inclusive = instructions.parse_annotate(LISTING)
        self.exclusive = {"a": 10, "b": 30, "c": 20, **{f"f{i}": i for i in range(12)}}
        self.stats = {"primary": stats(100, 1_000, 4_000, 50),
                      "secondary": stats(50, 400, 2_000, 30),
                      "shadow": stats(50, 100, 0, 20)}
        self.report = instructions.anatomy(1_000_000, self.inclusive, self.exclusive, self.stats)

    def test_parts_add_up_to_the_render_and_both_walks_count(self):
        parts = self.report["parts"]
        self.assertEqual(parts["points"], 300_000)
        self.assertEqual(parts["triangles"], 150_000)
        # The traversals (900 000) less points and triangles; the recursive visit is not used.
        self.assertEqual(parts["nodes_and_instances"], 450_000)
        self.assertEqual(parts["outside_traversal"], 100_000)
        self.assertEqual(sum(parts.values()), self.report["render_instructions"])

    def test_per_unit_divides_by_the_counts_of_every_kind(self):
        self.assertEqual(self.report["counts"], {"cones": 200, "node_visits": 1_500,
                                                 "points_tested": 6_000,
                                                 "triangles_tested": 100})
        unit = self.report["per_unit"]
        self.assertAlmostEqual(unit["cone"], 5_000)
        self.assertAlmostEqual(unit["node_visit"], 300)
        self.assertAlmostEqual(unit["point_tested"], 50)
        self.assertAlmostEqual(unit["triangle_tested"], 1_500)

    def test_functions_sum_their_variants_and_top_ten_is_sorted(self):
        functions = self.report["functions_inclusive"]
        self.assertEqual(functions["rectangle_test"], 40_000)
        self.assertEqual(functions["triangle_intersection"], 40_000)
        self.assertEqual(functions["circle_test"], 0)
        top = [entry["instructions"] for entry in self.report["top_ten_exclusive"]]
        self.assertEqual(top, sorted(self.exclusive.values(), reverse=True)[:10])

    def test_no_work_of_a_kind_gives_no_per_unit_figure(self):
        empty = {k: stats(1, 0, 0, 0) for k in ("primary", "secondary", "shadow")}
        report = instructions.anatomy(10, {}, {}, empty)
        self.assertIsNone(report["per_unit"]["node_visit"])
        self.assertIsNone(report["per_unit"]["point_tested"])
        self.assertAlmostEqual(report["per_unit"]["cone"], 10 / 3)


if __name__ == "__main__":
    unittest.main()
