#!/usr/bin/env python3
"""Plots of trace-bench results (matplotlib).

    python3 scripts/plot.py RESULTS.csv                  # auto: bars (results.csv) or
                                                         #   convergence (convergence.csv)
    python3 scripts/plot.py bars RESULTS.csv [--ray-kind primary] [--out bars.png]
    python3 scripts/plot.py sweep RESULTS.csv --param max_leaf [--metric mrays_per_s]
    python3 scripts/plot.py convergence CONVERGENCE.csv [--metric rmse|rel_mse]

- bars: MRays/s and steps per ray per scene, one bar per structure x traversal (x parameter
  set when a sweep varies one), for one ray kind, thread count and triangle test;
- sweep: a metric against one parameter (leaf size now; d_min, lambda, beta later), one line per
  scene x structure x traversal;
- convergence: error against render time, log-log, one panel per scene x integrator, one
  line per structure x traversal; budget rows (frame_budget_ms) are printed as a table.

The output defaults to a PNG beside the CSV (`<stem>-<kind>.png`).
"""

import argparse
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import amount, apply_filters, column, number, params_of, read_rows, varying_params  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def default_out(csv_path, kind):
    stem, _ = os.path.splitext(csv_path)
    return f"{stem}-{kind}.png"


def pick_one(rows, col, want):
    """Rows with `col == want`, or with the most common value when `want` is None."""
    values = sorted({r[col] for r in rows})
    if want is None:
        if not values:
            return rows, None
        want = max(values, key=lambda v: sum(r[col] == v for r in rows))
    return [r for r in rows if r[col] == want], want


def bars(args):
    rows = apply_filters(read_rows(args.csv), args.filter)
    rows = [r for r in rows if number(r.get("mrays_per_s")) is not None]
    rows, kind = pick_one(rows, "ray_kind", args.ray_kind)
    rows, threads = pick_one(rows, "threads", args.threads)
    rows, test = pick_one(rows, "triangle_test", args.triangle_test)
    rows = [r for r in rows if r.get("device", "cpu") == (args.device or r.get("device"))]
    if not rows:
        sys.exit("error: no timed rows match")
    sweep = varying_params(rows)

    def series(r):
        s = f"{r['structure']} {r['traversal']}"
        p = params_of(r)
        extra = ",".join(f"{k}={p[k]}" for k in sweep if k in p)
        return f"{s} [{extra}]" if extra else s

    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    names = list(dict.fromkeys(series(r) for r in rows))
    metrics = [("mrays_per_s", "MRays/s"), ("steps_per_ray", "steps per ray")]
    fig, axes = plt.subplots(1, 2, figsize=(max(8, 1.2 * len(scenes) * len(names) ** 0.5 + 6), 4.5))
    width = 0.8 / len(names)
    for ax, (col, title) in zip(axes, metrics):
        for i, n in enumerate(names):
            ys = []
            for s in scenes:
                v = [number(r[col]) for r in rows if r["scene"] == s and series(r) == n]
                v = [x for x in v if x is not None]
                ys.append(sum(v) / len(v) if v else 0.0)
            ax.bar([j + (i - (len(names) - 1) / 2) * width for j in range(len(scenes))], ys, width, label=n)
        ax.set_xticks(range(len(scenes)))
        ax.set_xticklabels(scenes, rotation=20, ha="right")
        ax.set_title(title)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{kind} rays, {threads} threads, {test} test")
    fig.tight_layout()
    out = args.out or default_out(args.csv, "bars")
    fig.savefig(out, dpi=args.dpi)
    print(f"wrote {out}")


