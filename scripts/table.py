#!/usr/bin/env python3
"""Print a results CSV in the layout of a paper's table: rows (e.g. scenes) x columns (variants),
each cell a value, with the percentage change against a named baseline column beside every
other column, as the papers print them.

    python3 scripts/table.py RESULTS.csv|RUN_FOLDER... --rows scene --cols param:max_leaf \\
        --value mrays_per_s --baseline 4 [--filter ray_kind=primary] \\
        [--format text|markdown|latex] [--digits 2] [--no-spread] [--drop-noisy]

Several CSVs (or run folders: FOLDER/results.csv, or FOLDER/LATEST/results.csv) are read as one:
rows with the same identity columns (scene, structure, params, traversal, device, threads,
triangle test, ray kind, ...) are taken from the later file, with a note on stderr.

--rows / --cols take a CSV column or `param:KEY` (one parameter of the `params` column), or
several joined by `+` (`--cols structure+traversal`). Every cell must come from exactly one
row: when several rows fall in one cell, narrow them with --filter COLUMN=VALUE (VALUE may list
alternatives `A|B`; the error names the columns that differ), or add them up with --sum COLUMN
(e.g. `--sum ray_kind`: the R-tree paper's "primary and shadow rays" times are the sum of the
two batches). A percentage is 100 · (value − baseline) / baseline of the same row. --value
takes a column, `stat:KEY` (one build figure of the `build_stats` column) or several of these
joined by `+`, added up (e.g. `planes_per_ray+prims_per_ray`, the multi-kd-tree paper's
traversal steps).

Timing values (trace_ms_median, mrays_per_s) print as `value ± half-width` of the median's 95%
confidence interval (the CSV's trace_ms_ci, relative to the median; mrays_per_s takes the same
relative half-width); only a single timing column has one, a `+` sum of columns none. A summed
cell (--sum) combines the half-widths of its rows in quadrature. A cell
of a timing column whose row is flagged `noisy` is marked †, and so is a percentage built from
it (the cell's or the baseline's); the footnote counts the noisy rows. --drop-noisy leaves the
timings of noisy rows out (their cells print -).

When the cells of a timing value (the timing columns, build_ms, upload_ms, readback_ms,
sort_ms) come from more than one machine (the `host` column, e.g. a run merged from shards that
ran on several cluster nodes), a warning on stderr names the hosts: counters are host-independent,
timings are not; narrow with --filter host=NAME or rerun on one machine.
"""

import argparse
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (DAGGER, NOISY_WHY, TIMING_COLUMNS, add_noisy_option,  # noqa: E402
                    amount, apply_filters, column, drop_noisy, is_noisy, read_csvs, rel_spread)


# Columns that identify a row (the others are measurements).
KEYS = ["scene", "structure", "params", "traversal", "device", "adapter", "threads",
        "triangle_test", "ray_kind", "integrator", "pass", "budget_ms"]


class Cell:
    """One table cell: value, absolute half-width of its 95% CI (None: none), noisy flag, and
    how many of its rows are timed / noisy (for the footnote)."""

    def __init__(self, value, half=None, noisy=False, timed=0, noisy_rows=0):
        self.value, self.half, self.noisy = value, half, noisy
        self.timed, self.noisy_rows = timed, noisy_rows


def cell_of(rows, args):
    """The cell of one row, or of several rows added up (--sum)."""
    cells = []
    for r in rows:
        # A `+` sum (amount) is never in SPREAD_COLUMNS / TIMING_COLUMNS: no ± and no †.
        v = amount(r, args.value)
        rel = rel_spread(r, args.value)
        noisy = args.value in TIMING_COLUMNS and is_noisy(r)
        cells.append(Cell(v, None if v is None or rel is None else abs(v) * rel, noisy))
    if any(c.value is None for c in cells):
        return Cell(None)
    halves = [c.half for c in cells]
    timing = args.value in TIMING_COLUMNS
    return Cell(sum(c.value for c in cells),
                None if None in halves else math.sqrt(sum(h * h for h in halves)),
                any(c.noisy for c in cells), len(cells) if timing else 0,
                sum(c.noisy for c in cells))


# Values measured in time: comparing them across machines compares the machines.
TIMED = TIMING_COLUMNS | {"build_ms", "upload_ms", "readback_ms", "sort_ms"}


def warn_hosts(rows, value):
    """Warn on stderr when a table of timings mixes rows of several hosts."""
    if not any(part in TIMED for part in value.split("+")):
        return
    hosts = list(dict.fromkeys(r.get("host", "") for r in rows if r.get("host")))
    if len(hosts) > 1:
        print(f"warning: this table compares timings taken on {len(hosts)} hosts "
              f"({', '.join(hosts)}): counters are host-independent, timings are not; "
              "narrow with --filter host=NAME", file=sys.stderr)


def name_of(spec):
    """`param:max_leaf` -> `max_leaf`; `structure+param:builder` -> `structure/builder`."""
    return "/".join(s.replace("param:", "", 1) for s in spec.split("+"))


