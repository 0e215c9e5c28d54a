#!/usr/bin/env python3
"""Self-test of the scripts: builds tiny CSVs in a temporary directory, checks table.py's
± spreads, sums, noisy marks, LaTeX output and `stat:KEY` / `a+b` values, and that plot.py
writes its PNGs (sweeps of summed metrics with --line reference rows included).
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
        self.assertIn("sponza 3.00x -> agree", out)
        # Table 3 reads the views: 14 / 10 MRays/s at view b.
        self.assertIn("sponza@b", out)
        self.assertIn("10.00 / 14.00 (+40%)", out)


if __name__ == "__main__":
    unittest.main()
