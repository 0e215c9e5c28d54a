#!/usr/bin/env python3
"""The GPU targets' verdicts from a GPU reference folder (scripts/gpu-reference.sh's OUT), each
line with its figures and a verdict (`holds`, `does not hold`, or `no rows`):

    python3 scripts/gpu-targets.py results/reference/DATE [--against results/reference/OLDER]

- timing within one run: every GPU row timed in at least 3 rounds has every round's time
  within ±5 % of the row's median (the same row at three positions of one run); the rows
  beyond it are listed (at most 5), or else the widest;
- timing between runs (with --against): the same row (the same results.csv path under each
  folder, scene, structure, params, traversal, ray kind and ray count) has medians within ±5 %
  (listed as above);
- the binary SBVH (`bvh`, builder sbvh, width 2) on the Conference at 1024 x 1024: primary rays
  at 2 GRays/s or more, AO rays (cast from that image) at 2.5 GRays/s or more, by its fastest
  traversal (every traversal listed);
- the irregular grid at the paper's densities, merge and expansion (λ_1 = 0.12, λ_2 = 2.4,
  merge, 3 passes) on Sponza primary rays: 1.0x or more of the fastest binary SBVH's rate on
  the same rays (each grid traversal listed, against each SBVH traversal).

Every results.csv under a folder is read; rows of other devices are ignored, and rows of a
software adapter (lavapipe) are refused unless --software (their times are not GPU figures).
Exit status 0 whatever the verdicts (they are results); 1 on bad input, with one line naming
the file (and line) and the problem. Standard library only (and common.py).
"""

import argparse
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import params_of, read_rows  # noqa: E402

TOLERANCE = 0.05
FULL = 1024 * 1024
SBVH_PRIMARY, SBVH_AO = 2.0, 2.5
KEY = ("scene", "structure", "params", "traversal", "ray_kind", "rays")


def is_num(p, k, want):
    try:
        return abs(float(p.get(k, "nan")) - want) <= 1e-9 * max(1.0, abs(want))
    except ValueError:
        return False


def rate(row):
    """GRays/s of the row's median time."""
    return int(row["rays"]) / float(row["trace_ms_median"]) / 1e6


def software(row):
    if row.get("adapter_type") == "software":
        return True
    a = row.get("adapter", "").lower()
    return any(s in a for s in ("llvmpipe", "lavapipe", "swiftshader", "softpipe"))


def read(folder, allow_software):
    """GPU rows of every results.csv under `folder`, each with its `file` (relative path)."""
    if not os.path.isdir(folder):
        sys.exit(f"error: {folder}: not a folder")
    rows = []
    for base, _, names in sorted(os.walk(folder)):
        if "results.csv" not in names:
            continue
        path = os.path.join(base, "results.csv")
        for line, r in enumerate(read_rows(path), start=2):
            if r.get("device") != "gpu" or not r.get("trace_ms_median"):
                continue
            try:
                ok = int(r["rays"]) > 0 and float(r["trace_ms_median"]) > 0
                [float(x) for x in (r.get("trace_ms_runs") or "").split(";") if x]
            except (KeyError, TypeError, ValueError):
                ok = False
            if not ok:
                sys.exit(f"error: {path}: line {line}: rays, trace_ms_median or "
                         "trace_ms_runs is not a positive number")
            if software(r) and not allow_software:
                sys.exit(f"error: {path}: rows of a software adapter ({r.get('adapter')}): "
                         "their times are not GPU figures (--software to read them)")
            r["file"] = os.path.relpath(path, folder)
            rows.append(r)
    return rows


def label(r):
    return f"{r['file']}: {r['scene']} {r['structure']}/{r['traversal']} {r['ray_kind']}"


def verdict(ok, n):
    return "no rows" if n == 0 else ("holds" if ok else "does not hold")


def within_run(rows):
    worst = []
    for r in rows:
        runs = [float(x) for x in r.get("trace_ms_runs", "").split(";") if x]
        if len(runs) < 3:
            continue
        m = statistics.median(runs)
        worst.append((max(abs(x / m - 1) for x in runs), r))
    worst.sort(key=lambda w: -w[0])
    bad = [w for w in worst if w[0] > TOLERANCE]
    print(f"timing within one run: {len(worst) - len(bad)} of {len(worst)} rows timed in 3 or "
          f"more rounds within ±{TOLERANCE:.0%} of their median: {verdict(not bad, len(worst))}")
    for d, r in (bad or worst)[:5]:
        print(f"  {d:+.1%} at worst: {label(r)} ({r['trace_ms_runs']} ms)")


