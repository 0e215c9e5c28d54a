#!/usr/bin/env python3
"""Figure 6 of Pérard-Gayot et al. 2017 ("GPU Ray Tracing using Irregular Grids") and our
Table 2 beside the paper's, from a results.csv of configs/irregular-lambda.toml.

Figure 6: per scene (default `crown`), two heat maps over the λ_1 x λ_2 sweep of the irregular
grid: build time (ms) and primary-ray traversal time (ms, median), written as a PNG beside the
CSV (`--out` to choose). Table 2 (printed): per scene, the irregular grid's [min, max] over the
sweep of build time, MRays/s and memory, the two-level grid at its fastest pair, the SBVH.

    python3 scripts/irregular-figure6.py results/irregular-lambda/LATEST [--scene crown]
        [--threads N] [--out fig6.png] [--no-plot] [--drop-noisy]

Several CSVs or run folders (FOLDER/results.csv) are read as one; a later file's rows replace
the same rows of an earlier one (a note on stderr says how many); the PNG goes beside the last.
MRays/s of a noisy row (Table 2: a [min, max] end, the two-level grid's best, the SBVH) and a
noisy cell of the primary-ray map are marked †; --drop-noisy leaves the timings of noisy rows
out (their map cells are blank; build times, memory and counters stay). Only the plot needs
matplotlib.
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (add_noisy_option, drop_noisy, is_noisy, mark,  # noqa: E402
                    memory_column, noisy_footnote, number, params_of, read_csvs)

# The paper's Table 2 (Titan X; SBVH build on one CPU core): build s [ours lo, hi], 2L, SBVH;
# MRays/s [ours lo, hi], 2L; memory MB [ours lo, hi], 2L, SBVH.
PAPER = {
    "Sponza (262K)": ((0.012, 0.026), 0.007, 9, (201, 653), 145, (4, 23), 24, 20),
    "Conference (283K)": ((0.016, 0.022), 0.007, 7, (182, 597), 77, (4, 12), 27, 21),
    "Hairball (2.9M)": ((0.349, 0.893), 0.177, 336, (79, 148), 37, (138, 779), 668, 413),
    "Crown (3.5M)": ((0.066, 0.203), 0.039, 44, (115, 296), 74, (53, 278), 182, 241),
    "San Miguel (7.9M)": ((0.162, 0.492), 0.071, 95, (97, 291), 63, (107, 565), 323, 510),
}


def pick_threads(rows, want):
    ts = sorted({int(r["threads"]) for r in rows if r.get("device", "cpu") == "cpu"})
    if not ts:
        sys.exit("error: no CPU rows")
    if want is not None:
        if want not in ts:
            sys.exit(f"error: no rows with {want} threads (have {ts})")
        return want
    return ts[-1]


def table2(rows):
    print("Table 2 (ours; the paper's below). Build s, MRays/s, memory MB; irregular grid over")
    print("the λ sweep [min, max], two-level grid at its fastest pair, SBVH.")
    mem = memory_column(rows)
    print(f"Memory: {mem}" + (" (the structure alone)" if mem == "structure_bytes" else ""))
    scenes = sorted({r["scene"] for r in rows})
    head = f"{'scene':<22} {'build ours':>16} {'2L':>7} {'SBVH':>7} {'MRays ours':>14} {'2L':>6} {'SBVH':>6} {'MB ours':>14} {'2L':>7} {'SBVH':>7}"
    print(head)
    for s in scenes:
        rs = [r for r in rows if r["scene"] == s]
        ig = [r for r in rs if r["structure"] == "irregular-grid"]
        tl = [r for r in rs if r["structure"] == "two-level-grid"]
        bv = [r for r in rs if r["structure"] == "bvh"]

        def rng(rr, col, scale=1.0):
            rr = [r for r in rr if number(r.get(col)) is not None]
            if not rr:
                return "-"
            lo = min(rr, key=lambda r: number(r[col]))
            hi = max(rr, key=lambda r: number(r[col]))
            # A timing end from a noisy row is marked (build times and memory have no flag).
            m = (lambda r: mark(is_noisy(r))) if col == "mrays_per_s" else (lambda r: "")
            return f"[{number(lo[col]) * scale:.3g}{m(lo)}, {number(hi[col]) * scale:.3g}{m(hi)}]"

        def best(rr):
            rr = [r for r in rr if number(r["mrays_per_s"]) is not None]
            return max(rr, key=lambda r: number(r["mrays_per_s"])) if rr else None

        def one(r, col, scale=1.0):
            if not r or number(r.get(col)) is None:
                return "-"
            return f"{number(r[col]) * scale:.3g}" + (mark(is_noisy(r)) if col == "mrays_per_s"
                                                      else "")

        t, b = best(tl), best(bv)
        print(
            f"{s:<22} {rng(ig, 'build_ms', 1e-3):>16} {one(t, 'build_ms', 1e-3):>7} {one(b, 'build_ms', 1e-3):>7} "
            f"{rng(ig, 'mrays_per_s'):>14} {one(t, 'mrays_per_s'):>6} {one(b, 'mrays_per_s'):>6} "
            f"{rng(ig, mem, 1e-6):>14} {one(t, mem, 1e-6):>7} {one(b, mem, 1e-6):>7}"
        )
        if t:
            p = params_of(t)
            print(f"{'':<22} two-level best at λ_1 = {p.get('lambda_1')}, λ_2 = {p.get('lambda_2')}")
    note = noisy_footnote(rows)
    if note:
        print(note)
    print("\nThe paper (Titan X):")
    for s, (ob, tb, sb, om, tm, omem, tmem, smem) in PAPER.items():
        print(
            f"{s:<22} {str(list(ob)):>16} {tb:>7} {sb:>7} {str(list(om)):>14} {tm:>6} {'':>6} "
            f"{str(list(omem)):>14} {tmem:>7} {smem:>7}"
        )


def figure6(rows, scene, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ig = [r for r in rows if r["scene"] == scene and r["structure"] == "irregular-grid"]
    if not ig:
        sys.exit(f"error: no irregular-grid rows for scene `{scene}`")
    l1 = sorted({float(params_of(r)["lambda_1"]) for r in ig})
    l2 = sorted({float(params_of(r)["lambda_2"]) for r in ig})
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    n_noisy = sum(is_noisy(r) for r in ig if number(r["trace_ms_median"]) is not None)
    for ax, (col, title) in zip(axes, [("build_ms", "build time (ms)"), ("trace_ms_median", "primary rays (ms)")]):
        grid = [[float("nan")] * len(l1) for _ in l2]
        noisy = [[False] * len(l1) for _ in l2]
        for r in ig:
            p = params_of(r)
            v = number(r[col])
            if v is not None:
                j, i = l2.index(float(p["lambda_2"])), l1.index(float(p["lambda_1"]))
                grid[j][i] = v
                noisy[j][i] = col == "trace_ms_median" and is_noisy(r)
        im = ax.imshow(grid, origin="lower", cmap="viridis", aspect="auto")
        for j, rowv in enumerate(grid):
            for i, v in enumerate(rowv):
                if v == v:
                    ax.text(i, j, f"{v:.0f}{mark(noisy[j][i])}", ha="center", va="center",
                            color="w", fontsize=8)
        if col == "trace_ms_median" and n_noisy:
            title += f"\n† noisy: {n_noisy} of the cells"
        ax.set_xticks(range(len(l1)), [f"{v:g}" for v in l1])
        ax.set_yticks(range(len(l2)), [f"{v:g}" for v in l2])
        ax.set_xlabel("λ_1 (top level)")
        ax.set_ylabel("λ_2 (second level)")
        ax.set_title(title)
        fig.colorbar(im, ax=ax)
    t = ig[0]
    fig.suptitle(f"{scene}: irregular grid, {t['threads']} threads (cf. the paper's Figure 6, crown)")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("csv", nargs="+", metavar="CSV|FOLDER",
                    help="results.csv files or run folders of configs/irregular-lambda.toml")
    ap.add_argument("--scene", default="crown")
    ap.add_argument("--threads", type=int)
    ap.add_argument("--ray-kind", default="primary")
    ap.add_argument("--out")
    ap.add_argument("--no-plot", action="store_true", help="print Table 2 only")
    add_noisy_option(ap)
    a = ap.parse_args()
    rows, files = read_csvs(a.csv)
    rows = [r for r in rows if r["ray_kind"] == a.ray_kind]
    th = pick_threads(rows, a.threads)
    rows = [r for r in rows if int(r["threads"]) == th and r.get("device", "cpu") == "cpu"]
    rows = drop_noisy(rows, a.drop_noisy)
    print(f"{a.ray_kind} rays, {th} threads")
    table2(rows)
    if not a.no_plot:
        out = a.out or os.path.join(os.path.dirname(files[-1]), "results-figure6.png")
        figure6(rows, a.scene, out)


if __name__ == "__main__":
    main()
