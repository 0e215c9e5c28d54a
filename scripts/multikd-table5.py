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

    python3 scripts/multikd-table5.py results/multikd/LATEST [GPU.csv|GPU_FOLDER] [--threads N]
        [--drop-noisy]

Several CSVs or run folders (FOLDER/results.csv) are read as one; a later file's rows replace
the same rows of an earlier one (a note on stderr says how many).

Noise: a figure built from a row flagged `noisy` (MRays/s of a pool with one, a gain or a sort
share built from one) is marked †, and the footnote counts the noisy rows; --drop-noisy leaves
those rows out (a pool then covers fewer views, which the `views` note shows). A CPU sort share
that comes out negative (time(-sorted) < time(-presorted)) is not a figure: where the two
pooled medians' 95% CIs overlap it prints `noise‡` (the difference is within noise); where they
do not, the share is printed with `!` (the -sorted row was faster beyond the CIs: something other
than the sort differs between the rows).

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
from common import (add_noisy_option, drop_noisy, is_noisy, mark, noisy_footnote,  # noqa: E402
                    number, params_of, read_csvs)

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
        self.noisy = 0      # rows flagged noisy
        self.half2 = 0.0    # sum of the squared absolute half-widths of the medians' 95% CIs
        self.ci_known = True

    def add(self, r):
        n = int(r["rays"])
        self.rays += n
        ms = float(r["trace_ms_median"])
        self.ms += ms
        ci = number(r.get("trace_ms_ci"))
        if ci is None:
            self.ci_known = False
        else:
            self.half2 += (ms * ci) ** 2
        self.noisy += is_noisy(r)
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

    def half(self):
        """Half-width of the pooled time's 95% CI (the views' in quadrature), None if unknown."""
        return self.half2 ** 0.5 if self.ci_known else None


def cell(x, sah, noisy_x=False, noisy_gain=False):
    """`MRays/s (gain)`, each followed by † when built from a noisy row (18 characters)."""
    return f"{x:7.2f}{mark(noisy_x) or ' '} ({gain(x, sah):+6.2f}){mark(noisy_gain) or ' '}"


def share_text(srt, pre, notes):
    """The sort's share of the inc. time, 7 characters: `20.0%` (then † when built from a noisy
    row), `noise‡` when negative within the CIs, `-3.0%!` when negative beyond them."""
    if srt.sort_ms is not None:  # timed on its own (GPU)
        share = 100.0 * srt.sort_ms / srt.ms if srt.ms else float("nan")
        return f"{share:5.1f}%{mark(srt.noisy > 0) or ' '}"
    diff = srt.ms - pre.ms
    share = 100.0 * diff / srt.ms if srt.ms else float("nan")
    if diff >= 0:
        return f"{share:5.1f}%{mark(srt.noisy > 0 or pre.noisy > 0) or ' '}"
    hs, hp = srt.half(), pre.half()
    if hs is not None and hp is not None and srt.ms + hs >= pre.ms - hp:
        notes.add("noise")
        return " noise‡"
    notes.add("negative")
    return f"{share:5.1f}%!"


# Our ray kinds and the paper's tables of them (one primary batch serves PT and AO).
KINDS = [("primary", ["PT", "AO"]), ("path1", ["PT"]), ("ao", ["AO"])]


