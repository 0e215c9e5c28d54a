#!/usr/bin/env python3
"""Table 4 of Pérard-Gayot et al. 2017 ("GPU Ray Tracing using Irregular Grids") beside ours,
from a dynamic.csv of configs/irregular-dynamic.toml: per scene, budget and structure, the
chosen densities and the AO samples per pixel that fit (min / median / max over the frames),
with the mean build, primary and per-sample AO times. Then the claim: the irregular grid gives
more samples than the two-level grid within the same budget.

    python3 scripts/irregular-table4.py results/irregular-dynamic/LATEST [more CSVs or folders]
        [--drop-noisy]

Several dynamic.csv files or run folders (FOLDER/dynamic.csv) are read as one; a later file's
row of the same scene, structure, parameters (the chosen densities aside), threads, image size,
budget and frame replaces the earlier one (a note on stderr says how many).

dynamic.csv has no `noisy` column today: its timings are wall-clock medians without a CI, and
the script says so. Should the column appear, the samples of a noisy row are marked † (a median
or a verdict built from one too) and --drop-noisy leaves such rows out.
"""

import argparse
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (DAGGER, IDENTITY, is_noisy, mark, params_of, read_csvs)  # noqa: E402

# Identity of a dynamic.csv row across runs: `params` holds the densities the run chose, which
# another run may choose differently for the same budget.
DENSITIES = ("lambda_1", "lambda_2")


def identity(r):
    p = ";".join(f"{k}={v}" for k, v in sorted(params_of(r).items()) if k not in DENSITIES)
    return tuple(p if c == "params" else r.get(c, "") for c in IDENTITY)


# The paper's Table 4 (Titan X, 1024x1024): scene -> budget ms -> (2L λ, 2L spp, ours λ, ours spp),
# as far as the published table is legible (the fairy's spp cells are not).
PAPER = {
    "exploding dragon (252K)": {100: ("0.2, 2.0", 21, "0.3, 2.4", 57), 50: ("0.2, 2.0", 8, "0.3, 2.4", 24), 33: ("0.2, 2.0", 3, "0.3, 2.4", 13)},
    "breaking lion (1.6M)": {100: ("0.03, 0.6", 1, "0.3, 2.4", 8), 50: ("0.03, 0.6", 0, "0.02, 0.16", 1), 33: ("0.03, 0.6", 0, "0.01, 0.08", 0)},
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("csv", nargs="+", metavar="CSV|FOLDER",
                    help="dynamic.csv files or run folders of configs/irregular-dynamic.toml")
    ap.add_argument("--drop-noisy", action="store_true",
                    help="leave out rows flagged noisy (dynamic.csv has no such flag today)")
    a = ap.parse_args()
    rows, _ = read_csvs(a.csv, names=("dynamic.csv",), key=identity)
    if not rows:
        sys.exit("error: no rows")
    flagged = "noisy" in rows[0]
    if not flagged:
        print("note: dynamic.csv records no `noisy` flag: its times are wall-clock medians "
              "without a CI, so a loaded machine shifts the samples unmarked"
              + ("; --drop-noisy has nothing to drop" if a.drop_noisy else ""))
    elif a.drop_noisy:
        n = sum(is_noisy(r) for r in rows)
        rows = [r for r in rows if not is_noisy(r)]
        print(f"--drop-noisy: {n} noisy row(s) left out", file=sys.stderr)
        if not rows:
            sys.exit("error: no rows left")
    key = lambda r: (r["scene"], float(r["budget_ms"]), r["structure"])  # noqa: E731
    groups = {}
    for r in rows:
        groups.setdefault(key(r), []).append(r)
    sizes = sorted({f"{r['width']}x{r['height']}" for r in rows})
    threads = sorted({r["threads"] for r in rows}, key=int)
    print(f"ours: {', '.join(sizes)}, {'/'.join(threads)} threads")
    print(f"{'scene':<12} {'budget':>7} {'structure':<15} {'λ_1, λ_2':<12} {'spp min/med/max':>16} {'build':>8} {'primary':>8} {'ao/spp':>8}")
    med = {}
    n_noisy = 0
    for (s, b, st), rr in sorted(groups.items(), key=lambda kv: (kv[0][0], -kv[0][1], kv[0][2])):
        spp = sorted(int(r["spp"]) for r in rr)
        m = statistics.median(spp)
        noisy = any(is_noisy(r) for r in rr)
        n_noisy += sum(is_noisy(r) for r in rr)
        med[(s, b, st)] = (m, noisy)
        mean = lambda c: statistics.mean(float(r[c]) for r in rr)  # noqa: E731
        lams = sorted({f"{float(r['lambda_1']):g}, {float(r['lambda_2']):g}" for r in rr})
        lam = " | ".join(lams)  # more than one: runs that chose differently
        print(
            f"{s:<12} {b:>7g} {st:<15} {lam:<12} {f'{spp[0]}/{m:g}/{spp[-1]}{mark(noisy)}':>16} "
            f"{mean('build_ms'):>8.1f} {mean('primary_ms'):>8.1f} {mean('ao_ms_per_spp'):>8.2f}"
        )
    if n_noisy:
        print(f"{DAGGER} noisy timing ({n_noisy} of {len(rows)} frames): samples from a noisy "
              "row; a median or verdict built from one is marked too; --drop-noisy leaves them out")
    print("\nThe paper (Titan X): 2L grid λ, spp | ours λ, spp")
    for s, per in PAPER.items():
        for b, (tl, ts, ol, os_) in per.items():
            print(f"{s:<24} {b:>4} ms   {tl:<10} {ts:>3} | {ol:<11} {os_:>3}")
    print("\nClaim: the irregular grid fits more AO samples than the two-level grid (paper: yes in every cell)")
    for (s, b, st), (m, mn) in sorted(med.items()):
        if st != "irregular-grid":
            continue
        if (s, b, "two-level-grid") not in med:
            continue
        t, tn = med[(s, b, "two-level-grid")]
        verdict = "agree" if m > t else ("tie" if m == t else "disagree")
        print(f"  {s:<12} {b:>6g} ms: irregular {m:g}{mark(mn)} vs two-level {t:g}{mark(tn)} spp "
              f"(median over frames): {verdict}{mark(mn or tn)}")


if __name__ == "__main__":
    main()
