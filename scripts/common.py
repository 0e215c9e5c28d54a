"""Shared helpers of the plotting scripts: reading trace-bench CSVs, parameter columns, filters."""

import csv
import sys


def read_rows(path):
    """Rows of a results.csv or convergence.csv as dicts of strings."""
    try:
        with open(path, newline="") as f:
            return list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f"error: {path}: {e.strerror}")


def params_of(row):
    """The `params` column `k=v;k=v` as a dict."""
    out = {}
    for kv in (row.get("params") or "").split(";"):
        if "=" in kv:
            k, v = kv.split("=", 1)
            out[k] = v
    return out


def stats_of(row):
    """The `build_stats` column `k=v;k=v` as a dict."""
    out = {}
    for kv in (row.get("build_stats") or "").split(";"):
        if "=" in kv:
            k, v = kv.split("=", 1)
            out[k] = v
    return out


def column(row, name):
    """Value of `name` in a row: a CSV column, `param:KEY` for one parameter, `stat:KEY` for one
    build figure (`build_stats`), or several of these joined by `+` (their values joined by
    `/`, empty ones left out)."""
    if "+" in name:
        return "/".join(v for v in (column(row, n) for n in name.split("+")) if v)
    if name.startswith("param:"):
        return params_of(row).get(name[len("param:"):], "")
    if name.startswith("stat:"):
        return stats_of(row).get(name[len("stat:"):], "")
    if name not in row:
        sys.exit(f"error: no column `{name}` (columns: {', '.join(row.keys())})")
    return row[name]


def number(s):
    """A cell as float, None when empty (not measured)."""
    try:
        return float(s) if s not in ("", None) else None
    except ValueError:
        return None


def amount(row, name):
    """A numeric value: a column (or `stat:KEY`), or the sum of several joined by `+` (None
    when one is empty), e.g. `planes_per_ray+prims_per_ray`."""
    vals = [number(column(row, n)) for n in name.split("+")]
    return None if None in vals else sum(vals)


def apply_filters(rows, filters):
    """Keep rows where every `COLUMN=VALUE` filter holds (COLUMN may be `param:KEY`; VALUE may
    list alternatives `A|B`, and an empty alternative matches rows without that parameter)."""
    for f in filters or []:
        if "=" not in f:
            sys.exit(f"error: --filter {f}: expected COLUMN=VALUE")
        k, v = f.split("=", 1)
        allowed = set(v.split("|"))
        rows = [r for r in rows if column(r, k) in allowed]
    return rows


def label(row, keys):
    """A short label from some columns, skipping empty ones."""
    return " ".join(column(row, k) for k in keys if column(row, k))


def varying_params(rows):
    """Parameter keys whose value differs between rows of the same structure."""
    by = {}
    for r in rows:
        for k, v in params_of(r).items():
            by.setdefault((r["structure"], k), set()).add(v)
    return sorted({k for (_, k), vs in by.items() if len(vs) > 1})