def print_kind(kind, renderers, pools, scenes, notes):
    sorted_kind = kind != "primary"
    print(f"{' and '.join(renderers)} {kind} rays: MRays/s (gain % vs SAH)"
          + (": n.inc. / inc. per heuristic" if sorted_kind else ""))
    head = f"  {'scene':<22}{'SAH':>9} " + "".join(
        f"  {m.upper():>{47 if sorted_kind else 18}}" for m in MEASURES[1:])
    print(head)
    paper = [(f"{r} {n}", v) for r in renderers for n, v in PAPER[(r, kind)].items()]
    for name, values in paper:
        sah = values[0]
        cells = [f"{sah:9.2f} "]
        for v in values[1:]:
            if sorted_kind:
                cells.append(f"  {cell(v[0], sah)} / {cell(v[1], sah)}        ")
            else:
                cells.append(f"  {cell(v, sah)}")
        print(f"  {name:<22}" + "".join(cells))
    for scene in scenes:
        label = SCENES.get(scene, scene)
        g = lambda m, t: pools.get((scene, kind, m, t))  # noqa: E731
        sah = g("sah", PLAIN)
        if not sah:
            continue
        cells = [f"{sah.mrays():9.2f}{mark(sah.noisy > 0) or ' '}"]
        plain_notes = []
        for m in MEASURES[1:]:
            plain, pre, srt = g(m, PLAIN), g(m, PRE), g(m, SORTED)
            if sorted_kind:
                sah_pre, sah_srt = g("sah", PRE), g("sah", SORTED)
                if not (pre and srt and sah_pre and sah_srt):
                    cells.append(f"  {'-':>47}")
                    continue
                # The GPU times its sort (`sort_ms`); on the CPU it is the difference of the rows.
                cells.append(
                    f"  {cell(pre.mrays(), sah_pre.mrays(), pre.noisy, pre.noisy + sah_pre.noisy)}"
                    f" / {cell(srt.mrays(), sah_srt.mrays(), srt.noisy, srt.noisy + sah_srt.noisy)}"
                    f" {share_text(srt, pre, notes)}")
                plain_notes.append(f"{m}: plain {plain.mrays():.2f}{mark(plain.noisy > 0)}"
                                   if plain else f"{m}: no plain row")
            else:
                cells.append(f"  {cell(plain.mrays(), sah.mrays(), plain.noisy, plain.noisy + sah.noisy)}"
                             if plain else f"  {'-':>18}")
        rows = [p for (s, k, _, _), p in pools.items() if s == scene and k == kind]
        mism = sum(p.mism for p in rows)
        equal = all(
            len({round(p.mean_steps(), 9) for p in (g(m, t) for t in (PLAIN, PRE, SORTED)) if p}) <= 1
            for m in MEASURES)
        lo, hi = min(p.views for p in rows), max(p.views for p in rows)
        views = f"{hi} views" if lo == hi else f"{lo}-{hi} views (pools differ: compare with care)"
        print(f"  {'ours ' + label:<22}" + "".join(cells)
              + f"   [{views}, steps={'equal' if equal else 'DIFFER'}, mism {mism}]")
        if sorted_kind:
            sp, ss = g("sah", PRE), g("sah", SORTED)
            print(f"  {'':<22}SAH plain {sah.mrays():.2f}{mark(sah.noisy > 0)}, n.inc. "
                  f"{sp.mrays() if sp else float('nan'):.2f}{mark(bool(sp and sp.noisy))}, inc. "
                  f"{ss.mrays() if ss else float('nan'):.2f}{mark(bool(ss and ss.noisy))}; "
                  + ", ".join(plain_notes))
    if sorted_kind:
        print("  (ours: the last figure of a cell is the sort's share of the inc. time)")
    print()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("csv", nargs="+", metavar="CSV|FOLDER",
                    help="results.csv files or run folders (CPU and GPU rows)")
    ap.add_argument("--threads", default=None, help="one thread count (default: each)")
    ap.add_argument("--triangle-test", default="watertight",
                    help="the rows of one triangle test (default: watertight; the config may "
                         "run both, and pooling them would count each view twice)")
    add_noisy_option(ap)
    a = ap.parse_args()
    all_rows, files = read_csvs(a.csv)
    rows = [r for r in all_rows
            if r["structure"] == "multi-kd" and r["device"] in ("cpu", "gpu")
            and r["traversal"] in (PLAIN, PRE, SORTED)
            and r["triangle_test"] == a.triangle_test
            and params_of(r).get("trees", "multi") == "multi"
            and params_of(r).get("measure") in MEASURES]
    if a.threads:
        rows = [r for r in rows if r["device"] == "gpu" or r["threads"] == a.threads]
    if not rows:
        raise SystemExit(f"no multi-kd recursive-direction rows (trees=multi) in {', '.join(files)}")
    # GPU rows without a time (no kernel, no adapter) are left out, and so are noisy rows with
    # --drop-noisy (their timings blanked).
    rows = [r for r in drop_noisy(rows, a.drop_noisy) if r.get("trace_ms_median")]
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
        notes = set()
        for kind, renderers in KINDS:
            if any(k[1] == kind for k in pools):
                print_kind(kind, renderers, pools, scenes, notes)
        block = [r for r in rows if (r["device"], r["threads"]) == (device, threads)]
        for line in [noisy_footnote(block),
                     "‡ noise: the sort's share came out negative, time(-sorted) < "
                     "time(-presorted), but the two pooled medians' 95% CIs overlap: the "
                     "difference of the two timings is within noise, not a figure of the sort"
                     if "noise" in notes else "",
                     "! a negative share beyond the CIs (or without them): the -sorted rows were "
                     "faster than the -presorted ones, which the sort cannot explain; rerun"
                     if "negative" in notes else ""]:
            if line:
                print(line)
        if any(notes) or noisy_footnote(block):
            print()


if __name__ == "__main__":
    main()
