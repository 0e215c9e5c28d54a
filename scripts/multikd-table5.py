#!/usr/bin/env python3
"""Our Table 5 of Torres et al. 2012 ("Improving ray traversal by using several specialized
kd-trees", MRays/s with the sort by tree index included, "inc.", and not included, "n.inc.")
beside the paper's, from the results.csv of configs/multikd.toml (CPU rows) and, where given, of
its GPU run (GPU rows; the paper's figures are GPU figures).

Rows of structure `multi-kd` with `trees=multi`, traversal `recursive-direction` (rays as
generated, the tree picked per ray), `recursive-direction-presorted` (the arrangement by tree
found by the untimed hint pass: "n.inc.") and `recursive-direction-sorted` (the same
arrangement computed inside the timed call: "inc."). Per scene table (the label before `@`)
the views are pooled: MRays/s = all rays / all median trace times. Our primary rays are
one batch for both renderers. The sort's share of the
`inc.` time is (t_sorted - t_presorted) / t_sorted: both rows walk the same order with the same
kernel, so the difference is the sort alone (keys, counts, placing).

Primary rays (PT and AO alike) are not sorted in the paper (Morton order): one column per
heuristic, our plain row. Secondary (`path1`) and shadow (`ao`) rays: n.inc. and inc. per
heuristic, with our plain (unsorted) MRays/s and the sort share. Gains are the paper's,
100 * (1 - SAH / x) (the time saved against SAH; for secondary rays against SAH's own
column of the same kind: the paper gives SAH one value). `steps=` says whether the three rows'
traversal steps per ray (planes + prims) agree, as they must; `mism` sums oracle mismatches.

    python3 scripts/multikd-table5.py results/multikd/LATEST/results.csv [GPU.csv] [--threads N]

--threads picks one thread count of the CPU rows (the CSV's, e.g. 16 for the config's `0`); by
default each thread count gets its own tables, and the GPU rows theirs (the paper's figures are
GPU figures: compare gains and shares, not MRays/s).

GPU rows (`device = gpu`, e.g. `trace-bench run configs/multikd.toml --device gpu --structure
multi-kd:recursive-direction,multi-kd:recursive-direction-presorted,multi-kd:recursive-direction-sorted`):
tb-gpu sorts each dispatch's rays by tree index in compute passes timed on their own
(`sort_ms`); `-presorted` rows' time is the trace alone (n.inc.), `-sorted` rows' the sort plus
the trace (inc.), and the sort's share is `sort_ms` / the `-sorted` time.
"""

import argparse
import os
import sys
from collections import defaultdict

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import params_of, read_rows  # noqa: E402

MEASURES = ["sah", "sphere-orth", "sphere-obli", "cube-orth", "cube-obli"]
SCENES = {"bunny-boxed": "BUNNY", "conference": "CONFROOM", "sponza": "SPONZA",
          "sibenik": "SIBENIK"}
PLAIN = "recursive-direction"
PRE = PLAIN + "-presorted"
SORTED = PLAIN + "-sorted"

