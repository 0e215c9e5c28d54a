#!/usr/bin/env python3
"""Self-test of the scripts: builds tiny CSVs in a temporary directory, checks table.py's
± spreads, sums, noisy marks and LaTeX output, and that plot.py writes its PNGs.
No network, a few seconds:

    python3 scripts/test_scripts.py [-v]
"""

import csv
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))

# The columns of a results.csv that the scripts read (a real one has more).
HEADER = ["scene", "structure", "params", "traversal", "device", "threads", "triangle_test",
          "ray_kind", "rays", "build_ms", "trace_ms_median", "mrays_per_s", "timed_runs",
          "trace_ms_ci", "noisy", "interior_per_ray", "leaves_per_ray", "planes_per_ray",
          "boxes_per_ray", "steps_per_ray", "cells_per_ray"]


def row(scene, structure, params, traversal, ray_kind, ms, ci, noisy=False, threads="1",
        steps=10.0, boxes=""):
    rays = 1_000_000
    return {"scene": scene, "structure": structure, "params": params, "traversal": traversal,
            "device": "cpu", "threads": threads, "triangle_test": "watertight",
            "ray_kind": ray_kind, "rays": rays, "build_ms": 12345.678, "trace_ms_median": ms,
            "mrays_per_s": rays / ms / 1000.0, "timed_runs": 5, "trace_ms_ci": ci,
            "noisy": "true" if noisy else "false", "interior_per_ray": steps / 2,
            "leaves_per_ray": 2.0, "planes_per_ray": "", "boxes_per_ray": boxes,
            "steps_per_ray": steps, "cells_per_ray": ""}


def results_rows():
    rows = []
    for scene in ["cornell", "a&b#1_x%"]:
        for strategy, ms in [("r-star", 30.0), ("str", 40.0)]:
            for kind, scale in [("primary", 1.0), ("shadow", 4.0 / 3.0)]:
                noisy = scene == "cornell" and strategy == "str" and kind == "shadow"
                rows.append(row(scene, "rtree", f"strategy={strategy};m=2", "stackless", kind,
                                ms * scale, 0.1, noisy, steps=20.0, boxes=20.0))
        # Threads: one row at 2 threads, so 1 thread is the most common choice.
        rows.append(row(scene, "rtree", "strategy=r-star;m=2", "stackless", "primary", 20.0,
                        0.1, threads="2"))
    return rows


def sweep_rows():
    """14 series (more than ten colours) of a leaf-size sweep, primary and ao tied."""
    rows = []
    for i in range(14):
        structure, traversal = ("bvh", "ordered") if i < 7 else ("rtree", f"t{i}")
        for leaf in [1, 2, 4, 8]:
            for kind in ["primary", "ao"]:
                rows.append(row("teapot", structure, f"max_leaf={leaf};variant={i}", traversal,
                                kind, 10.0 + i + leaf, 0.05, steps=5.0 + leaf,
                                boxes=3.0 if structure == "rtree" else 1.0))
    return rows


def convergence_rows():
    cols = ["scene", "structure", "params", "traversal", "triangle_test", "device", "threads",
            "integrator", "width", "height", "pass", "spp", "elapsed_ms", "build_ms", "rmse",
            "rel_mse", "budget_ms", "reference_spp", "reference_key"]
    rows = []
    for structure, traversal, speed in [("bvh", "ordered", 1.0), ("kdtree", "havran", 1.3)]:
        for integ in ["ao", "path"]:
            for p in range(5):
                spp = 2 ** p
                rows.append(dict(zip(cols, ["cornell", structure, "max_leaf=4", traversal,
                                            "watertight", "cpu", "2", integ, 96, 96, p + 1, spp,
                                            10.0 * spp * speed, 0.1, 0.3 / spp ** 0.5,
                                            0.1 / spp, "", 512, "abc"])))
            rows.append(dict(zip(cols, ["cornell", structure, "max_leaf=4", traversal,
                                        "watertight", "cpu", "2", integ, 96, 96, "", 3, 40.0,
                                        0.1, 0.17, 0.03, 50, 512, "abc"])))
    return cols, rows


def write(path, rows, header=HEADER):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=header)
        w.writeheader()
        w.writerows(rows)