def build(rows, args):
    """(row keys, column keys, cells {(row, col): Cell})."""
    groups = {}
    for r in rows:
        groups.setdefault((column(r, args.rows), column(r, args.cols)), []).append(r)
    cells = {}
    for key, rs in groups.items():
        if len(rs) > 1 and not (args.sum and len({column(r, args.sum) for r in rs}) == len(rs)):
            differ = [c for c in KEYS if c in rs[0] and len({r[c] for r in rs}) > 1]
            sys.exit(f"error: {len(rs)} rows for {args.rows}={key[0]}, {args.cols}={key[1]}; "
                     f"narrow with --filter on one of: {', '.join(differ) or '(identical rows)'}"
                     + ("" if args.sum else ", or add them up with --sum COLUMN"))
        cells[key] = cell_of(rs, args)
    row_keys = list(dict.fromkeys(k[0] for k in groups))
    col_keys = list(dict.fromkeys(k[1] for k in groups))
    try:
        col_keys.sort(key=float)
    except ValueError:
        pass
    if args.baseline not in col_keys:
        sys.exit(f"error: --baseline {args.baseline}: not a value of {args.cols} "
                 f"(values: {', '.join(col_keys)})")
    return row_keys, col_keys, cells


def fmt_num(v, digits):
    """Fixed decimals with thousands separators; `-0.00` printed as `0.00`."""
    s = f"{v:,.{digits}f}"
    return s[1:] if s.startswith("-") and float(s[1:].replace(",", "")) == 0 else s


def percent(v, base):
    if v is None or base in (None, 0):
        return None
    return round(100.0 * (v - base) / base, 1) + 0.0  # no "-0.0%"


def layout(row_keys, col_keys, cells, args):
    """Header and rows as lists of parts: a value cell is (value, half-width, mark) strings,
    a percentage cell and a label are plain strings."""
    corner = f"{name_of(args.rows)} \\ {name_of(args.cols)}"
    header = [corner]
    kinds = ["label"]
    for ck in col_keys:
        header.append(ck + (" (base)" if ck == args.baseline else ""))
        kinds.append("value")
        if ck != args.baseline:
            header.append("%")
            kinds.append("pct")
    body = []
    any_noisy = any(c.noisy and c.value is not None for c in cells.values())
    for rk in row_keys:
        base_cell = cells.get((rk, args.baseline), Cell(None))
        base = base_cell.value
        line = [rk]
        for ck in col_keys:
            c = cells.get((rk, ck), Cell(None))
            if c.value is None:
                line.append(("-", "", ""))
            else:
                half = fmt_num(c.half, args.digits) if c.half is not None and args.spread else ""
                line.append((fmt_num(c.value, args.digits), half, DAGGER if c.noisy else ""))
            if ck != args.baseline:
                p = percent(c.value, base)
                # A change built from a noisy cell or a noisy baseline is marked too.
                noisy = p is not None and (c.noisy or base_cell.noisy)
                line.append("-" if p is None else f"{p:+.1f}%" + (DAGGER if noisy else ""))
        body.append(line)
    return header, kinds, body, any_noisy


def footnote(cells):
    """The † footnote: how many of the table's timed rows are noisy."""
    shown = [c for c in cells.values() if c.value is not None]
    n, t = sum(c.noisy_rows for c in shown), sum(c.timed for c in shown)
    return (f"{DAGGER} noisy timing ({n} of {t} timed rows): {NOISY_WHY}; a % built from one "
            "is marked too; --drop-noisy leaves them out")


def render_text(header, kinds, body, any_noisy, style, note):
    def joined(parts, wv, wh, pm):
        v, h, m = parts
        if not h:
            s = v.rjust(wv) + (" " * (len(pm) + wh) if wh else "")
        else:
            s = v.rjust(wv) + pm + h.rjust(wh)
        return s + (m or " ") if any_noisy else s

    pm = " ± "
    # Widths of the value and half-width parts per column, so that ± lines up.
    cols = []
    for j, kind in enumerate(kinds):
        if kind == "value":
            wv = max(len(line[j][0]) for line in body)
            wh = max(len(line[j][1]) for line in body)
            cols.append((wv, wh))
        else:
            cols.append(None)
    cells = []
    for line in body:
        out = []
        for j, kind in enumerate(kinds):
            if kind == "value":
                out.append(joined(line[j], *cols[j], pm))
            elif kind == "pct" and any_noisy and not line[j].endswith(DAGGER):
                out.append(line[j] + " ")  # the marks line up
            else:
                out.append(line[j])
        cells.append(out)
    if style == "markdown":
        align = ["---" if k == "label" else "---:" for k in kinds]
        esc = lambda s: s.replace("|", "\\|")
        out = ["| " + " | ".join(esc(h) for h in header) + " |", "|" + "|".join(align) + "|"]
        out += ["| " + " | ".join(esc(c.strip()) for c in r) + " |" for r in cells]
    else:
        widths = [max(len(x) for x in col) for col in zip(header, *cells)]
        line = lambda r: "  ".join(x.ljust(w) if i == 0 else x.rjust(w)
                                   for i, (x, w) in enumerate(zip(r, widths))).rstrip()
        out = [line(header), "  ".join("-" * w for w in widths)] + [line(r) for r in cells]
    if any_noisy:
        out.append(("" if style == "text" else "\n") + note)
    return "\n".join(out)