# The paper's Table 5 (GeForce 285 GTX, 1024x1024, several cameras). Primary rays: one value
# per heuristic; secondary and shadow rays: SAH one value, the others (n.inc., inc.).
PAPER = {
    ("PT", "primary"): {
        "BUNNY": [141.12, 147.45, 144.10, 144.44, 143.68],
        "F.FOREST": [101.70, 105.92, 105.78, 106.04, 105.54],
        "CONFROOM": [149.19, 156.16, 157.52, 155.91, 156.78],
        "SPONZA": [171.75, 178.78, 177.90, 178.41, 177.83],
        "SIBENIK": [143.31, 155.06, 156.16, 156.66, 156.83],
    },
    ("PT", "path1"): {
        "BUNNY": [36.29, (37.14, 36.12), (38.42, 37.33), (37.72, 36.67), (37.33, 36.30)],
        "F.FOREST": [19.36, (20.41, 20.09), (20.62, 20.29), (20.54, 20.22), (20.66, 20.33)],
        "CONFROOM": [26.21, (27.96, 27.37), (28.11, 27.51), (28.16, 27.57), (27.79, 27.21)],
        "SPONZA": [26.14, (28.47, 27.83), (28.52, 27.91), (28.45, 27.84), (28.73, 28.11)],
        "SIBENIK": [19.66, (21.72, 21.37), (21.76, 21.40), (21.71, 21.35), (21.76, 21.41)],
    },
    ("AO", "primary"): {
        "BUNNY": [78.72, 81.29, 80.36, 79.59, 79.71],
        "F.FOREST": [63.44, 65.09, 65.09, 64.92, 64.85],
        "CONFROOM": [87.87, 94.28, 94.45, 93.15, 94.29],
        "SPONZA": [112.70, 117.33, 116.82, 117.11, 116.32],
        "SIBENIK": [79.41, 83.08, 84.02, 83.93, 84.55],
    },
    ("AO", "ao"): {
        "BUNNY": [46.89, (48.00, 46.33), (48.28, 46.59), (47.04, 45.44), (47.19, 45.58)],
        "F.FOREST": [30.80, (32.02, 31.21), (32.26, 31.45), (32.27, 31.46), (32.23, 31.43)],
        "CONFROOM": [52.80, (54.88, 52.57), (54.72, 52.43), (55.32, 52.98), (55.11, 52.78)],
        "SPONZA": [47.02, (50.49, 48.65), (50.90, 49.03), (50.65, 48.79), (50.87, 49.00)],
        "SIBENIK": [37.07, (39.73, 38.58), (39.80, 38.64), (39.96, 38.79), (39.84, 38.68)],
    },
}


def gain(x, sah):
    """The paper's gain: the time saved against SAH, in percent."""
    return 100.0 * (1.0 - sah / x) if x and sah else float("nan")


class Pool:
    """The rows of one (scene, ray kind, measure, traversal): rays, time, steps, mismatches."""

    def __init__(self):
        self.rays, self.ms, self.steps, self.mism, self.views = 0, 0.0, 0.0, 0, 0
        self.sort_ms = None

    def add(self, r):
        n = int(r["rays"])
        self.rays += n
        self.ms += float(r["trace_ms_median"])
        steps = sum(float(r.get(c) or 0) for c in ("planes_per_ray", "prims_per_ray"))
        self.steps += steps * n
        self.mism += int(r.get("mismatches") or 0)
        self.views += 1
        if r.get("sort_ms"):
            self.sort_ms = (self.sort_ms or 0.0) + float(r["sort_ms"])

    def mrays(self):
        return self.rays / self.ms / 1e3 if self.ms > 0 else float("nan")

    def mean_steps(self):
        return self.steps / self.rays if self.rays else float("nan")


def cell(x, sah):
    return f"{x:7.2f} ({gain(x, sah):+6.2f})"


# Our ray kinds and the paper's tables of them (one primary batch serves PT and AO).
KINDS = [("primary", ["PT", "AO"]), ("path1", ["PT"]), ("ao", ["AO"])]