def sweep(args):
    rows = apply_filters(read_rows(args.csv), args.filter)
    rows = [r for r in rows if amount(r, args.metric) is not None]
    rows, kind = pick_one(rows, "ray_kind", args.ray_kind)
    rows, threads = pick_one(rows, "threads", args.threads)
    rows, test = pick_one(rows, "triangle_test", args.triangle_test)
    # Reference rows (e.g. the SAH tree of the multi-kd-tree paper's Tables 6-7): dashed
    # horizontal lines, not points of the sweep.
    refs = apply_filters(rows, args.line) if args.line else []
    rows = [r for r in rows if args.param in params_of(r) and not any(r is x for x in refs)]
    if not rows:
        sys.exit(f"error: no rows with parameter `{args.param}` and a value of {args.metric}")
    lines = {}
    for r in rows:
        key = f"{r['scene']} {r['structure']} {r['traversal']}"
        x = number(params_of(r)[args.param])
        if x is None:
            sys.exit(f"error: parameter `{args.param}` is not numeric ({params_of(r)[args.param]})")
        lines.setdefault(key, []).append((x, amount(r, args.metric)))
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    colour = {}
    for key, pts in sorted(lines.items()):
        pts.sort()
        line, = ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=key)
        colour.setdefault(key.split(" ")[0], line.get_color())
    if args.line:
        for r in refs:
            ax.axhline(amount(r, args.metric), linestyle="--", linewidth=1,
                       color=colour.get(r["scene"], "grey"),
                       label=f"{r['scene']} {r['structure']} {r['traversal']} ({', '.join(args.line)})")
    ax.set_xlabel(args.param)
    ax.set_ylabel(args.metric)
    ax.set_title(f"{args.metric} against {args.param} ({kind} rays, {threads} threads, {test})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    out = args.out or default_out(args.csv, f"sweep-{args.param}")
    fig.savefig(out, dpi=args.dpi)
    print(f"wrote {out}")


def convergence(args):
    rows = apply_filters(read_rows(args.csv), args.filter)
    if rows and "integrator" not in rows[0]:
        sys.exit(f"error: {args.csv} is not a convergence.csv (no `integrator` column)")
    curves = [r for r in rows if not r.get("budget_ms")]
    budgets = [r for r in rows if r.get("budget_ms")]
    panels = list(dict.fromkeys((r["scene"], r["integrator"]) for r in curves))
    if not panels:
        sys.exit("error: no progressive rows")
    ncol = min(2, len(panels))
    nrow = math.ceil(len(panels) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.5 * ncol, 4.2 * nrow), squeeze=False)
    for ax, (scene, integ) in zip(axes.flat, panels):
        sel = [r for r in curves if r["scene"] == scene and r["integrator"] == integ]
        for key in dict.fromkeys(f"{r['structure']} {r['traversal']} {r['device']}" for r in sel):
            pts = [
                (number(r["elapsed_ms"]), number(r[args.metric]), r["spp"])
                for r in sel
                if f"{r['structure']} {r['traversal']} {r['device']}" == key
            ]
            pts = [p for p in pts if p[0] and p[1]]
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], marker="o", label=key)
            last = pts[-1] if pts else None
            if last:
                ax.annotate(f"{last[2]} spp", (last[0], last[1]), fontsize=7)
        # The 1/sqrt(t) slope for reference (MSE-type metrics fall as 1/t).
        xs = sorted(number(r["elapsed_ms"]) for r in sel if number(r["elapsed_ms"]))
        ys = [number(r[args.metric]) for r in sel if number(r[args.metric])]
        if xs and ys:
            p = 0.5 if args.metric == "rmse" else 1.0
            y0 = max(ys)
            ax.loglog([xs[0], xs[-1]], [y0, y0 * (xs[0] / xs[-1]) ** p], "k--", lw=0.8,
                      label=f"slope -{p:g}")
        ax.set_title(f"{scene}: {integ}")
        ax.set_xlabel("render time (ms)")
        ax.set_ylabel(args.metric)
        ax.grid(which="both", alpha=0.3)
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    fig.tight_layout()
    out = args.out or default_out(args.csv, "convergence")
    fig.savefig(out, dpi=args.dpi)
    print(f"wrote {out}")
    if budgets:
        print(f"{'scene':<12} {'integrator':<10} {'structure':<10} {'traversal':<10} {'budget_ms':>9} {'spp':>5} {'elapsed_ms':>10} {args.metric:>9}")
        for r in budgets:
            print(f"{r['scene']:<12} {r['integrator']:<10} {r['structure']:<10} {r['traversal']:<10} "
                  f"{float(r['budget_ms']):>9.1f} {r['spp']:>5} {float(r['elapsed_ms']):>10.1f} {r[args.metric] or '-':>9.9}")


def main(argv):
    kinds = {"bars", "sweep", "convergence"}
    if argv and argv[0] not in kinds and not argv[0].startswith("-"):
        # Auto-detect from the file.
        path = argv[0]
        rows = read_rows(path)
        kind = "convergence" if rows and "integrator" in rows[0] else "bars"
        argv = [kind] + argv
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="kind", required=True)

    def common(sp):
        sp.add_argument("csv")
        sp.add_argument("--out", help="PNG to write (default: beside the CSV)")
        sp.add_argument("--filter", action="append", metavar="COLUMN=VALUE",
                        help="keep rows where COLUMN (or param:KEY) equals VALUE; repeatable")
        sp.add_argument("--dpi", type=int, default=110)

    def select(sp):
        sp.add_argument("--ray-kind", help="default: the most common")
        sp.add_argument("--threads", help="default: the most common")
        sp.add_argument("--triangle-test", help="default: the most common")

    b = sub.add_parser("bars", help="MRays/s and steps per structure and traversal")
    common(b)
    select(b)
    b.add_argument("--device")
    s = sub.add_parser("sweep", help="a metric against a parameter")
    common(s)
    select(s)
    s.add_argument("--param", required=True, help="parameter key, e.g. max_leaf")
    s.add_argument("--metric", default="mrays_per_s",
                   help="a column, or several joined by + and added up")
    s.add_argument("--line", action="append", metavar="COLUMN=VALUE",
                   help="draw the rows that match as dashed horizontal lines instead of sweep "
                        "points (e.g. param:measure=sah); repeatable, all must hold")
    c = sub.add_parser("convergence", help="error against time, log-log")
    common(c)
    c.add_argument("--metric", default="rmse", choices=["rmse", "rel_mse"])
    args = p.parse_args(argv)
    {"bars": bars, "sweep": sweep, "convergence": convergence}[args.kind](args)


if __name__ == "__main__":
    main(sys.argv[1:])
