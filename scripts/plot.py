#!/usr/bin/env python3
"""Plots of trace-bench results (matplotlib).

    python3 scripts/plot.py RESULTS.csv|FOLDER...        # auto: bars (results.csv) or
                                                         #   convergence (convergence.csv)
    python3 scripts/plot.py bars RESULTS.csv... [--ray-kind primary] [--counters steps,prims]
    python3 scripts/plot.py sweep RESULTS.csv... --param max_leaf [--metric mrays_per_s]
        [--line COLUMN=VALUE]
    python3 scripts/plot.py convergence CONVERGENCE.csv... [--metric rmse|rel_mse]

Each subcommand takes several CSVs or run folders (FOLDER/results.csv or FOLDER/convergence.csv,
or FOLDER/LATEST/...), read as one: a later file's rows replace the same rows (same scene,
structure, params, traversal, device, threads, triangle test, ray kind, ...) of an earlier one,
with a note on stderr. The PNG goes beside the last file.

- bars: MRays/s per scene, one bar per structure x traversal (x parameter set when a sweep
  varies one), with the median's 95% CI as error bars; then one panel per per-ray counter the
  rows fill (`steps` split by what a step is: BVH nodes and R-tree boxes never share an axis);
  one ray kind, thread count and triangle test;
- sweep: a metric against one parameter, one line per scene x structure x traversal, error bars
  on timing metrics. The metric is a column, `stat:KEY` (a build figure) or several joined by
  `+` and added up (`planes_per_ray+prims_per_ray`). --line COLUMN=VALUE (repeatable, all must
  hold) draws the matching rows as dashed horizontal reference lines in their scene's colour
  instead of sweep points (e.g. `--line param:measure=sah`: the SAH tree against the COS-ORTH
  beta sweep);
- convergence: error against render time, log-log, one panel per scene x integrator, one
  line per structure x traversal x device; budget rows (frame_budget_ms, read from convergence-budget.csv beside it) are printed as a table.

Ray kind, threads and triangle test default to the value most rows have (ties: primary, 1
thread, watertight); the choice is printed and written in the title. The output defaults to a
PNG beside the CSV (`results-bars.png`, `results-sweep-max_leaf.png`, `convergence.png`).
"""

import argparse
import csv
import math
import os
import sys
import textwrap

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (SPREAD_COLUMNS, TIMING_COLUMNS, amount, apply_filters,  # noqa: E402
                    counter_columns, counter_def, counter_name, is_noisy, number, params_of,
                    pick, read_csvs, resolve, rel_spread, steps_meaning, threads_phrase, unit,
                    varying_params)

try:
    import matplotlib  # noqa: E402
except ImportError:
    sys.exit("error: plot.py needs matplotlib: pip install -r scripts/requirements.txt "
             "(table.py and the paper scripts' tables need only the standard library)")

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

# Ten distinct colours; past ten series the colours repeat with a hatch (bars) or another line
# style and marker (lines), so 60 series stay distinguishable.
COLOURS = plt.get_cmap("tab10").colors
HATCHES = ["", "////", "....", "xxxx", "\\\\\\\\", "oo"]
LINESTYLES = ["-", "--", ":", "-."]
MARKERS = ["o", "s", "^", "D", "v", "P"]

CI_NOTE = "error bars: 95% CI of the median (trace_ms_ci)"


