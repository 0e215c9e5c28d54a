#!/usr/bin/env python3
"""Tables 1, 3 and 5 of Pérard-Gayot et al. 2017 ("GPU Ray Tracing using Irregular Grids")
beside the paper's, from results.csv files of configs/irregular-grid.toml (Tables 1, 5, the
build's memory) and configs/irregular-table3.toml (Table 3, two views per scene). Several CSVs
may be given; each table reads the rows it needs.

- Table 1: per scene, primary rays: N_T (nodes visited for the SBVH: interior + leaves; cells
  for the grid) and N_I (triangle tests) per ray and MRays/s, for the SBVH, the initial
  two-level irregular grid, + merge, + merge & expansion (λ_1 = 0.12, λ_2 = 2.4), each with
  its change against the SBVH.
- Table 3: per scene and view, MRays/s of the SBVH and the irregular grid (merge & expansion)
  for primary, AO and random rays.
- Table 5: the uniform grid at λ = 5 with macro regions (Devillers 1989) against merge (M),
  expansion (E) and both (M + E) on it: MRays/s of primary rays and memory.
- The build's peak heap against what it keeps (`build_heap_peak_bytes`, `..._kept_bytes`,
  measured by the binary's counting allocator).
Then the paper's claims, each with our figures. The paper ran on a Titan X: compare ratios.

Several CSVs or run folders (FOLDER/results.csv) are read as one; a later file's rows replace
the same rows of an earlier one (a note on stderr says how many). An MRays/s figure of a row
flagged `noisy`, and a change or claim built from one, is marked †; the footnote counts them,
and the Table 3 claim says how many of its wins and losses rest on a noisy row. --drop-noisy
leaves the timings of noisy rows out (their cells print -, and the claims skip them).

    python3 scripts/irregular-tables.py results/irregular-grid/LATEST \\
        results/irregular-table3/LATEST [--threads N] [--drop-noisy]
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (add_noisy_option, drop_noisy, is_noisy, mark,  # noqa: E402
                    memory_column, noisy_footnote, number, params_of, read_csvs)

# Table 1 of the paper (primary rays, Titan X): N_T, N_I, MRays/s.
PAPER_T1 = {
    "Sponza": {"SBVH": (35, 6, 409), "Initial grid": (16, 12, 454),
               "+ Merge": (12, 12, 511), "+ Merge & Exp.": (7, 11, 653)},
    "Crown": {"SBVH": (39, 11, 232), "Initial grid": (15, 18, 238),
              "+ Merge": (13, 18, 266), "+ Merge & Exp.": (11, 17, 296)},
    "San Miguel": {"SBVH": (55, 8, 227), "Initial grid": (28, 13, 206),
                   "+ Merge": (15, 13, 241), "+ Merge & Exp.": (10, 13, 291)},
}
# Table 3 (MRays/s): per scene, views (a, b): primary SBVH/ours, AO SBVH/ours; random SBVH/ours.
PAPER_T3 = {
    "Sponza 262K": ((409, 653), (265, 473), (270, 386), (187, 234), (166, 274)),
    "Conference 283K": ((583, 597), (523, 526), (303, 332), (326, 338), (295, 312)),
    "Hairball 2.9M": ((100, 148), (79, 93), (53, 69), (63, 61), (19, 26)),
    "Crown 3.5M": ((232, 296), (181, 191), (108, 120), (112, 125), (221, 238)),
    "San Miguel 7.9M": ((227, 291), (157, 180), (119, 119), (125, 115), (119, 160)),
}
# Table 5 (primary rays): MRays/s and memory MB for macro regions, M, E, M + E.
PAPER_T5 = {
    "Sponza": {"Macro regions": (167, 10), "Ours (M)": (169, 8), "Ours (E)": (182, 47),
               "Ours (M + E)": (185, 8)},
    "Conference": {"Macro regions": (108, 9), "Ours (M)": (116, 7), "Ours (E)": (121, 50),
                   "Ours (M + E)": (135, 8)},
}


def pct(v, ref, noisy=False):
    return f"({(v / ref - 1) * 100:+.0f}%){mark(noisy)}" if ref and v is not None else ""


def mrays(r):
    """(MRays/s of a row, whether the row is noisy); None when not timed (or dropped)."""
    v = number(r["mrays_per_s"])
    return v, v is not None and is_noisy(r)


def variant(r):
    """The row's name in the paper's tables, or None."""
    p = params_of(r)
    s = r["structure"]
    if s == "bvh":
        return {"sbvh": "SBVH", "binned": "BVH (binned)"}.get(p.get("builder"))
    if s == "uniform-grid":
        return "Macro regions" if p.get("macro_regions") == "true" else "Uniform grid"
    if s == "two-level-grid":
        return "Two-level grid"
    if s == "irregular-grid":
        merge = p.get("merge") == "true"
        exp = int(p.get("expansion", "0")) > 0
        if p.get("initial") == "uniform":
            return {(False, False): "Uniform (initial)", (True, False): "Ours (M)",
                    (False, True): "Ours (E)", (True, True): "Ours (M + E)"}[(merge, exp)]
        return {(False, False): "Initial grid", (True, False): "+ Merge",
                (False, True): "+ Exp. only", (True, True): "+ Merge & Exp."}[(merge, exp)]
    return None


def n_t(r):
    """N_T: cells visited for a grid, interior + leaf nodes for a tree."""
    c = number(r.get("cells_per_ray"))
    if c:
        return c
    i, leaves = number(r.get("interior_per_ray")), number(r.get("leaves_per_ray"))
    return (i or 0) + (leaves or 0) if i is not None or leaves is not None else None


def pick_threads(rows, want):
    ts = sorted({int(r["threads"]) for r in rows if r.get("device", "cpu") == "cpu"})
    if not ts:
        sys.exit("error: no CPU rows")
    if want is None:
        return ts[0]
    if want not in ts:
        sys.exit(f"error: no rows with {want} threads (have {ts})")
    return want


def f(v, fmt):
    return "-" if v is None else format(v, fmt)


def table1(rows):
    print("Table 1 (ours): primary rays, N_T and N_I per ray, MRays/s; change against the SBVH")
    names = ["SBVH", "Initial grid", "+ Merge", "+ Merge & Exp."]
    claims = []
    for scene in sorted({r["scene"].split("@")[0] for r in rows}):
        rs = {variant(r): r for r in rows if r["scene"] == scene and r["ray_kind"] == "primary"}
        if "SBVH" not in rs or "+ Merge & Exp." not in rs:
            continue
        b = rs["SBVH"]
        bt, bi = n_t(b), number(b["prims_per_ray"])
        bm, bn = mrays(b)
        print(f"  {scene}")
        for n in names:
            if n not in rs:
                continue
            r = rs[n]
            t, i = n_t(r), number(r["prims_per_ray"])
            m, mn = mrays(r)
            print(f"    {n:<16} N_T {f(t, '6.2f')} {pct(t, bt):>7}  N_I {f(i, '6.2f')} {pct(i, bi):>7}"
                  f"  {f(m, '7.2f')}{mark(mn) or ' '}MRays/s {pct(m, bm, mn or bn):>8}")
        me = rs["+ Merge & Exp."]
        claims.append((scene, n_t(me) / bt - 1, number(me["prims_per_ray"]) / bi - 1))
    print("  The paper's Table 1 (Titan X):")
    for scene, t in PAPER_T1.items():
        bt, bi, bm = t["SBVH"]
        print(f"  {scene}")
        for n, (nt, ni, m) in t.items():
            print(f"    {n:<16} N_T {nt:6d} {pct(nt, bt):>7}  N_I {ni:6d} {pct(ni, bi):>7}"
                  f"  {m:7d} MRays/s {pct(m, bm):>7}")
    return claims


def table3(rows):
    print("Table 3 (ours): MRays/s, SBVH and the irregular grid (merge & expansion), per view")
    print(f"  {'scene@view':<22} {'primary':>22} {'AO':>22} {'random':>22}")
    out = []
    for scene in sorted({r["scene"] for r in rows}):
        cells = []
        for kind in ("primary", "ao", "random"):
            rs = {variant(r): r for r in rows if r["scene"] == scene and r["ray_kind"] == kind}
            if "SBVH" in rs and "+ Merge & Exp." in rs:
                (s, sn), (o, on) = mrays(rs["SBVH"]), mrays(rs["+ Merge & Exp."])
                if s is None or o is None:
                    cells.append("-")
                    out.append((scene, kind, None, False))
                    continue
                cells.append(f"{s:.2f}{mark(sn)} / {o:.2f}{mark(on)} {pct(o, s, sn or on)}")
                out.append((scene, kind, o / s - 1, sn or on))
            else:
                cells.append("-")
        if any(c != "-" for c in cells):
            print(f"  {scene:<22} {cells[0]:>22} {cells[1]:>22} {cells[2]:>22}")
    print("  The paper's Table 3 (Titan X; SBVH / ours, views a and b):")
    for scene, (pa, pb, aa, ab, rnd) in PAPER_T3.items():
        print(f"  {scene:<18} primary {pa[0]}/{pa[1]} {pct(pa[1], pa[0])}, {pb[0]}/{pb[1]} "
              f"{pct(pb[1], pb[0])}; AO {aa[0]}/{aa[1]} {pct(aa[1], aa[0])}, {ab[0]}/{ab[1]} "
              f"{pct(ab[1], ab[0])}; random {rnd[0]}/{rnd[1]} {pct(rnd[1], rnd[0])}")
    return out


def table5(rows):
    print("Table 5 (ours): uniform grid at λ = 5, primary rays: MRays/s (against macro regions), MB")
    names = ["Macro regions", "Ours (M)", "Ours (E)", "Ours (M + E)"]
    col = memory_column(rows)
    print(f"  memory: {col}" + (" (the structure alone)" if col == "structure_bytes" else ""))
    out = {}
    for scene in sorted({r["scene"].split("@")[0] for r in rows}):
        rs = {variant(r): r for r in rows if r["scene"] == scene and r["ray_kind"] == "primary"}
        if "Macro regions" not in rs:
            continue
        base, bn = mrays(rs["Macro regions"])
        print(f"  {scene}")
        for n in names:
            if n in rs:
                (m, mn), mem = mrays(rs[n]), number(rs[n].get(col))
                print(f"    {n:<14} {f(m, '8.2f')}{mark(mn) or ' '}MRays/s "
                      f"{pct(m, base, mn or bn):>8}  {mem / 1e6:8.1f} MB")
        out[scene] = {n: (*mrays(rs[n]), number(rs[n].get(col)))
                      for n in names if n in rs}
    print("  The paper's Table 5 (Titan X; memory MB):")
    for scene, t in PAPER_T5.items():
        base = t["Macro regions"][0]
        print(f"  {scene}: " + "; ".join(f"{n} {m} {pct(m, base)} {mb} MB" for n, (m, mb) in t.items()))
    return out


def heap(rows):
    print("Build heap (measured): the most the build held at once and what it kept, MB; ratio")
    out = []
    seen = set()
    for r in rows:
        peak, kept = number(r.get("build_heap_peak_bytes")), number(r.get("build_heap_kept_bytes"))
        key = (r["scene"].split("@")[0], r["structure"], r["params"])
        if peak is None or not kept or key in seen:
            continue
        seen.add(key)
        name = variant(r) or r["structure"]
        print(f"  {key[0]:<22} {name:<18} peak {peak / 1e6:8.1f}  kept {kept / 1e6:8.1f}  "
              f"{peak / kept:5.2f}x")
        if name == "+ Merge & Exp.":
            out.append((key[0], peak / kept))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("csv", nargs="+", metavar="CSV|FOLDER",
                    help="results.csv files or run folders")
    ap.add_argument("--threads", type=int, default=None, help="default: the fewest")
    add_noisy_option(ap)
    a = ap.parse_args()
    rows, _ = read_csvs(a.csv)
    rows = [r for r in rows if r.get("device", "cpu") == "cpu" and r["triangle_test"]]
    th = pick_threads(rows, a.threads)
    rows = drop_noisy([r for r in rows if int(r["threads"]) == th], a.drop_noisy)
    print(f"(CPU rows with {th} thread(s))\n")
    t1 = table1([r for r in rows if "@" not in r["scene"]])
    print()
    t3 = table3(rows)
    print()
    t5 = table5([r for r in rows if "@" not in r["scene"]])
    print()
    hp = heap(rows)
    print("\nClaims (paper, then ours):")
    for scene, dt, di in t1:
        # The paper's cuts run from -72 % to -81 % (Table 1); a deeper cut agrees.
        print(f"  merge & expansion cut N_T by 50-80 % against the SBVH while N_I rises: {scene} "
              f"N_T {dt * 100:+.0f} %, N_I {di * 100:+.0f} % -> "
              f"{'agree' if dt <= -0.5 and di > 0 else 'disagree'}")
    for scene, t in t5.items():
        if {"Macro regions", "Ours (M + E)", "Ours (E)"} <= t.keys():
            (me, men, me_mem), (mr, mrn, _) = t["Ours (M + E)"], t["Macro regions"]
            less = me_mem < t["Ours (E)"][2]
            head = (f"  M + E beats macro regions (+11 % / +25 %) with less memory than E alone: "
                    f"{scene} ")
            mem = f"memory M + E {me_mem / 1e6:.1f} MB vs E {t['Ours (E)'][2] / 1e6:.1f} MB"
            if me is None or mr is None:
                print(head + f"- (a noisy timing left out), {mem}")
                continue
            g = me / mr - 1
            print(head + f"{g * 100:+.0f} %{mark(men or mrn)}, {mem} -> "
                  f"{'agree' if g > 0 and less else 'disagree'}{mark(men or mrn)}")
    for scene, ratio in hp:
        print(f"  the build peaks at 2.5-3x the final memory: {scene} {ratio:.2f}x -> "
              f"{'agree' if 2.0 <= ratio <= 3.5 else 'disagree'}")
    cells = [c for c in t3 if c[2] is not None]
    wins = [c for c in cells if c[2] > 0]
    if t3:
        nw, nl = sum(c[3] for c in wins), sum(c[3] for c in cells if c[2] <= 0)
        noisy = (f"; {nw} of the {len(wins)} wins and {nl} of the {len(cells) - len(wins)} "
                 "losses rest on a noisy row†" if nw or nl else "")
        left = len(t3) - len(cells)
        print(f"  the irregular grid is about as fast as the SBVH or faster (Table 3): ours faster in "
              f"{len(wins)} of {len(cells)} scene x view x ray kind cells{noisy}"
              + (f" ({left} cell(s) left out: a noisy timing dropped)" if left else ""))
    note = noisy_footnote(rows)
    if note:
        print("\n" + note)


if __name__ == "__main__":
    main()