LATEX_ESCAPES = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
                 "_": r"\_", "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}",
                 "^": r"\textasciicircum{}", "±": r"$\pm$", "†": r"$^\dagger$",
                 "−": "$-$", "·": r"$\cdot$"}


def tex(s):
    return "".join(LATEX_ESCAPES.get(ch, ch) for ch in s)


def tex_num(s):
    """A number: a leading minus as a math minus."""
    return "$-$" + tex(s[1:]) if s.startswith("-") and len(s) > 1 else tex(s)


def render_latex(header, kinds, body, any_noisy, title, args, note):
    ncols = len(kinds)
    out = [f"% caption: {title}",
           "% needs \\usepackage{booktabs}",
           "\\begin{tabular}{l" + "r" * (ncols - 1) + "}",
           "\\toprule",
           f" & \\multicolumn{{{ncols - 1}}}{{c}}{{{tex(name_of(args.cols))}}} \\\\",
           f"\\cmidrule(lr){{2-{ncols}}}",
           " & ".join([tex(name_of(args.rows))] + [tex(h) for h in header[1:]]) + " \\\\",
           "\\midrule"]
    for line in body:
        parts = [tex(line[0])]
        for j, kind in enumerate(kinds[1:], 1):
            if kind == "value":
                v, h, m = line[j]
                s = tex_num(v) if v != "-" else "--"
                if h:
                    s += " $\\pm$ " + tex_num(h)
                if m:
                    s += "$^\\dagger$"
                parts.append(s)
            else:
                parts.append(tex_num(line[j]) if line[j] != "-" else "--")
        out.append(" & ".join(parts) + " \\\\")
    out.append("\\bottomrule")
    if any_noisy:
        # `--` would print as an en dash.
        note = tex(note).replace("--drop-noisy", "\\texttt{-{}-drop-noisy}")
        out.append(f"\\multicolumn{{{ncols}}}{{l}}{{\\footnotesize {note}}} \\\\")
    out.append("\\end{tabular}")
    return "\n".join(out)


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("csv", nargs="+", metavar="CSV|FOLDER",
                   help="results.csv files or run folders (FOLDER/results.csv, or "
                        "FOLDER/LATEST/results.csv); rows of a later file replace the same rows "
                        "of an earlier one")
    p.add_argument("--rows", default="scene")
    p.add_argument("--cols", required=True, help="column or param:KEY whose values are the columns")
    p.add_argument("--value", default="mrays_per_s",
                   help="a column, stat:KEY (a build figure), or several joined by + and added "
                        "up, e.g. planes_per_ray+prims_per_ray")
    p.add_argument("--baseline", required=True, help="the column value the others are compared with")
    p.add_argument("--filter", action="append", metavar="COLUMN=VALUE")
    p.add_argument("--sum", metavar="COLUMN",
                   help="add up the rows of a cell that differ only in this column")
    p.add_argument("--digits", type=int,
                   help="decimals of every value and half-width (default 2; 0 when every "
                        "value is a whole number, e.g. memory_bytes, nodes)")
    p.add_argument("--no-spread", dest="spread", action="store_false",
                   help="values only, without ± the half-width of the median's 95%% CI")
    p.add_argument("--format", default="text", choices=["text", "markdown", "latex"])
    add_noisy_option(p)
    args = p.parse_args(argv)
    if args.digits is not None and args.digits < 0:
        p.error("--digits must be 0 or more")
    rows, _ = read_csvs(args.csv)
    rows = drop_noisy(apply_filters(rows, args.filter), args.drop_noisy)
    for part in args.value.split("+") if rows else []:
        column(rows[0], part)  # an unknown column is an error here, naming the columns
    rows = [r for r in rows if column(r, args.cols) != ""]
    if not rows:
        sys.exit("error: no rows left after the filters")
    row_keys, col_keys, cells = build(rows, args)
    warn_hosts(rows, args.value)
    if args.digits is None:
        whole = all(c.value is None or (c.value == int(c.value) and c.half is None)
                    for c in cells.values())
        args.digits = 0 if whole else 2
    header, kinds, body, any_noisy = layout(row_keys, col_keys, cells, args)
    title = f"{args.value}, rows {args.rows}, columns {args.cols}, baseline {args.baseline}"
    if args.filter:
        title += f" ({', '.join(args.filter)})"
    if args.sum:
        title += f", summed over {args.sum}"
    if args.spread and any(c.half is not None for c in cells.values()):
        title += "; value ± half-width of the median's 95% CI"
    if args.drop_noisy:
        title += ", timings of noisy rows left out"
    note = footnote(cells)
    if args.format == "latex":
        print(render_latex(header, kinds, body, any_noisy, title, args, note))
    else:
        print(title)
        print(render_text(header, kinds, body, any_noisy, args.format, note))


if __name__ == "__main__":
    main(sys.argv[1:])