def bar_style(i):
    return {"facecolor": COLOURS[i % 10], "hatch": HATCHES[(i // 10) % len(HATCHES)],
            "edgecolor": "0.2", "linewidth": 0.4}


def line_style(i):
    return {"color": COLOURS[i % 10], "linestyle": LINESTYLES[(i // 10) % len(LINESTYLES)],
            "marker": MARKERS[(i // 10) % len(MARKERS)]}


def default_out(csv_path, *words):
    """`<dir>/<stem>-<words>.png`, leaving out words the stem already has
    (`convergence.csv` -> `convergence.png`, not `convergence-convergence.png`)."""
    stem, _ = os.path.splitext(csv_path)
    have = set(os.path.basename(stem).replace("_", "-").split("-"))
    extra = [w for w in words if w and w not in have]
    return "-".join([stem] + extra) + ".png"


def select(rows, args):
    """One ray kind, thread count and triangle test: the given ones, or the most common
    (ties: primary, 1 thread, watertight), printed. The thread count picks among CPU rows;
    GPU rows (threads 0: one host thread drives the GPU) are kept beside them."""
    rows, kind = pick(rows, "ray_kind", args.ray_kind, "primary", "ray kind", "--ray-kind")
    cpu = [r for r in rows if r.get("device", "cpu") != "gpu"]
    gpu = [r for r in rows if r.get("device", "cpu") == "gpu"]
    if cpu:
        cpu, threads = pick(cpu, "threads", args.threads, "1", "threads (CPU)", "--threads")
        rows = cpu + gpu
    rows, test = pick(rows, "triangle_test", args.triangle_test, "watertight", "triangle test",
                      "--triangle-test")
    if not rows:
        sys.exit("error: no rows match")
    on = threads_phrase(threads) if cpu else "GPU"
    if cpu and gpu:
        on = f"CPU {on}, GPU"
    return rows, f"{kind} rays, {on}, {test} test"


def error_bars(rows, col, values):
    """(lower, upper) error bar lengths of `values` from the rows' trace_ms_ci (the lower bar
    stops at zero), or None when `col` has no spread."""
    if col not in SPREAD_COLUMNS:
        return None
    lo, hi = [], []
    for r, v in zip(rows, values):
        rel = rel_spread(r, col) if r is not None else None
        h = 0.0 if v is None or rel is None else abs(v) * rel
        lo.append(min(h, v or 0.0))
        hi.append(h)
    return [lo, hi]


def noisy_note(rows, col):
    n = sum(is_noisy(r) for r in rows) if col in TIMING_COLUMNS else 0
    return f"; {n} of {len(rows)} rows noisy" if n else ""


def save(fig, out, dpi):
    fig.savefig(out, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    print(f"wrote {out}")


def bars(args):
    all_rows, files = read_csvs(args.csv)
    header = list(all_rows[0].keys()) if all_rows else []
    rows = apply_filters(all_rows, args.filter)
    rows = [r for r in rows if number(r.get("mrays_per_s")) is not None]
    if args.device:
        rows = [r for r in rows if r.get("device", "cpu") == args.device]
    if not rows:
        sys.exit("error: no timed rows match")
    rows, what = select(rows, args)
    sweep = varying_params(rows)
    several_devices = len({r.get("device", "cpu") for r in rows}) > 1

    def series(r):
        s = f"{r['structure']} {r['traversal']}"
        if several_devices:
            s += f" ({r.get('device', 'cpu')})"
        p = params_of(r)
        extra = ",".join(f"{k}={p[k]}" for k in sweep if k in p)
        return f"{s} [{extra}]" if extra else s

    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    names = list(dict.fromkeys(series(r) for r in rows))
    cell = {}
    for r in rows:
        cell.setdefault((r["scene"], series(r)), []).append(r)
    for (s, n), rs in cell.items():
        if len(rs) > 1:
            print(f"note: {len(rs)} rows for {s} / {n} averaged (narrow them with --filter)")

    # Panels: (column, title, y label, the series it may show or None for all).
    panels = [("mrays_per_s", "throughput", unit("mrays_per_s"), None)]
    counters = counter_columns(header)
    if args.counters is not None:
        want = [c.strip() for c in args.counters.split(",") if c.strip()]
        unknown = [c for c in want if f"{c}_per_ray" not in counters]
        if unknown:
            sys.exit(f"error: --counters {','.join(unknown)}: no such counter "
                     f"(counters: {', '.join(counter_name(c) for c in counters)})")
        counters = [f"{c}_per_ray" for c in want]
    skipped = []
    for col in counters:
        vals = [number(r.get(col)) for r in rows]
        if all(v is None for v in vals):
            skipped.append(f"{counter_name(col)} (not measured)")
            continue
        if all(not v for v in vals):
            skipped.append(f"{counter_name(col)} (0 for every row)")
            continue
        name = counter_name(col)
        if name != "steps":
            panels.append((col, name, textwrap.fill(f"{counter_def(col)}, per ray", 34), None))
            continue
        # A step is a different thing per structure: one panel per meaning.
        meanings = {}
        for r in rows:
            if number(r.get(col)) is not None:
                meanings.setdefault(steps_meaning(r["structure"], r["traversal"]), set()).add(series(r))
        for m, members in meanings.items():
            panels.append((col, f"steps: {m}", textwrap.fill(f"{m}, per ray", 34),
                           frozenset(members)))
    if skipped:
        print(f"counters left out: {', '.join(skipped)}")

    pw = max(3.6, 1.0 + 0.13 * len(scenes) * len(names))
    ncol = min(args.columns or (3 if pw <= 7 else 2 if pw <= 10 else 1), len(panels))
    nrow = math.ceil(len(panels) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(pw * ncol, 3.3 * nrow), squeeze=False,
                             layout="constrained")
    index = {n: i for i, n in enumerate(names)}
    for ax, (col, title, ylabel, members) in zip(axes.flat, panels):
        present = [n for n in names if (members is None or n in members)
                   and any(number(r.get(col)) is not None for s in scenes for r in cell.get((s, n), []))]
        width = 0.8 / max(3, len(present))  # a lone series is not one wide block
        for i, n in enumerate(present):
            xs, ys, rs = [], [], []
            for j, s in enumerate(scenes):
                got = [r for r in cell.get((s, n), []) if number(r.get(col)) is not None]
                if not got:
                    continue  # not measured: no bar, not a zero
                xs.append(j + (i - (len(present) - 1) / 2) * width)
                ys.append(sum(number(r[col]) for r in got) / len(got))
                rs.append(got[0] if len(got) == 1 else None)
            err = error_bars(rs, col, ys)
            ax.bar(xs, ys, width, yerr=err, error_kw={"elinewidth": 0.8, "capsize": 1.5,
                                                      "ecolor": "black"},
                   **bar_style(index[n]))
        ax.set_xticks(range(len(scenes)))
        ax.set_xticklabels(scenes, rotation=20 if len(scenes) > 3 else 0,
                           ha="right" if len(scenes) > 3 else "center")
        ax.set_title(title, fontsize=10)
        ax.set_ylabel(ylabel, fontsize=8)
        ax.grid(axis="y", alpha=0.3)
        ax.set_axisbelow(True)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    handles = [Patch(label=n, **bar_style(index[n])) for n in names]
    fig.legend(handles=handles, loc="outside right upper", fontsize=8,
               title="structure traversal", title_fontsize=8)
    fig.suptitle(f"{what}\n{CI_NOTE}{noisy_note(rows, 'mrays_per_s')}", fontsize=10)
    save(fig, args.out or default_out(files[-1], "bars"), args.dpi)


def metric_label(metric, rows):
    """The y label of a metric: its unit, and for counters what they count; a `+` sum names
    each part."""
    parts = metric.split("+")
    if all(p.endswith("_per_ray") for p in parts):
        defs = []
        for p in parts:
            if counter_name(p) == "steps":
                meanings = {steps_meaning(r["structure"], r["traversal"]) for r in rows}
                defs.append(meanings.pop() if len(meanings) == 1 else "see the legend")
            else:
                defs.append(counter_def(p))
        names = " + ".join(counter_name(p) for p in parts)
        return textwrap.fill(f"{names} per ray: {' + '.join(defs)}", 40)
    return textwrap.fill(" + ".join(unit(p) for p in parts), 40)


def single_point_hint(lines, param):
    """A line with one value of the swept parameter among several (e.g. sparse boxes' HTR,
    which reads no box, at the default d_min) is one point, not a line: say how to draw it as
    a horizontal reference line (--line) instead."""
    xs = {p[0] for pts in lines.values() for p in pts}
    single = {k for k, pts in lines.items() if len({p[0] for p in pts}) == 1}
    if len(xs) < 2 or not single:
        return
    hints = []
    for k in single:
        r = lines[k][0][2]
        for col in ("traversal", "structure"):
            if all(k2 in single for k2, pts in lines.items() if pts[0][2][col] == r[col]):
                hints.append(f"--line {col}={r[col]}")
                break
        else:
            hints.append("--line COLUMN=VALUE")
    hints = sorted(set(hints))
    print(f"note: {len(single)} line(s) have a single {param} value, drawn as one point: "
          f"{'; '.join(sorted(single))}. A series that does not depend on {param} reads better "
          f"as a horizontal reference line: {' or '.join(hints)}")


def sweep(args):
    rows, files = read_csvs(args.csv)
    rows = apply_filters(rows, args.filter)
    for part in args.metric.split("+"):
        if rows and part not in rows[0] and not part.startswith(("param:", "stat:")):
            sys.exit(f"error: --metric {args.metric}: no column `{part}`")
    rows = [r for r in rows if amount(r, args.metric) is not None]
    # Reference rows (e.g. the SAH tree against the multi-kd-tree paper's COS-ORTH beta sweep,
    # Tables 6-7): dashed horizontal lines, not points of the sweep. They need not have the
    # swept parameter.
    refs = apply_filters(rows, args.line) if args.line else []
    if args.line and not refs:
        sys.exit(f"error: --line {' '.join(args.line)}: no row matches (with a value of "
                 f"{args.metric})")
    ref_ids = {id(r) for r in refs}
    rows = [r for r in rows if id(r) in ref_ids or args.param in params_of(r)]
    if not [r for r in rows if id(r) not in ref_ids]:
        sys.exit(f"error: no rows with parameter `{args.param}` and a value of {args.metric}"
                 + (" besides the --line rows" if refs else ""))
    rows, what = select(rows, args)
    refs = [r for r in rows if id(r) in ref_ids]
    rows = [r for r in rows if id(r) not in ref_ids]
    if not rows:
        sys.exit(f"error: no sweep rows left with {what} (only --line rows)")
    if args.line and not refs:
        print(f"note: no --line row with {what}")
    others = [k for k in varying_params(rows) if k != args.param]
    several_devices = len({r.get("device", "cpu") for r in rows}) > 1
    steps = args.metric == "steps_per_ray" and len(
        {steps_meaning(r["structure"], r["traversal"]) for r in rows}) > 1
    if steps:
        print("note: steps mean different things for these structures; each line says which")
    lines, scene_of = {}, {}
    for r in rows:
        p = params_of(r)
        key = f"{r['scene']} {r['structure']} {r['traversal']}"
        if several_devices:
            key += f" ({r.get('device', 'cpu')})"
        extra = ",".join(f"{k}={p[k]}" for k in others if k in p)
        if extra:
            key += f" [{extra}]"
        if steps:
            key += f" (steps: {steps_meaning(r['structure'], r['traversal'])})"
        x = number(p[args.param])
        if x is None:
            sys.exit(f"error: parameter `{args.param}` is not numeric ({p[args.param]})")
        lines.setdefault(key, []).append((x, amount(r, args.metric), r))
        scene_of[key] = r["scene"]
    single_point_hint(lines, args.param)
    # Wide enough for the legend outside the axes to leave the axes their room.
    longest = max(len(k) for k in lines) + (40 if refs else 0)
    fig, ax = plt.subplots(figsize=(max(6.5, 4.0 + 0.065 * longest), 4.2), layout="constrained")
    xs = sorted({p[0] for pts in lines.values() for p in pts})
    # A log axis for geometric sweeps (1, 2, 4, 8), a linear one for evenly spaced values
    # (beta 0.5, 1, 1.5, ...), whose ticks would pile up at the right of a log axis.
    ratios = sorted(b / a for a, b in zip(xs, xs[1:])) if xs[0] > 0 else []
    log = bool(ratios) and xs[-1] / xs[0] >= 8 and ratios[len(ratios) // 2] >= 1.5
    spread = args.metric in SPREAD_COLUMNS

    def dodge(x, i):
        """Error bars of different lines side by side instead of on top of each other."""
        if not spread or len(lines) == 1:
            return x
        k = (i - (len(lines) - 1) / 2) * min(0.04, 0.3 / len(lines))
        return x * 2 ** k if log else x + k * (xs[-1] - xs[0] or 1) / max(1, len(xs) - 1)

    colour = {}  # scene -> the colour of its first line
    for i, (key, pts) in enumerate(lines.items()):
        pts.sort(key=lambda p: p[0])
        ys = [p[1] for p in pts]
        err = error_bars([p[2] for p in pts], args.metric, ys)
        ax.errorbar([dodge(p[0], i) for p in pts], ys, yerr=err, label=key, capsize=2.5,
                    elinewidth=0.8, markersize=4, **line_style(i))
        colour.setdefault(scene_of[key], line_style(i)["color"])
    ref_scene = {}  # legend label of a reference line -> its scene
    for r in refs:
        y = amount(r, args.metric)
        c = colour.get(r["scene"], "0.4")
        lab = f"{r['scene']} {r['structure']} {r['traversal']} [{', '.join(args.line)}]: {y:.4g}"
        ref_scene[lab] = r["scene"]
        ax.axhline(y, linestyle="--", linewidth=1.2, color=c, label=lab)
        rel = rel_spread(r, args.metric)
        if rel:
            ax.axhspan(y * (1 - rel), y * (1 + rel), color=c, alpha=0.12, linewidth=0)
    if log:
        ax.set_xscale("log", base=2)
        ax.set_xticks(xs)
        ax.set_xticklabels([f"{x:g}" for x in xs])
        ax.minorticks_off()
    ax.set_xlabel(args.param)
    ax.set_ylabel(metric_label(args.metric, rows + refs))
    note = CI_NOTE if args.metric in SPREAD_COLUMNS else ""
    if refs:
        note += ("; " if note else "") + "dashed: --line rows"
        if args.metric in SPREAD_COLUMNS:
            note += " (band: their CI)"
    note += noisy_note(rows + refs, args.metric)
    ax.set_title(f"{args.metric} against {args.param}\n{what}" + (f"\n{note.lstrip('; ')}" if note else ""),
                 fontsize=10)
    ax.grid(alpha=0.3)
    # The legend: each scene's reference lines right after that scene's sweep lines.
    handles, labels = ax.get_legend_handles_labels()
    order = {k: i for i, k in enumerate(lines)}
    ref_at = {lab: max((order[k] for k in lines if scene_of[k] == sc), default=len(lines)) + 0.5
              for lab, sc in ref_scene.items()}
    pairs = sorted(zip(handles, labels), key=lambda hl: ref_at.get(hl[1], order.get(hl[1], 0)))
    ax.legend([h for h, _ in pairs], [lab for _, lab in pairs], loc="upper left",
              bbox_to_anchor=(1.02, 1.0), fontsize=8, borderaxespad=0)
    metric = "" if args.metric == "mrays_per_s" else args.metric.replace(":", "-")
    save(fig, args.out or default_out(files[-1], "sweep", args.param, metric), args.dpi)


def convergence(args):
    rows, files = read_csvs(args.csv, names=("convergence.csv",))
    rows = apply_filters(rows, args.filter)
    if rows and "integrator" not in rows[0]:
        sys.exit(f"error: {', '.join(files)}: not a convergence.csv (no `integrator` column)")
    # Frame-budget rows live in convergence-budget.csv beside convergence.csv (older runs
    # mixed them into convergence.csv with `budget_ms` set).
    sides = [os.path.join(os.path.dirname(f), "convergence-budget.csv") for f in files]
    sides = [f for f in sides if os.path.isfile(f)]
    extra = apply_filters(read_csvs(sides)[0], args.filter) if sides else []
    curves = [r for r in rows if not r.get("budget_ms")]
    budgets = [r for r in rows + extra if r.get("budget_ms")]
    panels = list(dict.fromkeys((r["scene"], r["integrator"]) for r in curves))
    if not panels:
        sys.exit("error: no progressive rows")
    key_of = lambda r: f"{r['structure']} {r['traversal']} {r['device']}"
    keys = list(dict.fromkeys(key_of(r) for r in curves))
    ncol = min(2, len(panels))
    nrow = math.ceil(len(panels) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.0 * ncol, 3.8 * nrow), squeeze=False,
                             layout="constrained")
    p = 0.5 if args.metric == "rmse" else 1.0
    for ax, (scene, integ) in zip(axes.flat, panels):
        sel = [r for r in curves if r["scene"] == scene and r["integrator"] == integ]
        drawn = 0
        for i, key in enumerate(keys):
            pts = [(number(r["elapsed_ms"]), number(r[args.metric]), r["spp"])
                   for r in sel if key_of(r) == key]
            pts = [q for q in pts if q[0] and q[1]]
            if not pts:
                continue
            ax.loglog([q[0] for q in pts], [q[1] for q in pts], markersize=4, label=key,
                      **line_style(i))
            # The final sample count beside the last point, each curve's label moved down by
            # its index so that curves ending close together do not print over each other.
            ax.annotate(f"{pts[-1][2]} spp", (pts[-1][0], pts[-1][1]), xytext=(6, 2 - 10 * drawn),
                        textcoords="offset points", fontsize=7, color=line_style(i)["color"],
                        va="center")
            drawn += 1
        # The Monte Carlo slope for reference (1/sqrt(t) for RMSE, 1/t for MSE-type metrics).
        xs = sorted(number(r["elapsed_ms"]) for r in sel if number(r["elapsed_ms"]))
        ys = [number(r[args.metric]) for r in sel if number(r[args.metric])]
        if xs and ys:
            y0 = max(ys)
            ax.loglog([xs[0], xs[-1]], [y0, y0 * (xs[0] / xs[-1]) ** p], "k--", lw=0.8,
                      label=f"slope −{p:g} (Monte Carlo)")
        # Room on the right for the spp labels.
        lo, hi = ax.get_xlim()
        ax.set_xlim(lo, hi * 2.5)
        ax.set_title(f"{scene}: {integ}", fontsize=10)
        ax.set_xlabel("render time (ms)")
        ax.set_ylabel(unit(args.metric))
        ax.grid(which="both", alpha=0.3)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    handles = {}
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(list(handles.values()), list(handles.keys()), loc="outside right upper",
               fontsize=8, title="structure traversal device", title_fontsize=8)
    metric = "" if args.metric == "rmse" else args.metric
    save(fig, args.out or default_out(files[-1], "convergence", metric), args.dpi)
    if budgets:
        print(f"{'scene':<12} {'integrator':<10} {'structure':<10} {'traversal':<10} {'budget_ms':>9} {'spp':>5} {'elapsed_ms':>10} {args.metric:>9}")
        for r in budgets:
            v = number(r[args.metric])
            print(f"{r['scene']:<12} {r['integrator']:<10} {r['structure']:<10} {r['traversal']:<10} "
                  f"{float(r['budget_ms']):>9.1f} {r['spp']:>5} {float(r['elapsed_ms']):>10.1f} "
                  f"{'-' if v is None else f'{v:.4f}':>9}")


def main(argv):
    kinds = {"bars", "sweep", "convergence"}
    if argv and argv[0] not in kinds and not argv[0].startswith("-"):
        # Auto-detect from the file (a folder: results.csv, else convergence.csv).
        path = resolve(argv[0], ("results.csv", "convergence.csv"))
        head = []
        if os.path.isfile(path):  # otherwise read_csvs names the missing file
            with open(path, newline="") as f:
                head = next(csv.reader(f), [])
        kind = "convergence" if "integrator" in head else "bars"
        argv = [kind] + argv
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="kind", required=True)

    def common(sp):
        sp.add_argument("csv", nargs="+", metavar="CSV|FOLDER",
                        help="CSVs or run folders, read as one (a later file's rows replace "
                             "the same rows of an earlier one)")
        sp.add_argument("--out", help="PNG to write (default: beside the (last) CSV)")
        sp.add_argument("--filter", action="append", metavar="COLUMN=VALUE",
                        help="keep rows where COLUMN (or param:KEY) equals VALUE; repeatable")
        sp.add_argument("--dpi", type=int, default=110)

    def selection(sp):
        sp.add_argument("--ray-kind", help="default: the most common (tie: primary)")
        sp.add_argument("--threads", help="default: the most common (tie: 1)")
        sp.add_argument("--triangle-test", help="default: the most common (tie: watertight)")

    b = sub.add_parser("bars", help="MRays/s and per-ray counters per structure and traversal")
    common(b)
    selection(b)
    b.add_argument("--device", help="cpu or gpu (default: both, told apart in the legend)")
    b.add_argument("--counters", metavar="NAME,…",
                   help="counter panels, e.g. steps,prims (default: every counter the rows "
                        "measure; an empty string for none)")
    b.add_argument("--columns", type=int,
                   help="panels per row (default: 3, fewer when the panels are wide)")
    s = sub.add_parser("sweep", help="a metric against a parameter")
    common(s)
    selection(s)
    s.add_argument("--param", required=True, help="parameter key, e.g. max_leaf")
    s.add_argument("--metric", default="mrays_per_s",
                   help="a column, stat:KEY (a build figure), or several joined by + and added "
                        "up, e.g. planes_per_ray+prims_per_ray")
    s.add_argument("--line", action="append", metavar="COLUMN=VALUE",
                   help="draw the rows that match as dashed horizontal reference lines instead "
                        "of sweep points (e.g. param:measure=sah); repeatable, all must hold")
    c = sub.add_parser("convergence", help="error against time, log-log")
    common(c)
    c.add_argument("--metric", default="rmse", choices=["rmse", "rel_mse"])
    args = p.parse_args(argv)
    if getattr(args, "columns", None) is not None and args.columns < 1:
        p.error("--columns must be 1 or more")
    {"bars": bars, "sweep": sweep, "convergence": convergence}[args.kind](args)


if __name__ == "__main__":
    main(sys.argv[1:])
