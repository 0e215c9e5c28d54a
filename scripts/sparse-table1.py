#!/usr/bin/env python3
"""Our Table 1 of Havran and Bittner 2007 ("Stackless Ray Traversal for kD-Trees with Sparse
Boxes") beside the paper's, from a results.csv of configs/sparse-boxes.toml.

Rows of structure `sparse-boxes` are grouped by scene (the label before `@`: the rows of each
of a table's `views`) and traversal; per-ray counters are averaged over the views weighted by their rays,
T_R is the mean trace time per view in seconds. N_B and M_KD come from `build_stats` (`n_b`;
`m_kd_bytes` for BTR/SLTR, `m_kd_htr_bytes` for HTR/SEQ, which read no box). Then the paper's
claims, each with our ratio.

    python3 scripts/sparse-table1.py results/sparse-boxes/*/results.csv [--ray-kind primary]
"""

import argparse
import csv
from collections import defaultdict

# The paper's Table 1 (primary rays, 13 views, 800x600, one core): N_B, M_KD [MB], r_ITM, N_L,
# N_I, T_R [s].
PAPER = {
    "arena (1.4M triangles, 7.1M kD-nodes)": {
        "HTR": (0, 89, 35.93, 9.45, 86.85, 1.71),
        "BTR": (0.725e6, 117, 31.96, 9.46, 73.67, 1.55),
        "SLTR": (0.725e6, 117, 37.06, 10.80, 126.49, 2.37),
        "SEQ": (0, 89, 37.06, 10.81, 246.97, 2.89),
    },
    "city (0.8M triangles, 4.0M kD-nodes)": {
        "HTR": (0, 42, 20.97, 7.95, 58.85, 1.24),
        "BTR": (0.557e6, 64, 22.92, 8.21, 50.87, 1.19),
        "SLTR": (0.557e6, 64, 21.01, 9.15, 85.67, 1.66),
        "SEQ": (0, 42, 21.01, 9.15, 195.83, 2.24),
    },
}

ORDER = ["htr", "btr", "btr-root", "sltr", "sltr-root", "seq"]


def stats(s):
    out = {}
    for kv in (s or "").split(";"):
        if "=" in kv:
            k, v = kv.split("=", 1)
            try:
                out[k] = float(v)
            except ValueError:
                pass
    return out


def fmt_row(name, v):
    nb, mkd, r, nl, ni, tr = v
    nb_s = f"{nb / 1e6:.3f}M" if nb >= 1e5 else f"{nb:.0f}"
    return f"  {name:<10} {nb_s:>9} {mkd:>9.2f} {r:>8.2f} {nl:>7.2f} {ni:>8.2f} {tr:>8.3f}"


HEAD = f"  {'method':<10} {'N_B':>9} {'M_KD[MB]':>9} {'r_ITM':>8} {'N_L':>7} {'N_I':>8} {'T_R[s]':>8}"


def claims(t):
    """The paper's claims with our figures; `t` maps traversal -> row tuple."""
    out = []
    if all(k in t for k in ("htr", "btr", "sltr", "seq")):
        h, b, s, q = t["htr"], t["btr"], t["sltr"], t["seq"]
        out.append(f"    BTR N_I / HTR N_I = {b[4] / h[4]:.3f} (paper: 0.848 arena, 0.864 city)")
        out.append(f"    HTR T_R / BTR T_R = {h[5] / b[5]:.3f} (paper: 1.04-1.10)")
        out.append(f"    SLTR N_I / HTR N_I = {s[4] / h[4]:.3f} (paper: about 1.46)")
        out.append(f"    SLTR T_R / HTR T_R = {s[5] / h[5]:.3f} (paper: about 1.38)")
        out.append(f"    SEQ T_R / SLTR T_R = {q[5] / s[5]:.3f} (paper: about 1.35)")
        out.append(f"    M_KD(BTR) / M_KD(HTR) = {b[1] / h[1]:.3f} (paper: 1.31 arena, 1.52 city)")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("csv")
    ap.add_argument("--ray-kind", default="primary")
    ap.add_argument("--threads", default=None, help="default: the smallest")
    a = ap.parse_args()
    rows = [r for r in csv.DictReader(open(a.csv))
            if r["structure"] == "sparse-boxes" and r["ray_kind"] == a.ray_kind
            and r["device"] == "cpu"]
    if not rows:
        raise SystemExit(f"no sparse-boxes rows with ray_kind={a.ray_kind} in {a.csv}")
    threads = a.threads or min({r["threads"] for r in rows}, key=int)
    rows = [r for r in rows if r["threads"] == threads]
    groups = defaultdict(list)
    for r in rows:
        groups[(r["scene"].split("@")[0], r["params"], r["traversal"])].append(r)
    scenes = sorted({(k[0], k[1]) for k in groups})
    for name, table in PAPER.items():
        print(f"paper: '{name}'")
        print(HEAD)
        for m, v in table.items():
            print(fmt_row(m, v))
        print("  claims")
        print("\n".join(claims({k.lower(): v for k, v in table.items()})))
        print()
    for scene, params in scenes:
        t = {}
        for trav in ORDER:
            g = groups.get((scene, params, trav))
            if not g:
                continue
            n = sum(int(r["rays"]) for r in g)
            mean = lambda c: sum(float(r[c]) * int(r["rays"]) for r in g) / n
            bs = stats(g[0]["build_stats"])
            boxes = trav in ("btr", "btr-root", "sltr", "sltr-root")
            nb = bs.get("n_b", 0) if boxes else 0
            mkd = bs.get("m_kd_bytes" if boxes else "m_kd_htr_bytes", 0) / 1e6
            tr = sum(float(r["trace_ms_median"]) for r in g) / len(g) / 1e3
            t[trav] = (nb, mkd, mean("prims_per_ray"), mean("leaves_per_ray"),
                       mean("interior_per_ray"), tr)
            ups = mean("ups_per_ray") if g[0].get("ups_per_ray") else 0.0
            mism = sum(int(r["mismatches"] or 0) for r in g)
            t[trav + "_extra"] = (len(g), ups, mism)
        tri = groups[(scene, params, ORDER[0])][0]["triangles"] if (scene, params, ORDER[0]) in groups else "?"
        print(f"ours: '{scene}' ({tri} triangles), {a.ray_kind} rays, threads={threads}, [{params}]")
        print(HEAD + f" {'ups':>6} {'views':>5} {'mism':>5}")
        for trav in ORDER:
            if trav in t:
                views, ups, mism = t[trav + "_extra"]
                print(fmt_row(trav.upper(), t[trav]) + f" {ups:>6.2f} {views:>5} {mism:>5}")
        print("  claims")
        print("\n".join(claims(t)))
        print()


if __name__ == "__main__":
    main()
