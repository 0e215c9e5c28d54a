#!/usr/bin/env python3
"""Our Table 1 of Havran and Bittner 2007 ("Stackless Ray Traversal for kD-Trees with Sparse
Boxes") beside the paper's, from a results.csv of configs/sparse-boxes.toml.

Rows of structure `sparse-boxes` are grouped by scene (the label before `@`: the rows of each
of a table's `views`) and traversal; per-ray counters are averaged over the views weighted by their rays,
T_R is the mean trace time per view in seconds. N_B and M_KD come from `build_stats` (`n_b`;
`paper_bytes`, a box priced as Table 1 does, for BTR/SLTR (`m_kd_bytes` in rows made before
it), `m_kd_htr_bytes` for HTR/SEQ, which read no box). SLTR is the paper's Algorithm 3;
`sltr-mask` is our variant. Then the paper's
claims, each with our ratio. The paper's figures are for primary rays: with another
`--ray-kind` they are not printed ("paper: primary rays only").

A T_R built from a noisy row (any of its views) is marked †, and so is a claim's time ratio
built from one; the footnote counts them. --drop-noisy leaves the timings of noisy rows out:
T_R is then the mean over the views still timed (the `timed` column), and a time ratio of two
methods is taken over the views both have timed.

    python3 scripts/sparse-table1.py results/sparse-boxes/LATEST [more CSVs or run folders]
        [--ray-kind primary] [--threads N] [--drop-noisy]

Several CSVs or run folders (FOLDER/results.csv) are read as one; a later file's rows replace
the same rows of an earlier one (a note on stderr says how many).
"""

import argparse
import os
import sys
from collections import defaultdict

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (add_noisy_option, drop_noisy, is_noisy, mark,  # noqa: E402
                    noisy_footnote, number, read_csvs)

# The paper's figures are for this ray kind only.
PAPER_RAYS = "primary"

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

ORDER = ["htr", "btr", "btr-root", "sltr", "sltr-root", "sltr-mask", "sltr-mask-root", "seq"]


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


class Method:
    """One traversal's figures over a scene's views: N_B, M_KD [MB], r_ITM, N_L, N_I, T_R [s],
    and the per-view trace times (ms) and which views' rows are noisy."""

    def __init__(self, nb, mkd, r, nl, ni, tr, ms=None, noisy_views=()):
        self.nb, self.mkd, self.r, self.nl, self.ni, self.tr = nb, mkd, r, nl, ni, tr
        self.ms = ms if ms is not None else {"all": tr}
        self.noisy_views = set(noisy_views)

    @property
    def noisy(self):
        return bool(self.noisy_views & set(self.ms))


def fmt_row(name, m):
    nb_s = f"{m.nb / 1e6:.3f}M" if m.nb >= 1e5 else f"{m.nb:.0f}"
    tr = "-" if m.tr is None else f"{m.tr:.3f}"
    return (f"  {name:<10} {nb_s:>9} {m.mkd:>9.2f} {m.r:>8.2f} {m.nl:>7.2f} {m.ni:>8.2f} "
            f"{tr:>8}{mark(m.noisy and m.tr is not None) or ' '}")


HEAD = f"  {'method':<10} {'N_B':>9} {'M_KD[MB]':>9} {'r_ITM':>8} {'N_L':>7} {'N_I':>8} {'T_R[s]':>8} "


def time_ratio(a, b):
    """T_R(a) / T_R(b) over the views both have timed: (text, noisy)."""
    common = [v for v in a.ms if v in b.ms and a.ms[v] is not None and b.ms[v] is not None]
    if not common:
        return "-", False
    x, y = sum(a.ms[v] for v in common), sum(b.ms[v] for v in common)
    noisy = any(v in a.noisy_views or v in b.noisy_views for v in common)
    partial = len(common) < max(len(a.ms), len(b.ms))
    where = f" (over the {len(common)} view(s) both timed)" if partial else ""
    return f"{x / y:.3f}{mark(noisy)}{where}", noisy


