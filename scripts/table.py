#!/usr/bin/env python3
"""Print a results CSV in the layout of a paper's table: rows (e.g. scenes) x columns (variants),
each cell a value, with the percentage change against a named baseline column beside every
other column, as the papers print them.

    python3 scripts/table.py RESULTS.csv --rows scene --cols param:max_leaf \\
        --value mrays_per_s --baseline 4 [--filter ray_kind=primary] [--format text|markdown]

--rows / --cols take a CSV column or `param:KEY` (one parameter of the `params` column), or
several joined by `+` (`--cols structure+traversal`). Every cell must come from exactly one
row: when several rows fall in one cell, narrow them with --filter COLUMN=VALUE (VALUE may list
alternatives `A|B`; the error names the columns that differ), or add them up with --sum COLUMN
(e.g. `--sum ray_kind`: the R-tree paper's "primary and shadow rays" times are the sum of the
two batches). A percentage is 100 · (value − baseline) / baseline of the same row. --value
takes a column, `stat:KEY` (one build figure) or several joined by `+`, added up (e.g.
`planes_per_ray+prims_per_ray`, the multi-kd-tree paper's traversal steps).
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import amount, apply_filters, column, read_rows  # noqa: E402


# Columns that identify a row (the others are measurements).
KEYS = ["scene", "structure", "params", "traversal", "device", "adapter", "threads",
        "triangle_test", "ray_kind", "integrator", "pass", "budget_ms"]


def fmt(v, digits):
    if v is None:
        return "-"
    if abs(v) >= 1000:
        return f"{v:,.0f}"
    return f"{v:.{digits}f}"


def build(rows, args):
    cells = {}
    for r in rows:
        key = (column(r, args.rows), column(r, args.cols))
        cells.setdefault(key, []).append(r)
    summed = {}
    for key, rs in cells.items():
        if args.sum and len(rs) > 1 and len({r[args.sum] for r in rs}) == len(rs):
            vals = [amount(r, args.value) for r in rs]
            summed[key] = None if None in vals else sum(vals)
            continue
        if len(rs) > 1:
            differ = [c for c in KEYS if c in rs[0] and len({r[c] for r in rs}) > 1]
            sys.exit(f"error: {len(rs)} rows for {args.rows}={key[0]}, {args.cols}={key[1]}; "
                     f"narrow with --filter on one of: {', '.join(differ) or '(identical rows)'}")
    def value(key):
        if key not in cells:
            return None
        if key in summed:
            return summed[key]
        return amount(cells[key][0], args.value)

    row_keys = list(dict.fromkeys(k[0] for k in cells))
    col_keys = list(dict.fromkeys(k[1] for k in cells))
    try:
        col_keys.sort(key=float)
    except ValueError:
        pass
    if args.baseline not in col_keys:
        sys.exit(f"error: --baseline {args.baseline}: not a value of {args.cols} "
                 f"(values: {', '.join(col_keys)})")
    table = []
    for rk in row_keys:
        base = value((rk, args.baseline))
        line = [rk]
        for ck in col_keys:
            v = value((rk, ck))
            line.append(fmt(v, args.digits))
            if ck != args.baseline:
                if v is None or base in (None, 0):
                    line.append("-")
                else:
                    pct = round(100.0 * (v - base) / base, 1) + 0.0  # no "-0.0%"
                    line.append(f"{pct:+.1f}%")
        table.append(line)
    header = [args.rows]
    for ck in col_keys:
        name = f"{args.cols.replace('param:', '')}={ck}"
        header.append(name + (" (base)" if ck == args.baseline else ""))
        if ck != args.baseline:
            header.append("%")
    return header, table


def render(header, table, style):
    if style == "markdown":
        out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
        out += ["| " + " | ".join(r) + " |" for r in table]
        return "\n".join(out)
    widths = [max(len(x) for x in col) for col in zip(header, *table)]
    line = lambda r: "  ".join(x.ljust(w) if i == 0 else x.rjust(w) for i, (x, w) in enumerate(zip(r, widths)))
    return "\n".join([line(header), "  ".join("-" * w for w in widths)] + [line(r) for r in table])


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("csv")
    p.add_argument("--rows", default="scene")
    p.add_argument("--cols", required=True, help="column or param:KEY whose values are the columns")
    p.add_argument("--value", default="mrays_per_s")
    p.add_argument("--baseline", required=True, help="the column value the others are compared with")
    p.add_argument("--filter", action="append", metavar="COLUMN=VALUE")
    p.add_argument("--sum", metavar="COLUMN",
                   help="add up the rows of a cell that differ only in this column")
    p.add_argument("--digits", type=int, default=2)
    p.add_argument("--format", default="text", choices=["text", "markdown"])
    args = p.parse_args(argv)
    rows = apply_filters(read_rows(args.csv), args.filter)
    rows = [r for r in rows if column(r, args.cols) != ""]
    if not rows:
        sys.exit("error: no rows left after the filters")
    header, table = build(rows, args)
    title = f"{args.value}, rows {args.rows}, columns {args.cols}, baseline {args.baseline}"
    if args.filter:
        title += f" ({', '.join(args.filter)})"
    if args.sum:
        title += f", summed over {args.sum}"
    print(title)
    print(render(header, table, args.format))


if __name__ == "__main__":
    main(sys.argv[1:])