def run(script, *args):
    p = subprocess.run([sys.executable, os.path.join(HERE, script), *args],
                       capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"})
    if p.returncode != 0:
        raise AssertionError(f"{script} {' '.join(args)} failed:\n{p.stdout}{p.stderr}")
    return p.stdout


class Table(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.csv = os.path.join(cls.tmp.name, "results.csv")
        write(cls.csv, results_rows())
        cls.base = ["--cols", "param:strategy", "--baseline", "r-star", "--filter", "threads=1"]

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_spread_and_header(self):
        out = run("table.py", self.csv, *self.base, "--value", "trace_ms_median",
                  "--filter", "ray_kind=primary")
        self.assertIn("scene \\ strategy", out)
        self.assertNotIn("strategy=", out.splitlines()[1])
        # 30 ms, CI 10 % of the median: ± 3.
        self.assertIn("30.00 ± 3.00", out)
        self.assertIn("40.00 ± 4.00", out)
        self.assertIn("+33.3%", out)
        self.assertNotIn("†", out)

    def test_mrays_relative_spread(self):
        out = run("table.py", self.csv, *self.base, "--filter", "ray_kind=primary")
        # 1e6 rays in 30 ms: 33.33 MRays/s, the same 10 %.
        self.assertIn("33.33 ± 3.33", out)

    def test_sum_quadrature_and_noisy(self):
        out = run("table.py", self.csv, *self.base, "--value", "trace_ms_median",
                  "--sum", "ray_kind")
        # 30 ± 3 plus 40 ± 4 gives 70 ± 5; str: 40 ± 4 plus 53.33 ± 5.33 gives 93.33 ± 6.67.
        self.assertIn("70.00 ± 5.00", out)
        self.assertIn("93.33 ± 6.67†", out)
        self.assertIn("† noisy", out)

    def test_no_spread_digits_thousands(self):
        out = run("table.py", self.csv, *self.base, "--value", "build_ms", "--no-spread",
                  "--digits", "1", "--filter", "ray_kind=primary")
        self.assertIn("12,345.7", out)
        self.assertNotIn("±", out)
        out = run("table.py", self.csv, *self.base, "--no-spread", "--filter", "ray_kind=primary")
        self.assertNotIn("±", out)
        # Whole numbers: no decimals unless --digits asks.
        out = run("table.py", self.csv, *self.base, "--value", "rays", "--filter",
                  "ray_kind=primary")
        self.assertIn("1,000,000", out)
        self.assertNotIn("1,000,000.00", out)

    def test_counters_not_marked_noisy(self):
        out = run("table.py", self.csv, *self.base, "--value", "steps_per_ray",
                  "--sum", "ray_kind")
        self.assertNotIn("†", out)
        self.assertNotIn("±", out)

    def test_latex(self):
        out = run("table.py", self.csv, *self.base, "--value", "trace_ms_median",
                  "--sum", "ray_kind", "--format", "latex")
        for s in ["\\toprule", "\\midrule", "\\bottomrule", "\\begin{tabular}", "\\end{tabular}",
                  "70.00 $\\pm$ 5.00", "$^\\dagger$", "a\\&b\\#1\\_x\\%", "+33.3\\%",
                  "\\multicolumn{3}{c}{strategy}"]:
            self.assertIn(s, out)
        self.assertTrue(out.startswith("% caption: trace_ms_median"), out)
        body = [ln for ln in out.splitlines() if not ln.startswith("%")]
        self.assertFalse(any("±" in ln or "†" in ln for ln in body), out)

    def test_markdown(self):
        out = run("table.py", self.csv, *self.base, "--format", "markdown",
                  "--filter", "ray_kind=primary")
        self.assertIn("|---|---:|", out)

    def test_two_rows_in_a_cell(self):
        p = subprocess.run([sys.executable, os.path.join(HERE, "table.py"), self.csv,
                            "--cols", "param:strategy", "--baseline", "r-star"],
                           capture_output=True, text=True)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("ray_kind", p.stderr)


class Plot(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        d = cls.tmp.name
        cls.results = os.path.join(d, "results.csv")
        write(cls.results, results_rows())
        cls.sweep = os.path.join(d, "sweep.csv")
        write(cls.sweep, sweep_rows())
        cls.conv = os.path.join(d, "convergence.csv")
        cols, rows = convergence_rows()
        write(cls.conv, rows, cols)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def png(self, path):
        self.assertTrue(os.path.exists(path), path)
        with open(path, "rb") as f:
            self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")

    def test_bars(self):
        out = run("plot.py", self.results)
        self.png(os.path.join(self.tmp.name, "results-bars.png"))
        self.assertIn("threads (CPU): 1", out)
        self.assertIn("cells (not measured)", out)
        self.assertIn("planes (not measured)", out)

    def test_bars_many_series_tie(self):
        out = run("plot.py", "bars", self.sweep, "--out", os.path.join(self.tmp.name, "b.png"))
        self.png(os.path.join(self.tmp.name, "b.png"))
        self.assertIn("ray kind: primary", out)

    def test_sweep(self):
        out = run("plot.py", "sweep", self.sweep, "--param", "max_leaf")
        self.png(os.path.join(self.tmp.name, "sweep-max_leaf.png"))
        self.assertIn("tie broken in favour of primary", out)
        run("plot.py", "sweep", self.sweep, "--param", "max_leaf", "--metric", "steps_per_ray")
        self.png(os.path.join(self.tmp.name, "sweep-max_leaf-steps_per_ray.png"))

    def test_convergence(self):
        out = run("plot.py", self.conv)
        self.png(os.path.join(self.tmp.name, "convergence.png"))
        self.assertIn("budget_ms", out)


if __name__ == "__main__":
    unittest.main()