def claims(t, paper):
    """The paper's claims with the figures of `t` (traversal -> Method); `paper` is False when
    the rays are not the paper's (its figures are then not printed)."""
    out = []
    if not all(k in t for k in ("htr", "btr", "sltr", "seq")):
        return out
    h, b, s, q = t["htr"], t["btr"], t["sltr"], t["seq"]
    p = (lambda text: f"(paper: {text})") if paper else (lambda _: f"(paper: {PAPER_RAYS} rays only)")
    out.append(f"    BTR N_I / HTR N_I = {b.ni / h.ni:.3f} {p('0.848 arena, 0.864 city')}")
    out.append(f"    HTR T_R / BTR T_R = {time_ratio(h, b)[0]} {p('1.04-1.10')}")
    out.append(f"    SLTR N_I / HTR N_I = {s.ni / h.ni:.3f} {p('about 1.46')}")
    out.append(f"    SLTR T_R / HTR T_R = {time_ratio(s, h)[0]} {p('about 1.38')}")
    out.append(f"    SEQ T_R / SLTR T_R = {time_ratio(q, s)[0]} {p('about 1.35')}")
    out.append(f"    M_KD(BTR) / M_KD(HTR) = {b.mkd / h.mkd:.3f} {p('1.31 arena, 1.52 city')}")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("csv", nargs="+", metavar="CSV|FOLDER",
                    help="results.csv files or run folders of configs/sparse-boxes.toml")
    ap.add_argument("--ray-kind", default="primary")
    ap.add_argument("--threads", default=None, help="default: the smallest")
    add_noisy_option(ap)
    a = ap.parse_args()
    all_rows, files = read_csvs(a.csv)
    rows = [r for r in all_rows
            if r["structure"] == "sparse-boxes" and r["ray_kind"] == a.ray_kind
            and r["device"] == "cpu"]
    if not rows:
        raise SystemExit(f"no sparse-boxes rows with ray_kind={a.ray_kind} in {', '.join(files)}")
    threads = a.threads or min({r["threads"] for r in rows}, key=int)
    rows = drop_noisy([r for r in rows if r["threads"] == threads], a.drop_noisy)
    groups = defaultdict(list)
    for r in rows:
        groups[(r["scene"].split("@")[0], r["params"], r["traversal"])].append(r)
    scenes = sorted({(k[0], k[1]) for k in groups})
    paper = a.ray_kind == PAPER_RAYS
    if paper:
        for name, table in PAPER.items():
            print(f"paper: '{name}'")
            print(HEAD)
            ms = {k.lower(): Method(*v) for k, v in table.items()}
            for m, v in ms.items():
                print(fmt_row(m.upper(), v))
            print("  claims")
            print("\n".join(claims(ms, True)))
            print()
    else:
        print(f"paper: {PAPER_RAYS} rays only (Table 1): no figures of the paper for "
              f"{a.ray_kind} rays; our ratios below stand alone\n")
    for scene, params in scenes:
        t = {}
        extra = {}
        for trav in ORDER:
            g = groups.get((scene, params, trav))
            if not g:
                continue
            n = sum(int(r["rays"]) for r in g)
            mean = lambda c: sum(float(r[c]) * int(r["rays"]) for r in g) / n  # noqa: E731
            bs = stats(g[0]["build_stats"])
            boxes = trav in ("btr", "btr-root", "sltr", "sltr-root", "sltr-mask", "sltr-mask-root")
            nb = bs.get("n_b", 0) if boxes else 0
            # M_KD as Table 1 prices a box (`paper_bytes`; older rows: `m_kd_bytes`).
            mkd = bs.get(("paper_bytes" if "paper_bytes" in bs else "m_kd_bytes") if boxes
                         else "m_kd_htr_bytes", 0) / 1e6
            ms = {r["scene"]: number(r["trace_ms_median"]) for r in g}
            got = [v for v in ms.values() if v is not None]
            tr = sum(got) / len(got) / 1e3 if got else None
            ms = {v: x for v, x in ms.items() if x is not None}
            t[trav] = Method(nb, mkd, mean("prims_per_ray"), mean("leaves_per_ray"),
                             mean("interior_per_ray"), tr, ms,
                             {r["scene"] for r in g if is_noisy(r)})
            ups = mean("ups_per_ray") if g[0].get("ups_per_ray") else 0.0
            mism = sum(int(r.get("mismatches") or 0) for r in g)
            extra[trav] = (len(g), len(ms), ups, mism)
        key = (scene, params, ORDER[0])
        tri = groups[key][0].get("triangles", "?") if key in groups else "?"
        print(f"ours: '{scene}' ({tri} triangles), {a.ray_kind} rays, threads={threads}, [{params}]")
        print(HEAD + f"{'ups':>6} {'views':>5} {'timed':>5} {'mism':>5}")
        for trav in ORDER:
            if trav in t:
                views, timed_views, ups, mism = extra[trav]
                print(fmt_row(trav.upper(), t[trav])
                      + f"{ups:>6.2f} {views:>5} {timed_views:>5} {mism:>5}")
        print("  claims")
        print("\n".join(claims(t, paper)))
        print()
    note = noisy_footnote(rows)
    if note:
        print(note)


if __name__ == "__main__":
    main()
