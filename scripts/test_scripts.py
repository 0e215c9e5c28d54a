#!/usr/bin/env python3
"""Self-test of the scripts: builds tiny CSVs in a temporary directory, checks table.py's
± spreads, sums, noisy marks, LaTeX output and `stat:KEY` / `a+b` values, the paper scripts'
tables, several CSVs and run folders read as one (the later file wins), the noisy marks and
--drop-noisy of every table script, and that plot.py writes its PNGs (sweeps of summed metrics
with --line reference rows included), and that check-docs.py finds every name the documents
cite and fails on a stale one. No network, a few seconds:

    python3 scripts/test_scripts.py [-v]

The plotting tests need matplotlib (scripts/requirements.txt); without it they are skipped with
a notice, and the rest run. TRACE_BENCH_REQUIRE_MATPLOTLIB=1 turns the skip into a failure (CI,
in the virtual environment that installs requirements.txt).
"""

import csv
import importlib.util
import re
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
HAVE_MPL = importlib.util.find_spec("matplotlib") is not None
REQUIRE_MPL = os.environ.get("TRACE_BENCH_REQUIRE_MATPLOTLIB", "") not in ("", "0")
MPL_NOTICE = (f"matplotlib is not installed for {sys.executable}: the plotting tests are "
              "skipped (pip install -r scripts/requirements.txt to run them)")

# The columns of a results.csv that the scripts read (a real one has more).
HEADER = ["scene", "structure", "params", "traversal", "device", "threads", "triangle_test",
          "ray_kind", "rays", "build_ms", "trace_ms_median", "mrays_per_s", "timed_runs",
          "trace_ms_ci", "noisy", "interior_per_ray", "leaves_per_ray", "planes_per_ray",
          "boxes_per_ray", "steps_per_ray", "cells_per_ray", "prims_per_ray", "build_stats"]


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


def multikd_rows():
    """A multi-kd-tree run in small: SAH and COS-ORTH trees (beta swept; the SAH rows carry a
    beta too), two scenes, two ray kinds, recursive-direction only."""
    rows = []
    for scene, extra in [("sibenik", 0.0), ("sponza", 5.0)]:
        for measure, betas in [("sah", [2]), ("cos-orth", [0.5, 1, 1.5, 2, 2.5])]:
            for beta in betas:
                for kind, ms in [("primary", 20.0), ("path1", 25.0)]:
                    r = row(scene, "multi-kd", f"measure={measure};beta={beta};trees=multi",
                            "recursive-direction", kind, ms, 0.1)
                    planes = 30.0 + extra + (0.0 if measure == "sah" else beta)
                    r["planes_per_ray"], r["prims_per_ray"] = planes, 10.25
                    nodes = 1000 if measure == "sah" else 3000 + int(10 * beta)
                    r["build_stats"] = f"trees=1;nodes={nodes};references=800;paper_bytes=19200"
                    rows.append(r)
    return rows


def table5_gpu_rows():
    """The GPU run of table5_rows' config: path1's trace 4 ms, its sort about 1 ms (`sort_ms`
    on both sorted rows; in the time of -sorted only)."""
    rows = []
    for view in ["1", "2"]:
        for measure in ["sah", "sphere-orth"]:
            for traversal, extra in [("recursive-direction", 0.5),
                                     ("recursive-direction-presorted", 0.0),
                                     ("recursive-direction-sorted", 1.0)]:
                for kind, ms in [("primary", 2.0), ("path1", 4.0)]:
                    ms = ms + (extra if kind == "path1" else 0.0)
                    r = row(f"sponza@{view}", "multi-kd", f"measure={measure};trees=multi",
                            traversal, kind, ms, 0.1, threads="0")
                    r["device"], r["adapter"] = "gpu", "TestGPU / vulkan / test"
                    # Timed apart from the trace: the -sorted row's median sort 1.25 ms.
                    sort = {"recursive-direction-presorted": 1.0,
                            "recursive-direction-sorted": 1.25}
                    r["sort_ms"] = sort.get(traversal, "")
                    r["planes_per_ray"], r["prims_per_ray"] = 30.0, 10.0
                    rows.append(r)
    # A GPU row without a time (no adapter) is left out.
    rows.append({**rows[0], "trace_ms_median": "", "mrays_per_s": "", "note": "no adapter"})
    return rows


def table5_rows():
    """configs/multikd.toml in small: two views of one scene, SAH and SPHERE-ORTH, the plain,
    -presorted and -sorted rows; the sort costs 2 ms of path1's -sorted 10 ms per view."""
    rows = []
    for view in ["1", "2"]:
        for measure in ["sah", "sphere-orth"]:
            for traversal, extra in [("recursive-direction", 1.0),
                                     ("recursive-direction-presorted", 0.0),
                                     ("recursive-direction-sorted", 2.0)]:
                for kind, ms in [("primary", 5.0), ("path1", 8.0)]:
                    ms = ms + (extra if kind == "path1" else 0.0)
                    ms = ms * (0.5 if measure == "sah" else 1.0)
                    r = row(f"sponza@{view}", "multi-kd", f"measure={measure};trees=multi",
                            traversal, kind, ms, 0.1)
                    r["planes_per_ray"], r["prims_per_ray"] = 30.0, 10.0
                    rows.append(r)
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
    return run2(script, *args)[0]