def print_kind(kind, renderers, pools, scenes):
    sorted_kind = kind != "primary"
    print(f"{' and '.join(renderers)} {kind} rays: MRays/s (gain % vs SAH)"
          + (": n.inc. / inc. per heuristic" if sorted_kind else ""))
    head = f"  {'scene':<22}{'SAH':>9}" + "".join(
        f"  {m.upper():>{37 if sorted_kind else 16}}" for m in MEASURES[1:])
    print(head)
    paper = [(f"{r} {n}", v) for r in renderers for n, v in PAPER[(r, kind)].items()]
    for name, values in paper:
        sah = values[0]
        cells = [f"{sah:9.2f}"]
        for v in values[1:]:
            if sorted_kind:
                cells.append(f"  {cell(v[0], sah)} / {cell(v[1], sah)}       ")
            else:
                cells.append(f"  {cell(v, sah)}")
        print(f"  {name:<22}" + "".join(cells))
    for scene in scenes:
        label = SCENES.get(scene, scene)
        g = lambda m, t: pools.get((scene, kind, m, t))  # noqa: E731
        sah = g("sah", PLAIN)
        if not sah:
            continue
        cells = [f"{sah.mrays():9.2f}"]
        notes = []
        for m in MEASURES[1:]:
            plain, pre, srt = g(m, PLAIN), g(m, PRE), g(m, SORTED)
            if sorted_kind:
                sah_pre, sah_srt = g("sah", PRE), g("sah", SORTED)
                if not (pre and srt and sah_pre and sah_srt):
                    cells.append(f"  {'-':>37}")
                    continue
                # The GPU times its sort (`sort_ms`); on the CPU it is the difference of the rows.
                sort_ms = srt.sort_ms if srt.sort_ms is not None else srt.ms - pre.ms
                share = 100.0 * sort_ms / srt.ms if srt.ms else float("nan")
                cells.append(f"  {cell(pre.mrays(), sah_pre.mrays())} / "
                             f"{cell(srt.mrays(), sah_srt.mrays())} {share:5.1f}%")
                notes.append(f"{m}: plain {plain.mrays():.2f}" if plain else f"{m}: no plain row")
            else:
                cells.append(f"  {cell(plain.mrays(), sah.mrays())}" if plain else f"  {'-':>16}")
        rows = [p for (s, k, _, _), p in pools.items() if s == scene and k == kind]
        mism = sum(p.mism for p in rows)
        equal = all(
            len({round(p.mean_steps(), 9) for p in (g(m, t) for t in (PLAIN, PRE, SORTED)) if p}) <= 1
            for m in MEASURES)
        views = max(p.views for p in rows)
        print(f"  {'ours ' + label:<22}" + "".join(cells)
              + f"   [{views} views, steps={'equal' if equal else 'DIFFER'}, mism {mism}]")
        if sorted_kind:
            print(f"  {'':<22}SAH plain {sah.mrays():.2f}, n.inc. "
                  f"{g('sah', PRE).mrays() if g('sah', PRE) else float('nan'):.2f}, inc. "
                  f"{g('sah', SORTED).mrays() if g('sah', SORTED) else float('nan'):.2f}; "
                  + ", ".join(notes))
    if sorted_kind:
        print("  (ours: the last figure of a cell is the sort's share of the inc. time)")
    print()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("csv", nargs="+", help="results.csv files (CPU and GPU rows)")
    ap.add_argument("--threads", default=None, help="one thread count (default: each)")
    ap.add_argument("--triangle-test", default="watertight",
                    help="the rows of one triangle test (default: watertight; the config may "
                         "run both, and pooling them would count each view twice)")
    a = ap.parse_args()
    rows = [r for path in a.csv for r in read_rows(path)
            if r["structure"] == "multi-kd" and r["device"] in ("cpu", "gpu")
            and r["traversal"] in (PLAIN, PRE, SORTED)
            and r["triangle_test"] == a.triangle_test
            and params_of(r).get("trees", "multi") == "multi"
            and params_of(r).get("measure") in MEASURES]
    if a.threads:
        rows = [r for r in rows if r["device"] == "gpu" or r["threads"] == a.threads]
    if not rows:
        raise SystemExit(f"no multi-kd recursive-direction rows (trees=multi) in {', '.join(a.csv)}")
    # GPU rows without a time (no kernel, no adapter) are left out.
    rows = [r for r in rows if r.get("trace_ms_median")]
    groups = sorted({(r["device"], r["threads"]) for r in rows},
                    key=lambda g: (g[0] == "gpu", int(g[1])))
    for device, threads in groups:
        pools = defaultdict(Pool)
        for r in rows:
            if (r["device"], r["threads"]) == (device, threads):
                key = (r["scene"].split("@")[0], r["ray_kind"], params_of(r)["measure"],
                       r["traversal"])
                pools[key].add(r)
        scenes = sorted({k[0] for k in pools}, key=lambda s: list(SCENES).index(s)
                        if s in SCENES else len(SCENES))
        if device == "gpu":
            adapters = sorted({r.get("adapter") or "?" for r in rows if r["device"] == "gpu"})
            print(f"=== Table 5, GPU {'; '.join(adapters)} (paper: one GPU)")
        else:
            print(f"=== Table 5, threads={threads} (paper: one GPU)")
        print()
        for kind, renderers in KINDS:
            if any(k[1] == kind for k in pools):
                print_kind(kind, renderers, pools, scenes)


if __name__ == "__main__":
    main()