def between_runs(rows, older):
    before = {(r["file"],) + tuple(r.get(k, "") for k in KEY): r for r in older}
    pairs = []
    for r in rows:
        o = before.get((r["file"],) + tuple(r.get(k, "") for k in KEY))
        if o is not None:
            pairs.append((float(r["trace_ms_median"]) / float(o["trace_ms_median"]) - 1, r, o))
    pairs.sort(key=lambda p: -abs(p[0]))
    bad = [p for p in pairs if abs(p[0]) > TOLERANCE]
    print(f"timing between runs: {len(pairs) - len(bad)} of {len(pairs)} rows found in both "
          f"within ±{TOLERANCE:.0%}: {verdict(not bad, len(pairs))}")
    for d, r, o in (bad or pairs)[:5]:
        print(f"  {d:+.1%}: {label(r)} ({o['trace_ms_median']} -> {r['trace_ms_median']} ms)")


def binary_sbvh(r):
    p = params_of(r)
    return r["structure"] == "bvh" and p.get("builder") == "sbvh" and p.get("width") == "2"


def in_scene(r, name):
    return r["scene"] == name or r["scene"].startswith(name + "@")


def full_images(rows, name):
    """(file, scene) of the 1024 x 1024 primary images of scene `name`."""
    return {(r["file"], r["scene"]) for r in rows if in_scene(r, name)
            and r["ray_kind"] == "primary" and int(r["rays"]) == FULL}


def sbvh_rate(rows):
    full = full_images(rows, "conference")
    for kind, goal in [("primary", SBVH_PRIMARY), ("ao", SBVH_AO)]:
        got = [r for r in rows if binary_sbvh(r) and r["ray_kind"] == kind
               and (r["file"], r["scene"]) in full]
        best = {}
        for r in got:
            k = (r["file"], r["scene"])
            if k not in best or rate(r) > rate(best[k]):
                best[k] = r
        ok = all(rate(r) >= goal for r in best.values())
        print(f"binary SBVH, Conference {kind} rays at 1024x1024, fastest traversal >= {goal} "
              f"GRays/s: {verdict(ok, len(best))}")
        for r in sorted(got, key=lambda r: (r["file"], r["scene"], -rate(r))):
            mark = " (fastest)" if best[(r["file"], r["scene"])] is r else ""
            print(f"  {rate(r):.2f} GRays/s {label(r)} {r['params']}{mark}")


def paper_grid(r):
    p = params_of(r)
    return (r["structure"] == "irregular-grid" and is_num(p, "lambda_1", 0.12)
            and is_num(p, "lambda_2", 2.4) and p.get("merge") == "true"
            and p.get("expansion") == "3")


def grid_vs_sbvh(rows):
    full = full_images(rows, "sponza")
    grids = [r for r in rows if paper_grid(r) and r["ray_kind"] == "primary"
             and (r["file"], r["scene"]) in full]
    ratios = []
    for g in grids:
        same = [r for r in rows if binary_sbvh(r) and r["file"] == g["file"]
                and r["scene"] == g["scene"] and r["ray_kind"] == "primary"
                and r["rays"] == g["rays"]]
        if not same:
            continue
        fastest = max(same, key=rate)
        ratios.append((rate(g) / rate(fastest), g, fastest, same))
    ok = all(x >= 1.0 for x, *_ in ratios)
    print(f"irregular grid (0.12, 2.4, merge, 3 passes), Sponza primary rays at 1024x1024, "
          f">= 1.0x the fastest binary SBVH: {verdict(ok, len(ratios))}")
    for x, g, fastest, same in ratios:
        others = ", ".join(f"{rate(g) / rate(s):.2f}x {s['traversal']}" for s in same)
        print(f"  {x:.2f}x: {label(g)} {rate(g):.2f} GRays/s; against {others}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", help="a GPU reference folder (gpu-reference.sh's OUT)")
    ap.add_argument("--against", help="an earlier reference folder, for the timing between runs")
    ap.add_argument("--software", action="store_true",
                    help="read a software adapter's rows (tests; not GPU figures)")
    a = ap.parse_args(argv)
    rows = read(a.folder, a.software)
    adapters = sorted({r.get("adapter", "") for r in rows})
    print(f"{a.folder}: {len(rows)} GPU rows; adapter: {', '.join(adapters) or 'none'}")
    within_run(rows)
    if a.against:
        between_runs(rows, read(a.against, a.software))
    sbvh_rate(rows)
    grid_vs_sbvh(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