def run2(script, *args):
    """(stdout, stderr) of a script that must succeed."""
    p = subprocess.run([sys.executable, os.path.join(HERE, script), *args],
                       capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"})
    if p.returncode != 0:
        raise AssertionError(f"{script} {' '.join(args)} failed:\n{p.stdout}{p.stderr}")
    return p.stdout, p.stderr


def needs_matplotlib(cls):
    """Skip a test class without matplotlib (a failure with TRACE_BENCH_REQUIRE_MATPLOTLIB=1)."""
    if HAVE_MPL or REQUIRE_MPL:
        return cls
    return unittest.skip(MPL_NOTICE)(cls)


class Table(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.csv = os.path.join(cls.tmp.name, "results.csv")
        write(cls.csv, results_rows())
        cls.mk = os.path.join(cls.tmp.name, "multikd.csv")
        write(cls.mk, multikd_rows())
        cls.base = ["--cols", "param:strategy", "--baseline", "r-star", "--filter", "threads=1"]
        cls.t5 = os.path.join(cls.tmp.name, "table5.csv")
        write(cls.t5, table5_rows())
        cls.t5_gpu = os.path.join(cls.tmp.name, "table5-gpu.csv")
        write(cls.t5_gpu, table5_gpu_rows(), HEADER + ["adapter", "sort_ms", "note"])

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_hosts_warning(self):
        rows = results_rows()
        for i, r in enumerate(rows):
            r["host"] = "node1" if i % 2 else "node2"
        path = os.path.join(self.tmp.name, "hosts.csv")
        write(path, rows, HEADER + ["host"])
        args = [sys.executable, os.path.join(HERE, "table.py"), path, *self.base,
                "--filter", "ray_kind=primary"]
        p = subprocess.run(args, capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("timings taken on 2 hosts (node2, node1)", p.stderr)
        # Counters do not depend on the host: no warning.
        p = subprocess.run(args + ["--value", "steps_per_ray"], capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertNotIn("hosts", p.stderr)
        # One host: no warning.
        p = subprocess.run(args + ["--filter", "host=node1"], capture_output=True, text=True)
        self.assertNotIn("hosts", p.stderr)

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
        # The change built from the noisy cell is marked too; the footnote counts the rows.
        self.assertIn("+33.3%†", out)
        self.assertIn("† noisy timing (1 of 8 timed rows)", out)
        a_line = next(ln for ln in out.splitlines() if ln.startswith("a&b"))
        self.assertNotIn("†", a_line)

    def test_noisy_baseline_marks_every_change(self):
        rows = results_rows()
        for r in rows:
            r["noisy"] = "true" if (r["scene"] == "cornell" and r["params"].startswith(
                "strategy=r-star") and r["ray_kind"] == "primary" and r["threads"] == "1") \
                else "false"
        path = os.path.join(self.tmp.name, "noisy-base.csv")
        write(path, rows)
        out = run("table.py", path, *self.base, "--filter", "ray_kind=primary",
                  "--value", "trace_ms_median")
        line = next(ln for ln in out.splitlines() if ln.startswith("cornell"))
        self.assertIn("30.00 ± 3.00†", line)
        self.assertIn("40.00 ± 4.00 ", line)   # the cell itself is clean ...
        self.assertIn("+33.3%†", line)         # ... its change against a noisy base is not
        # Counters are exact: never marked, and --drop-noisy leaves them alone.
        out = run("table.py", path, *self.base, "--filter", "ray_kind=primary",
                  "--value", "steps_per_ray", "--drop-noisy")
        line = next(ln for ln in out.splitlines() if ln.startswith("cornell"))
        self.assertEqual(line.split(), ["cornell", "20", "20", "+0.0%"])
        self.assertNotIn("†", out)

    def test_drop_noisy(self):
        out, err = run2("table.py", self.csv, *self.base, "--value", "trace_ms_median",
                        "--sum", "ray_kind", "--drop-noisy", "--format", "markdown")
        self.assertIn("the timings of 1 noisy row(s) of 8 left out", err)
        self.assertIn("| cornell | 70.00 ± 5.00 | - | - |", out)
        self.assertIn("| a&b#1_x% | 70.00 ± 5.00 | 93.33 ± 6.67 | +33.3% |", out)
        self.assertNotIn("†", out)
        self.assertIn("timings of noisy rows left out", out.splitlines()[0])

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

    def test_multikd_table5(self):
        out = run("multikd-table5.py", self.t5)
        self.assertIn("=== Table 5, threads=1", out)
        self.assertIn("PT SPONZA", out)
        # Views pooled: 2 x 1M rays in 2 x 10 ms (-sorted) = 100 MRays/s; presorted 125; the
        # sort 2 of 10 ms = 20%; SAH takes half the time, a gain of -100%.
        line = next(l for l in out.splitlines() if l.strip().startswith("ours SPONZA")
                    and "125.00" in l)
        self.assertIn("100.00", line)
        self.assertIn("20.0%", line)
        self.assertIn("-100.00", line)
        self.assertIn("2 views, steps=equal, mism 0", line)

    def test_multikd_table5_gpu(self):
        out = run("multikd-table5.py", self.t5, self.t5_gpu)
        self.assertIn("=== Table 5, threads=1", out)
        self.assertIn("=== Table 5, GPU TestGPU / vulkan / test", out)
        gpu = out[out.index("=== Table 5, GPU"):]
        # 2 x 1M rays in 2 x 4 ms (-presorted) = 250 MRays/s, in 2 x 5 ms (-sorted, the sort
        # included) = 200; the sort's share from -sorted's own sort_ms, 1.25 of 5 ms = 25% (not
        # the difference of the rows); SAH as fast, a gain of 0.
        line = next(l for l in gpu.splitlines() if l.strip().startswith("ours SPONZA")
                    and "250.00" in l)
        self.assertIn("200.00", line)
        self.assertIn("25.0%", line)
        self.assertIn("+0.00", line)
        self.assertIn("2 views, steps=equal, mism 0", line)

    def test_stat_value(self):
        out = run("table.py", self.mk, "--cols", "param:measure", "--value", "stat:nodes",
                  "--baseline", "sah", "--filter", "param:beta=2|", "--filter", "ray_kind=primary")
        self.assertIn("3,020", out)
        self.assertIn("+202.0%", out)
        self.assertNotIn("3,020.00", out)  # build figures are whole numbers
        self.assertNotIn("±", out)

    def test_summed_value(self):
        # Table 4 of the multi-kd-tree paper: planes + triangles per ray, no ± on a sum.
        out = run("table.py", self.mk, "--rows", "scene+ray_kind", "--cols", "param:measure",
                  "--value", "planes_per_ray+prims_per_ray", "--baseline", "sah",
                  "--filter", "param:beta=2", "--filter", "traversal=recursive-direction")
        self.assertIn("sibenik/primary", out)
        self.assertIn("40.25", out)   # sah: 30 + 10.25
        self.assertIn("42.25", out)   # cos-orth beta 2: 32 + 10.25
        self.assertIn("+5.0%", out)
        self.assertIn("45.25", out)   # sponza sah: 35 + 10.25
        self.assertNotIn("±", out)
        self.assertNotIn("†", out)
        # A single timing column keeps its ±; --sum over ray kinds adds the summed values.
        out = run("table.py", self.mk, "--cols", "param:measure", "--value", "mrays_per_s",
                  "--baseline", "sah", "--filter", "param:beta=2", "--filter", "ray_kind=primary")
        self.assertIn("50.00 ± 5.00", out)
        out = run("table.py", self.mk, "--cols", "param:measure", "--baseline", "sah",
                  "--value", "planes_per_ray+prims_per_ray", "--filter", "param:beta=2",
                  "--sum", "ray_kind")
        self.assertIn("80.50", out)   # sibenik sah: 40.25 primary + 40.25 path1
        self.assertNotIn("±", out)

    def test_summed_value_latex(self):
        out = run("table.py", self.mk, "--cols", "param:measure", "--baseline", "sah",
                  "--value", "planes_per_ray+prims_per_ray", "--filter", "param:beta=2",
                  "--filter", "ray_kind=primary", "--format", "latex")
        self.assertTrue(out.startswith("% caption: planes_per_ray+prims_per_ray"), out)
        self.assertIn("sibenik & 40.25 & 42.25 & +5.0\\%", out)

    def test_unknown_value_column(self):
        p = subprocess.run([sys.executable, os.path.join(HERE, "table.py"), self.mk,
                            "--cols", "param:measure", "--baseline", "sah",
                            "--value", "planes_per_ray+nope_per_ray"],
                           capture_output=True, text=True)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("nope_per_ray", p.stderr)

    def test_two_rows_in_a_cell(self):
        p = subprocess.run([sys.executable, os.path.join(HERE, "table.py"), self.csv,
                            "--cols", "param:strategy", "--baseline", "r-star"],
                           capture_output=True, text=True)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("ray_kind", p.stderr)


@needs_matplotlib
class Plot(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        d = cls.tmp.name
        cls.results = os.path.join(d, "results.csv")
        write(cls.results, results_rows())
        cls.sweep = os.path.join(d, "sweep.csv")
        write(cls.sweep, sweep_rows())
        cls.mk = os.path.join(d, "multikd.csv")
        write(cls.mk, multikd_rows())
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

    def test_sweep_summed_metric_with_line(self):
        # Tables 6-7 of the multi-kd-tree paper: COS-ORTH against beta, the SAH dashed.
        out = run("plot.py", "sweep", self.mk, "--param", "beta", "--metric",
                  "planes_per_ray+prims_per_ray", "--filter", "param:measure=cos-orth|sah",
                  "--filter", "traversal=recursive-direction", "--ray-kind", "path1",
                  "--line", "param:measure=sah")
        self.png(os.path.join(self.tmp.name, "multikd-sweep-beta-planes_per_ray+prims_per_ray.png"))
        self.assertIn("ray kind: path1", out)
        # Timing metric (the reference line gets a CI band), stat:KEY, a repeated --line.
        run("plot.py", "sweep", self.mk, "--param", "beta", "--line", "param:measure=sah",
            "--line", "scene=sibenik", "--out", os.path.join(self.tmp.name, "l2.png"))
        self.png(os.path.join(self.tmp.name, "l2.png"))
        run("plot.py", "sweep", self.mk, "--param", "beta", "--metric", "stat:nodes",
            "--filter", "param:measure=cos-orth")
        self.png(os.path.join(self.tmp.name, "multikd-sweep-beta-stat-nodes.png"))

    def test_sweep_line_matches_nothing(self):
        p = subprocess.run([sys.executable, os.path.join(HERE, "plot.py"), "sweep", self.mk,
                            "--param", "beta", "--line", "param:measure=nope"],
                           capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"})
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("--line", p.stderr)

    def test_sweep_without_line_keeps_reference_points(self):
        # Without --line the SAH rows (beta=2) are ordinary sweep points, as before.
        out = run("plot.py", "sweep", self.mk, "--param", "beta", "--metric",
                  "planes_per_ray+prims_per_ray", "--out", os.path.join(self.tmp.name, "n.png"))
        self.png(os.path.join(self.tmp.name, "n.png"))
        self.assertIn("wrote", out)

    def test_convergence(self):
        out = run("plot.py", self.conv)
        self.png(os.path.join(self.tmp.name, "convergence.png"))
        self.assertIn("budget_ms", out)


def irregular_rows():
    """Table 1 and Table 5 rows of one scene: SBVH, the irregular grid's phases, the uniform
    grid with macro regions and with M, E, M + E (built-heap columns on the M + E row)."""
    rows = []
    variants = [
        ("bvh", "builder=sbvh", 20.0, 0.0, 4.0, 10.0, 1e6),
        ("irregular-grid", "lambda_1=0.12;initial=two-level;merge=false;expansion=0", 0, 12.0, 8.0, 11.0, 2e6),
        ("irregular-grid", "lambda_1=0.12;initial=two-level;merge=true;expansion=0", 0, 9.0, 8.0, 12.0, 2e6),
        ("irregular-grid", "lambda_1=0.12;initial=two-level;merge=true;expansion=3", 0, 6.0, 7.0, 14.0, 2e6),
        ("uniform-grid", "lambda=5;macro_regions=true", 0, 30.0, 9.0, 8.0, 3e6),
        ("irregular-grid", "lambda_1=5;initial=uniform;merge=true;expansion=0", 0, 20.0, 9.0, 9.0, 2e6),
        ("irregular-grid", "lambda_1=5;initial=uniform;merge=false;expansion=3", 0, 15.0, 9.0, 10.0, 9e6),
        ("irregular-grid", "lambda_1=5;initial=uniform;merge=true;expansion=3", 0, 12.0, 9.0, 9.9, 2.5e6),
    ]
    for structure, params, interior, cells, prims, mrays, mem in variants:
        for scene in ["sponza", "sponza@b"]:
            r = row(scene, structure, params, "walk", "primary", 1000.0 / mrays, 0.01)
            r["interior_per_ray"], r["leaves_per_ray"] = (interior, 5.0) if interior else ("", "")
            r["cells_per_ray"], r["prims_per_ray"], r["memory_bytes"] = (cells or ""), prims, mem
            if params.endswith("merge=true;expansion=3") and "two-level" in params:
                r["build_heap_peak_bytes"], r["build_heap_kept_bytes"] = 6e6, 2e6
            rows.append(r)
    return rows


class Irregular(unittest.TestCase):
    def test_tables_and_claims(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "results.csv")
            write(path, irregular_rows(),
                  HEADER + ["memory_bytes", "build_heap_peak_bytes", "build_heap_kept_bytes"])
            out = run("irregular-tables.py", path)
        # N_T of the SBVH is interior + leaves (25); merge & expansion: 6 cells, -76 %.
        self.assertIn("N_T  25.00", out)
        self.assertIn("+ Merge & Exp.   N_T   6.00  (-76%)", out)
        self.assertIn("sponza N_T -76 %, N_I +75 % -> agree", out)
        # M + E against macro regions: 9.9 / 8.0 MRays/s, less memory than E.
        self.assertIn("sponza +24 %, memory M + E 2.5 MB vs E 9.0 MB -> agree", out)
        self.assertIn("memory: memory_bytes", out)
        # With the structure alone (`structure_bytes`), Table 5's memory reads it.
        rows = irregular_rows()
        for r in rows:
            r["structure_bytes"] = 0.4 * r["memory_bytes"]
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "results.csv")
            write(path, rows, HEADER + ["memory_bytes", "structure_bytes", "build_heap_peak_bytes",
                                        "build_heap_kept_bytes"])
            out = run("irregular-tables.py", path)
        self.assertIn("memory: structure_bytes (the structure alone)", out)
        self.assertIn("sponza +24 %, memory M + E 1.0 MB vs E 3.6 MB -> agree", out)
        self.assertIn("sponza 3.00x -> agree", out)
        # Table 3 reads the views: 14 / 10 MRays/s at view b.
        self.assertIn("sponza@b", out)
        self.assertIn("10.00 / 14.00 (+40%)", out)


def sparse_rows(noisy=(), scale=1.0):
    """configs/sparse-boxes.toml in small: one scene, two views, HTR/BTR/SLTR/SEQ, primary and
    shadow rays; `noisy` lists (view, traversal) pairs flagged noisy; times scaled by `scale`."""
    rows = []
    for view in ["1", "2"]:
        for trav, ni, ms in [("htr", 80.0, 10.0), ("btr", 70.0, 9.0), ("sltr", 120.0, 14.0),
                             ("seq", 240.0, 19.0)]:
            for kind in ["primary", "shadow"]:
                r = row(f"arena@{view}", "sparse-boxes", "d_min=2", trav, kind, ms * scale, 0.02,
                        noisy=(view, trav) in noisy)
                r.update(interior_per_ray=ni, prims_per_ray=30.0, leaves_per_ray=9.0,
                         build_stats="n_b=700000;m_kd_bytes=2000000;m_kd_htr_bytes=1500000",
                         ups_per_ray=1.0 if trav in ("btr", "sltr") else "", mismatches=0,
                         triangles=1000)
                rows.append(r)
    return rows


SPARSE_HEADER = HEADER + ["ups_per_ray", "mismatches", "triangles"]


def dmin_rows():
    """configs/sparse-dmin.toml in small: BTR and SLTR over d_min 1..4, HTR once (its rows
    carry the default d_min = 2, as the harness writes the full parameter set)."""
    rows = []
    for scene in ["sponza", "sibenik"]:
        for trav in ["btr", "sltr"]:
            for d in [1, 2, 3, 4]:
                r = row(scene, "sparse-boxes", f"d_min={d};max_leaf=2", trav, "primary",
                        10.0 + d, 0.02, steps=60.0 - d)
                r["interior_per_ray"] = 60.0 - d
                rows.append(r)
        r = row(scene, "sparse-boxes", "d_min=2;max_leaf=2", "htr", "primary", 12.0, 0.02)
        r["interior_per_ray"] = 70.0
        rows.append(r)
    return rows


DYNAMIC_HEADER = ["scene", "source", "structure", "params", "threads", "width", "height",
                  "budget_ms", "frame", "triangles", "lambda_1", "lambda_2", "build_ms",
                  "primary_ms", "ao_ms_per_spp", "spp"]


def dynamic_rows(spp_irregular=10, lam=0.3):
    rows = []
    for structure, spp, l1 in [("two-level-grid", 5, 0.2), ("irregular-grid", spp_irregular, lam)]:
        for budget in [100, 50]:
            for frame in [0, 10, 20]:
                rows.append(dict(zip(DYNAMIC_HEADER, [
                    "explode", f"builtin:explode?frame={frame}", structure,
                    f"lambda_1={l1};lambda_2={8 * l1:g};merge=true", 2, 256, 256, budget, frame,
                    1000, l1, 8 * l1, 10.0, 5.0, 2.0, spp if budget == 100 else spp // 2])))
    return rows


def run_dirs(tmp, name, tables, file="results.csv", header=HEADER):
    """results/<name>/<run k>/<file> for each table of rows, and results/<name>/LATEST, a link
    to the last run folder (as the harness makes it). Returns (the run folders, results/<name>)."""
    base = os.path.join(tmp, "results", name)
    dirs = []
    for k, rows in enumerate(tables):
        d = os.path.join(base, f"2026-01-0{k + 1}T00-00-00")
        os.makedirs(d, exist_ok=True)
        write(os.path.join(d, file), rows, header)
        dirs.append(d)
    latest = os.path.join(base, "LATEST")
    if not os.path.lexists(latest):
        os.symlink(os.path.basename(dirs[-1]), latest)
    return dirs, base


class SeveralRuns(unittest.TestCase):
    """Finding 1: every script takes several CSVs and run folders; a later file wins."""

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)

    def test_table_later_file_wins(self):
        old = results_rows()
        new = [dict(r) for r in results_rows() if r["scene"] == "cornell"]
        for r in new:
            r["trace_ms_median"] = r["trace_ms_median"] * 2
        (d1, d2), base = run_dirs(self.tmp.name, "rtree", [old, new])
        args = [*("--cols", "param:strategy", "--baseline", "r-star", "--filter", "threads=1"),
                "--value", "trace_ms_median", "--filter", "ray_kind=primary", "--no-spread"]
        for inputs in ([os.path.join(d1, "results.csv"), os.path.join(d2, "results.csv")],
                       [d1, d2], [d1, os.path.join(base, "LATEST")]):
            out, err = run2("table.py", *inputs, *args)
            self.assertIn("note: 5 row(s) of", err)
            self.assertIn("the later file wins", err)
            lines = {ln.split()[0]: ln.split() for ln in out.splitlines()[2:]}
            self.assertEqual(lines["cornell"][1:3], ["60.00", "80.00"])   # the later run
            self.assertEqual(lines["a&b#1_x%"][1:3], ["30.00", "40.00"])  # only in the first
        # The other order: the first run's rows win.
        cornell = lambda out: next(ln.split()[1:3] for ln in out.splitlines()  # noqa: E731
                                   if ln.startswith("cornell"))
        self.assertEqual(cornell(run("table.py", d2, d1, *args)), ["30.00", "40.00"])
        # results/NAME (no results.csv of its own) reads results/NAME/LATEST.
        self.assertEqual(cornell(run("table.py", base, *args)), ["60.00", "80.00"])
        # The same file twice is read once, without a note about replaced rows.
        out, err = run2("table.py", d1, os.path.join(d1, "results.csv"), *args)
        self.assertIn("given twice", err)
        self.assertNotIn("replaced", err)

    def test_folder_without_results(self):
        p = subprocess.run([sys.executable, os.path.join(HERE, "table.py"), self.tmp.name,
                            "--cols", "param:strategy", "--baseline", "r-star"],
                           capture_output=True, text=True)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("a folder without results.csv", p.stderr)

    def test_columns_of_another_version(self):
        # An older run without the `boxes_per_ray` column beside a newer one: the union of the
        # columns, empty where a file lacks one.
        old = [{k: v for k, v in r.items() if k != "boxes_per_ray"}
               for r in results_rows() if r["scene"] == "cornell"]
        new = [r for r in results_rows() if r["scene"] != "cornell"]
        d = self.tmp.name
        write(os.path.join(d, "old.csv"), old, [c for c in HEADER if c != "boxes_per_ray"])
        write(os.path.join(d, "new.csv"), new)
        out = run("table.py", os.path.join(d, "old.csv"), os.path.join(d, "new.csv"),
                  "--cols", "param:strategy", "--baseline", "r-star", "--filter", "threads=1",
                  "--filter", "ray_kind=primary", "--value", "boxes_per_ray")
        self.assertIn("cornell", out)
        self.assertIn("a&b#1_x%", out)

    def test_sparse_table1(self):
        (d1, d2), base = run_dirs(self.tmp.name, "sparse-boxes",
                                  [sparse_rows(), sparse_rows(scale=2.0)], header=SPARSE_HEADER)
        out, err = run2("sparse-table1.py", d1, d2)
        self.assertIn("replaced", err)
        htr = next(ln for ln in out.splitlines() if ln.strip().startswith("HTR")
                   and "1.50" in ln)
        self.assertIn("0.020", htr)  # T_R of the second run: 20 ms
        out2, _ = run2("sparse-table1.py", os.path.join(base, "LATEST"))
        self.assertEqual(out, out2)

    def test_irregular_figure6(self):
        rows = []
        for l1 in [0.1, 0.2]:
            for l2 in [1, 2]:
                r = row("crown", "irregular-grid", f"lambda_1={l1};lambda_2={l2}", "walk",
                        "primary", 10.0 * l1 + l2, 0.01)
                r["memory_bytes"] = 1e6
                rows.append(r)
        newer = [dict(rows[0], trace_ms_median=1.0, mrays_per_s=1000.0)]
        (d1, d2), _ = run_dirs(self.tmp.name, "irregular-lambda", [rows, newer],
                               header=HEADER + ["memory_bytes"])
        out, err = run2("irregular-figure6.py", d1, d2, "--no-plot")
        self.assertIn("note: 1 row(s) of", err)
        self.assertIn("1e+03]", out)  # the newer row's 1000 MRays/s is the max
        self.assertIn("Memory: memory_bytes", out)  # rows without structure_bytes
        # With the structure alone (`structure_bytes`) the memory column reads it.
        for r in rows:
            r["structure_bytes"] = 4e5
        p = os.path.join(self.tmp.name, "f6s.csv")
        write(p, rows, HEADER + ["memory_bytes", "structure_bytes"])
        out = run("irregular-figure6.py", p, "--no-plot")
        self.assertIn("Memory: structure_bytes (the structure alone)", out)
        self.assertIn("[0.4, 0.4]", out)

    def test_irregular_table4(self):
        first = dynamic_rows(spp_irregular=4, lam=0.3)
        # The second run chose other densities for the same budgets: its rows still replace
        # the first's (the chosen densities are not part of a row's identity).
        second = dynamic_rows(spp_irregular=10, lam=0.2)
        (d1, d2), base = run_dirs(self.tmp.name, "irregular-dynamic", [first, second],
                                  file="dynamic.csv", header=DYNAMIC_HEADER)
        out, err = run2("irregular-table4.py", d1, d2)
        self.assertIn("note: 12 row(s) of", err)
        self.assertIn("irregular 10 vs two-level 5 spp (median over frames): agree", out)
        self.assertIn("0.2, 1.6", out)
        self.assertNotIn("0.3, 2.4", out.split("The paper")[0])
        self.assertIn("records no `noisy` flag", out)
        out, _ = run2("irregular-table4.py", base)  # results/NAME -> LATEST/dynamic.csv
        self.assertIn("irregular 10 vs two-level 5", out)

    def test_irregular_tables_and_multikd(self):
        header = HEADER + ["memory_bytes", "build_heap_peak_bytes", "build_heap_kept_bytes"]
        (d1,), _ = run_dirs(self.tmp.name, "irregular-grid", [irregular_rows()], header=header)
        out = run("irregular-tables.py", d1)
        self.assertIn("sponza 3.00x -> agree", out)
        (d2,), base = run_dirs(self.tmp.name, "multikd", [table5_rows()])
        out = run("multikd-table5.py", base)
        self.assertIn("2 views, steps=equal, mism 0", out)

    @unittest.skipUnless(HAVE_MPL or REQUIRE_MPL, MPL_NOTICE)
    def test_plot_folders(self):
        (d1, d2), base = run_dirs(self.tmp.name, "sweep", [sweep_rows()[:40], sweep_rows()[40:]])
        out = run("plot.py", "sweep", d1, d2, "--param", "max_leaf")
        # The PNG goes beside the last file.
        self.assertIn(os.path.join(d2, "results-sweep-max_leaf.png"), out)
        out = run("plot.py", base)  # auto-detected: bars, from LATEST/results.csv
        self.assertIn("results-bars.png", out)
        cols, rows = convergence_rows()
        c1 = os.path.join(self.tmp.name, "conv")
        os.makedirs(c1)
        write(os.path.join(c1, "convergence.csv"), rows, cols)
        out = run("plot.py", c1)  # a folder with only convergence.csv: convergence
        self.assertIn(os.path.join(c1, "convergence.png"), out)


class Noise(unittest.TestCase):
    """Finding 4: every table script marks timings of noisy rows and offers --drop-noisy."""

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)

    def path(self, name, rows, header=HEADER):
        p = os.path.join(self.tmp.name, name)
        write(p, rows, header)
        return p

    def test_irregular_table3_win_from_noisy_row(self):
        # Table 3's SBVH row at view b noisy: the irregular grid's "win" there is marked.
        rows = irregular_rows()
        for r in rows:
            if r["scene"] == "sponza@b" and r["params"] == "builder=sbvh":
                r["noisy"] = "true"
        p = self.path("irr.csv", rows,
                      HEADER + ["memory_bytes", "build_heap_peak_bytes", "build_heap_kept_bytes"])
        out = run("irregular-tables.py", p)
        self.assertIn("10.00† / 14.00 (+40%)†", out)
        self.assertIn("ours faster in 2 of 2 scene x view x ray kind cells; 1 of the 2 wins and "
                      "0 of the 0 losses rest on a noisy row†", out)
        self.assertIn("† noisy timing (1 of 16 timed rows)", out)
        out = run("irregular-tables.py", p, "--drop-noisy")
        self.assertIn("ours faster in 1 of 1 scene x view x ray kind cells (1 cell(s) left out",
                      out)
        self.assertNotIn("†", out)
        # Counters (N_T, N_I) are not timings: the Table 1 claim stays.
        self.assertIn("sponza N_T -76 %, N_I +75 % -> agree", out)

    def test_irregular_table5_claim_from_noisy_row(self):
        rows = irregular_rows()
        for r in rows:
            if r["scene"] == "sponza" and r["params"] == "lambda=5;macro_regions=true":
                r["noisy"] = "true"
        p = self.path("irr5.csv", rows,
                      HEADER + ["memory_bytes", "build_heap_peak_bytes", "build_heap_kept_bytes"])
        out = run("irregular-tables.py", p)
        self.assertIn("sponza +24 %†, memory M + E 2.5 MB vs E 9.0 MB -> agree†", out)
        out = run("irregular-tables.py", p, "--drop-noisy")
        self.assertIn("sponza - (a noisy timing left out)", out)

    def test_multikd_negative_share_within_noise(self):
        rows = table5_rows()
        for r in rows:
            if r["traversal"].endswith("-sorted") and r["ray_kind"] == "path1" \
                    and "sphere-orth" in r["params"]:
                # 7.9 ms against -presorted's 8 ms, CIs of 10 %: overlapping.
                r["trace_ms_median"], r["mrays_per_s"] = 7.9, 1e6 / 7.9 / 1000
        out = run("multikd-table5.py", self.path("neg.csv", rows))
        line = next(ln for ln in out.splitlines() if ln.strip().startswith("ours SPONZA")
                    and "125.00" in ln)
        self.assertIn("noise‡", line)
        self.assertNotIn("%!", line)
        self.assertNotRegex(line, r"-\d+\.\d%")  # no negative share printed as a figure
        self.assertIn("‡ noise: the sort's share came out negative", out)
        self.assertIn("within noise", out)

    def test_multikd_negative_share_beyond_noise(self):
        rows = table5_rows()
        for r in rows:
            r["trace_ms_ci"] = 0.01
            if r["traversal"].endswith("-sorted") and r["ray_kind"] == "path1" \
                    and "sphere-orth" in r["params"]:
                r["trace_ms_median"], r["mrays_per_s"] = 5.0, 0.2
        out = run("multikd-table5.py", self.path("neg2.csv", rows))
        self.assertIn("-60.0%!", out)
        self.assertIn("! a negative share beyond the CIs", out)
        self.assertNotIn("‡", out)

    def test_multikd_noisy_and_drop(self):
        rows = table5_rows()
        for r in rows:
            if r["scene"] == "sponza@2" and r["traversal"].endswith("-sorted") \
                    and r["ray_kind"] == "path1" and "sah" in r["params"]:
                r["noisy"] = "true"
        p = self.path("t5n.csv", rows)
        out = run("multikd-table5.py", p)
        line = next(ln for ln in out.splitlines() if ln.strip().startswith("ours SPONZA")
                    and "125.00" in ln)
        # SPHERE-ORTH's inc. gain is against SAH's noisy -sorted pool: the gain is marked, its
        # own MRays/s and the share (from the clean sphere-orth rows) are not.
        self.assertIn("100.00  (-100.00)†", line)
        self.assertIn(" 20.0% ", line + " ")
        self.assertIn("† noisy timing (1 of 24 timed rows)", out)
        out, err = run2("multikd-table5.py", p, "--drop-noisy")
        self.assertIn("left out", err)
        self.assertIn("1-2 views (pools differ: compare with care)", out)
        self.assertNotIn("†", out)

    def test_sparse_noisy_and_drop(self):
        p = self.path("s.csv", sparse_rows(noisy={("2", "btr")}), SPARSE_HEADER)
        out = run("sparse-table1.py", p)
        ours = out[out.index("ours:"):]
        self.assertIn("0.009†", ours)                       # BTR's T_R
        self.assertIn("HTR T_R / BTR T_R = 1.111†", ours)    # built from it
        self.assertIn("SLTR T_R / HTR T_R = 1.400 ", ours)   # not
        self.assertIn("† noisy timing (1 of 8 timed rows)", out)
        out = run("sparse-table1.py", p, "--drop-noisy")
        self.assertIn("HTR T_R / BTR T_R = 1.111 (over the 1 view(s) both timed)", out)
        ours = out[out.index("ours:"):]
        btr = next(ln for ln in ours.splitlines() if ln.strip().startswith("BTR "))
        self.assertEqual(btr.split()[-3:-1], ["2", "1"])  # views 2, timed 1
        self.assertNotIn("†", ours)

    def test_irregular_figure6_noisy(self):
        rows = []
        for l1 in [0.1, 0.2]:
            r = row("crown", "irregular-grid", f"lambda_1={l1};lambda_2=1", "walk", "primary",
                    10.0 if l1 == 0.1 else 20.0, 0.01, noisy=l1 == 0.1)
            r["memory_bytes"] = 1e6
            rows.append(r)
        p = self.path("f6.csv", rows, HEADER + ["memory_bytes"])
        out = run("irregular-figure6.py", p, "--no-plot")
        self.assertIn("[50, 100†]", out)
        self.assertIn("† noisy timing (1 of 2 timed rows)", out)
        out = run("irregular-figure6.py", p, "--no-plot", "--drop-noisy")
        self.assertIn("[50, 50]", out)

    def test_irregular_table4_noisy_column(self):
        rows = dynamic_rows()
        for r in rows:
            r["noisy"] = "true" if r["structure"] == "irregular-grid" and r["frame"] == 0 \
                else "false"
        p = self.path("dynamic.csv", rows, DYNAMIC_HEADER + ["noisy"])
        out = run("irregular-table4.py", p)
        self.assertIn("irregular 10† vs two-level 5 spp (median over frames): agree†", out)
        self.assertIn("† noisy timing (2 of 12 frames)", out)
        out = run("irregular-table4.py", p, "--drop-noisy")
        self.assertNotIn("†", out)


class SparseBoxes(unittest.TestCase):
    """Findings 2 and 3: the paper's figures only for primary rays; HTR as a line over d_min."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.csv = os.path.join(cls.tmp.name, "results.csv")
        write(cls.csv, sparse_rows(), SPARSE_HEADER)
        cls.dmin = os.path.join(cls.tmp.name, "dmin.csv")
        write(cls.dmin, dmin_rows())

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_primary_prints_the_paper(self):
        out = run("sparse-table1.py", self.csv)
        self.assertIn("paper: 'arena", out)
        self.assertIn("(paper: 0.848 arena, 0.864 city)", out)
        self.assertIn("BTR N_I / HTR N_I = 0.875 (paper: 0.848 arena, 0.864 city)", out)

    def test_shadow_does_not_print_the_paper(self):
        out = run("sparse-table1.py", self.csv, "--ray-kind", "shadow")
        self.assertNotIn("paper: 'arena", out)
        for figure in ["0.848", "86.85", "1.04-1.10", "about 1.46", "1.31 arena"]:
            self.assertNotIn(figure, out)
        self.assertIn("paper: primary rays only", out)
        self.assertIn("BTR N_I / HTR N_I = 0.875 (paper: primary rays only)", out)
        self.assertIn("shadow rays", out)

    def test_config_runs_htr(self):
        try:
            import tomllib
        except ImportError:
            self.skipTest("tomllib needs Python 3.11")
        with open(os.path.join(ROOT, "configs", "sparse-dmin.toml"), "rb") as f:
            config = tomllib.load(f)
        travs = {t for s in config["structure"] if s["name"] == "sparse-boxes"
                 for t in s.get("traversals", [])}
        self.assertTrue({"htr", "btr", "sltr"} <= travs, travs)

    @unittest.skipUnless(HAVE_MPL or REQUIRE_MPL, MPL_NOTICE)
    def test_dmin_sweep_htr_line(self):
        # Without --line: HTR is one point at d_min = 2, and the script says how to draw it.
        out = run("plot.py", "sweep", self.dmin, "--param", "d_min", "--metric",
                  "interior_per_ray", "--out", os.path.join(self.tmp.name, "a.png"))
        self.assertIn("--line traversal=htr", out)
        self.assertIn("sponza sparse-boxes htr", out)
        # With it: a dashed line per scene, no hint.
        for metric in ["interior_per_ray", "trace_ms_median"]:
            out = run("plot.py", "sweep", self.dmin, "--param", "d_min", "--metric", metric,
                      "--line", "traversal=htr")
            self.assertNotIn("single d_min value", out)
            png = os.path.join(self.tmp.name, f"dmin-sweep-d_min-{metric}.png")
            self.assertIn(png, out)
            with open(png, "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")


class Variation(unittest.TestCase):
    """variation.py --summary: per row the spread of its median between each arm's processes,
    and of its ratio to the first row of its timing group."""

    def test_spreads_between_processes(self):
        header = ["scene", "structure", "params", "traversal", "ray_kind", "threads",
                  "trace_ms_median", "trace_ms_ci", "timing_group"]
        with tempfile.TemporaryDirectory() as tmp:
            # Arm a: medians 10, 20 (max/min 2); arm b: 10, 11. Row y is twice row x in
            # every process of both arms: the paired ratio does not move.
            for arm, ms in [("a", [10.0, 20.0]), ("b", [10.0, 11.0])]:
                for i, m in enumerate(ms):
                    d = os.path.join(tmp, f"{arm}-{i:02d}")
                    os.makedirs(d)
                    rows = [{"scene": "s", "structure": "bvh", "params": "width=8",
                             "traversal": t, "ray_kind": "primary", "threads": "1",
                             "trace_ms_median": m * k, "trace_ms_ci": 0.05,
                             "timing_group": "g"} for t, k in [("x", 1), ("y", 2)]]
                    write(os.path.join(d, "results.csv"), rows, header)
            out = run("variation.py", "--summary", "--out", tmp, "--arm", "a:",
                      "--arm", "b:env:K=V")
        self.assertIn("a: 2 processes; rows' median max/min, geometric mean 2.000", out)
        self.assertIn("b: 2 processes; rows' median max/min, geometric mean 1.100", out)
        self.assertIn("a: paired ratios (row / first row of its timing group), 1: max/min "
                      "geometric mean 1.000", out)


class GpuTargets(unittest.TestCase):
    """gpu-targets.py: the GPU targets' verdicts from a reference folder: the spread of each
    row's rounds, the medians between two folders, the SBVH's rate on the Conference at
    1024x1024 and the irregular grid's rate against it on Sponza."""

    HEADER = ["scene", "structure", "params", "traversal", "device", "adapter", "ray_kind",
              "rays", "trace_ms_median", "trace_ms_runs"]
    SBVH = "builder=sbvh;width=2;max_leaf=8;c_trav=2"
    GRID = "lambda_1=0.12;lambda_2=2.4;merge=true;expansion=3"

    def rows(self, scale=1.0, adapter="NVIDIA H200"):
        full = 1024 * 1024

        def r(scene, structure, params, traversal, kind, rays, ms, runs=None):
            ms *= scale
            runs = runs or [ms, ms, ms]
            return {"scene": scene, "structure": structure, "params": params,
                    "traversal": traversal, "device": "gpu", "adapter": adapter,
                    "ray_kind": kind, "rays": rays, "trace_ms_median": ms,
                    "trace_ms_runs": ";".join(str(x) for x in runs)}

        return [
            # Conference: 2.1 and 1.05 GRays/s primary; AO 600K rays at 2.4 GRays/s.
            r("conference@a", "bvh", self.SBVH, "while-while-speculative", "primary", full,
              full / 2.1e6),
            r("conference@a", "bvh", self.SBVH, "ordered", "primary", full, full / 1.05e6),
            r("conference@a", "bvh", self.SBVH, "while-while-speculative", "ao", 600000,
              600000 / 2.4e6),
            # A 256x256 image is not the target's.
            r("conference@b", "bvh", self.SBVH, "ordered", "primary", 65536, 0.001),
            # Sponza: the grid at 1.2x the fastest SBVH; a round 10 % off its median.
            r("sponza@a", "bvh", self.SBVH, "while-while-speculative", "primary", full,
              full / 2.0e6, runs=[0.5, 0.5, 0.55]),
            r("sponza@a", "irregular-grid", self.GRID, "walk", "primary", full, full / 2.4e6),
            r("sponza@a", "irregular-grid", "lambda_1=5;merge=true;expansion=3", "walk",
              "primary", full, 0.01),
        ]

    def folder(self, tmp, name, rows):
        d = os.path.join(tmp, name, "runs", "paper", "1-table3")
        os.makedirs(d)
        write(os.path.join(d, "results.csv"), rows, self.HEADER)
        return os.path.join(tmp, name)

    def test_the_lines_and_their_verdicts(self):
        with tempfile.TemporaryDirectory() as tmp:
            new = self.folder(tmp, "new", self.rows())
            old = self.folder(tmp, "old", self.rows(scale=1.03)[:-2] + self.rows(2.0)[-2:])
            out = run("gpu-targets.py", new, "--against", old)
        self.assertIn("new: 7 GPU rows; adapter: NVIDIA H200", out)
        self.assertIn("timing within one run: 6 of 7 rows timed in 3 or more rounds within "
                      "±5% of their median: does not hold", out)
        self.assertIn("+10.0% at worst: runs/paper/1-table3/results.csv: sponza@a "
                      "bvh/while-while-speculative primary", out)
        self.assertIn("timing between runs: 5 of 7 rows found in both within ±5%: "
                      "does not hold", out)
        self.assertIn("-50.0%: runs/paper/1-table3/results.csv: sponza@a irregular-grid/walk", out)
        self.assertIn("Conference primary rays at 1024x1024, fastest traversal >= 2.0 "
                      "GRays/s: holds", out)
        self.assertIn("2.10 GRays/s runs/paper/1-table3/results.csv: conference@a "
                      "bvh/while-while-speculative primary", out)
        # The 256x256 image is not the target's.
        self.assertNotIn("conference@b", out[out.index("binary SBVH"):])
        self.assertNotIn("conference@a", out[:out.index("timing between runs")])
        self.assertIn("Conference ao rays at 1024x1024, fastest traversal >= 2.5 GRays/s: "
                      "does not hold", out)
        self.assertIn(">= 1.0x the fastest binary SBVH: holds", out)
        self.assertIn("1.20x: runs/paper/1-table3/results.csv: sponza@a irregular-grid/walk "
                      "primary 2.40 GRays/s; against 1.20x while-while-speculative", out)

    def test_software_rows_are_refused_without_the_flag(self):
        with tempfile.TemporaryDirectory() as tmp:
            d = self.folder(tmp, "soft", self.rows(adapter="llvmpipe (LLVM 15)"))
            p = subprocess.run([sys.executable, os.path.join(HERE, "gpu-targets.py"), d],
                               capture_output=True, text=True)
            self.assertNotEqual(p.returncode, 0)
            self.assertIn("rows of a software adapter (llvmpipe (LLVM 15))", p.stderr)
            self.assertIn("holds", run("gpu-targets.py", d, "--software"))


class GpuDevice(unittest.TestCase):
    """gpu-device.sh: its usage, and `run` refuses to start without the device's OUT (the
    whole path, `run --smoke` with OUT set, takes a lavapipe smoke run: checked by hand)."""

    def call(self, *args, env=None):
        return subprocess.run(["bash", os.path.join(HERE, "gpu-device.sh"), *args],
                              capture_output=True, text=True, env=env)

    def test_usage(self):
        p = self.call()
        self.assertEqual(p.returncode, 2)
        self.assertIn("usage: scripts/gpu-device.sh pack | run [--smoke]", p.stderr)

    def test_run_needs_out(self):
        env = {k: v for k, v in os.environ.items() if k != "OUT"}
        p = self.call("run", env=env)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("OUT, the device tool folder, is not set", p.stderr)


class WithoutMatplotlib(unittest.TestCase):
    @unittest.skipIf(HAVE_MPL, "matplotlib is installed")
    def test_plot_says_what_it_needs(self):
        p = subprocess.run([sys.executable, os.path.join(HERE, "plot.py"), "bars", "x.csv"],
                           capture_output=True, text=True)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("plot.py needs matplotlib", p.stderr)
        self.assertNotIn("Traceback", p.stderr)

    def test_tables_need_no_matplotlib(self):
        # The table scripts import nothing beyond the standard library (and common.py).
        for script in ["table.py", "sparse-table1.py", "irregular-tables.py",
                       "irregular-table4.py", "multikd-table5.py", "irregular-figure6.py"]:
            with open(os.path.join(HERE, script)) as f:
                top = re.findall(r"^(?:import|from) (\w+)", f.read(), re.M)
            self.assertNotIn("matplotlib", top, script)


class CheckDocs(unittest.TestCase):
    """check-docs.py: the documents' names exist in the code, and a stale one fails."""

    @classmethod
    def setUpClass(cls):
        spec = importlib.util.spec_from_file_location(
            "check_docs", os.path.join(HERE, "check-docs.py"))
        cls.m = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(cls.m)
        cls.code = cls.m.Code()

    def unknown(self, text, path="docs/x.md"):
        return self.m.check_doc(path, text, self.code)

    def test_the_documents_pass(self):
        self.assertEqual(self.m.main([]), 0)

    def test_stale_names_fail(self):
        # Each was cited once in the docs while the code said otherwise.
        for stale, why in [
            ("`registry::generator_params`", "`generator_params` is not in registry"),
            ("`multi::ARRANGE_BLOCK`", "`multi` is no crate, module or type"),
            ("`Traversal::new`", "`new` is no member of `Traversal`"),
            ("`bvh/ordered-w16`", "appears nowhere"),
            ("`configs/nope.toml`", "does not exist"),
            ("`shaders/nope.wgsl`", "no file's path ends with"),
            ("`no_such_column`", "no word of the code"),
            ("`run.no_such_key`", "no word of the code"),
            ("`trace-bench run configs/ci.toml --no-such-flag`", "has no flag `--no-such-flag`"),
            ("`cargo test --release -p tb-nope`", "package `tb-nope` unknown"),
            ("`cargo test -p tb-kdtree --test nope`", "test `nope` unknown"),
            ("`--no-such-flag`", "flag `--no-such-flag`"),
            ("[GPU](README.md#no-such-heading)", "has no heading"),
        ]:
            errs = self.unknown(stale, path="ARCHITECTURE.md")
            self.assertEqual(len(errs), 1, (stale, errs))
            self.assertIn(why, errs[0])

    def test_current_names_pass(self):
        for good in ["`registry::generator`", "`tb_multikd::ARRANGE_BLOCK`", "`Traversal::cpu`",
                     "`bvh/ordered-w8`", "`rtree/stackless-mM`", "`kdtree/short-stack-N`",
                     "`GpuProgram::needs_f64`", "`tb_core::for_each_counter!`",
                     "`shaders/kd.wgsl`", "`trace_ms_ci`", "`run.threads`", "`--resume`",
                     "`gpu_required = false`", "`cargo test --release -p tb-kdtree --test gpu`",
                     "`trace-bench list --markdown --details`", "[GPU](README.md#gpu)"]:
            self.assertEqual(self.unknown(good, path="ARCHITECTURE.md"), [], good)

    def test_a_span_may_cross_a_line_break(self):
        errs = self.unknown("the tests\n(`cargo test --release\n-p tb-nope`) and more")
        self.assertEqual(len(errs), 1, errs)
        self.assertTrue(errs[0].startswith("docs/x.md:2: "), errs)

    def test_shape(self):
        setup = "\n".join(self.m.SETUP)
        ok = {"README.md": "# t\n" + setup + "\n", "ARCHITECTURE.md": "a\n" * 200}
        self.assertEqual(self.m.check_shape(self.code, ok), [])
        late = {"README.md": "\n" * 40 + setup, "ARCHITECTURE.md": "a\n" * 201}
        errs = self.m.check_shape(self.code, late)
        self.assertEqual(len(errs), 3, errs)
        self.assertIn("201 lines", errs[2])


if __name__ == "__main__":
    if not HAVE_MPL:
        if REQUIRE_MPL:
            print(f"error: TRACE_BENCH_REQUIRE_MATPLOTLIB is set, but {MPL_NOTICE}",
                  file=sys.stderr)
        else:
            print(f"notice: {MPL_NOTICE}", file=sys.stderr)
    unittest.main()
