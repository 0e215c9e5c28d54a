"""Shared helpers of the plotting scripts: reading trace-bench CSVs, parameter columns, filters."""

import csv
import os
import sys


def read_rows(path):
    """Rows of a results.csv or convergence.csv as dicts of strings."""
    try:
        with open(path, newline="") as f:
            return list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f"error: {path}: {e.strerror}")


# --- Several runs: files and folders, concatenated ------------------------------------------

# Columns that identify a row (the others are measurements), in any of the CSVs a run writes:
# results.csv, convergence.csv (integrator, width, height, pass, budget_ms), dynamic.csv
# (width, height, budget_ms, frame). A column a CSV lacks counts as empty.
IDENTITY = ["scene", "structure", "params", "traversal", "device", "adapter", "threads",
            "triangle_test", "ray_kind", "integrator", "width", "height", "pass", "budget_ms",
            "frame"]


def resolve(path, names=("results.csv",)):
    """A CSV path as given, or a run folder: FOLDER/NAME, the first of `names` it holds; a
    folder holding none of them but a `LATEST` entry (results/NAME/LATEST, the harness's link
    to the newest run) reads FOLDER/LATEST/NAME."""
    if not os.path.isdir(path):
        return path
    for base in (path, os.path.join(path, "LATEST")):
        for n in names:
            p = os.path.join(base, n)
            if os.path.isfile(p):
                return p
    sys.exit(f"error: {path}: a folder without {' or '.join(names)} (nor LATEST/ holding one)")


def identity_of(row, header):
    return tuple(row.get(c, "") for c in IDENTITY if c in header)


def read_csvs(paths, names=("results.csv",), key=None):
    """The rows of several CSVs (or run folders, see `resolve`), concatenated in the order
    given, as dicts over the union of their headers (a column a file lacks is empty). A row
    whose identity columns (IDENTITY; `key(row)` instead when given) equal a row of an earlier
    file replaces it: the later file wins, and a note on stderr says how many rows of which file
    were replaced. A file given twice is read once. Returns (rows, the files read)."""
    files, seen = [], set()
    for p in paths:
        f = resolve(p, names)
        real = os.path.realpath(f)
        if real in seen:
            print(f"note: {f} given twice; read once", file=sys.stderr)
            continue
        seen.add(real)
        files.append(f)
    tables = [read_rows(f) for f in files]
    header = list(dict.fromkeys(c for t in tables for r in t[:1] for c in r if c is not None))
    owner = {}  # identity -> (file index, positions in `out` of that file's rows)
    out = []
    same = "identity" if key else ", ".join(c for c in IDENTITY if c in header)
    for i, t in enumerate(tables):
        replaced = {}
        for r in t:
            r = {c: (r.get(c) if r.get(c) is not None else "") for c in header}
            k = key(r) if key else identity_of(r, header)
            prev = owner.get(k)
            if prev is not None and prev[0] != i:
                for at in prev[1]:
                    out[at] = None
                replaced[prev[0]] = replaced.get(prev[0], 0) + len(prev[1])
                prev = None
            if prev is None:
                prev = owner[k] = (i, [])
            prev[1].append(len(out))
            out.append(r)
        for j, n in sorted(replaced.items()):
            print(f"note: {n} row(s) of {files[j]} replaced by the same rows (same {same}) of "
                  f"{files[i]}: the later file wins", file=sys.stderr)
    return [r for r in out if r is not None], files


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


def memory_column(rows):
    """The memory column the papers' tables read: `structure_bytes` (the structure alone, as
    the papers count memory) where any row has it, else `memory_bytes` (results written
    before that column existed)."""
    has = any(number(r.get("structure_bytes")) is not None for r in rows)
    return "structure_bytes" if has else "memory_bytes"


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


# --- Measurements: spread, noise, units, counters -------------------------------------------

# Columns whose spread is the median's confidence interval (`trace_ms_ci`, relative to the
# median): the median time itself and the throughput computed from it.
SPREAD_COLUMNS = {"trace_ms_median", "mrays_per_s"}
# Columns from the timed runs, which the row's `noisy` flag is about (counters are exact).
TIMING_COLUMNS = {"trace_ms_min", "trace_ms_median", "trace_ms_max", "mrays_per_s"}

# The per-ray counters' definitions (README, "Results columns"); a counter not listed here
# (a newer one) is still plotted and tabulated, with a pointer to the README.
COUNTER_DEFS = {
    "interior": "interior nodes visited",
    "leaves": "leaves visited (empty ones included)",
    "prims": "ray-triangle tests",
    "boxes": "ray-box (slab) tests",
    "planes": "ray-splitting-plane distances computed (kd-trees)",
    "restarts": "restarts from the root or a pushed-down node, and backtracks",
    "steps": "traversal steps, as each structure defines them",
}


def counter_columns(header):
    """The `<counter>_per_ray` columns of a CSV header, in header order."""
    return [c for c in header if c.endswith("_per_ray")]


def counter_name(col):
    """`interior_per_ray` -> `interior`."""
    return col[: -len("_per_ray")] if col.endswith("_per_ray") else col


def counter_def(col):
    """A counter column's definition, or a pointer to the README for one not known here."""
    return COUNTER_DEFS.get(counter_name(col), "see README, Results columns")


def steps_meaning(structure, traversal):
    """What one `steps` unit is for a structure and traversal (README, `steps_per_ray`):
    rows whose steps mean different things must not share an axis or a column."""
    if structure in ("bvh", "kdtree", "rtree"):
        # The R-tree's three traversals count the nodes they enter alike (README).
        return "nodes visited"
    return f"{structure} {traversal} steps"


def unit(col):
    """An axis label with the unit of a column."""
    if col == "mrays_per_s":
        return "MRays/s (million rays per second)"
    if col.endswith("_ms") or col.startswith("trace_ms_") or col in ("elapsed_ms", "budget_ms"):
        return f"{col} (ms)"
    if col.endswith("_per_ray"):
        return f"{counter_name(col)} per ray"
    if col.endswith("_max"):
        return f"{col[: -len('_max')]}, most in one ray"
    if col.endswith("_bytes"):
        return f"{col} (bytes)"
    if col == "hit_rate":
        return "hit rate (share of rays)"
    if col == "rmse":
        return "RMSE"
    if col == "rel_mse":
        return "relative MSE"
    return col


def rel_spread(row, col):
    """Relative half-width of a timing column's 95% CI (`trace_ms_ci`), or None where the
    column has no such spread or the row does not record it."""
    if col not in SPREAD_COLUMNS:
        return None
    return number(row.get("trace_ms_ci"))


def is_noisy(row):
    """The row's `noisy` flag (README: the CI is wider than run.target_ci, or the machine was
    loaded while it ran)."""
    return (row.get("noisy") or "").strip().lower() in ("true", "1", "yes")


DAGGER = "†"
NOISY_WHY = ("the median's 95% CI is wider than run.target_ci, or the machine was loaded "
             "while the row ran")
# What a noisy row's timings are: the columns --drop-noisy leaves out.
NOISY_DROPPED = ["trace_ms_min", "trace_ms_median", "trace_ms_max", "mrays_per_s",
                 "trace_ms_ci", "sort_ms"]


def mark(noisy):
    """† after a figure built from a noisy row, else nothing."""
    return DAGGER if noisy else ""


def add_noisy_option(parser):
    parser.add_argument("--drop-noisy", action="store_true",
                        help="leave out the timings of rows flagged noisy (figures built from "
                             "them print -; counters, which do not depend on the load, stay)")


def drop_noisy(rows, enabled=True):
    """With `enabled`, the rows with the timings of the noisy ones blanked (NOISY_DROPPED; the
    counters and build figures stay), and a note on stderr saying how many."""
    if not enabled:
        return rows
    n = sum(is_noisy(r) for r in rows)
    print(f"--drop-noisy: the timings of {n} noisy row(s) of {len(rows)} left out",
          file=sys.stderr)
    return [{**r, **{c: "" for c in NOISY_DROPPED if c in r}} if is_noisy(r) else r
            for r in rows]


def timed(row):
    """Whether a row has a trace time (a skipped or dropped row has none)."""
    return number(row.get("trace_ms_median")) is not None


def noisy_footnote(rows):
    """The † footnote: how many of the timed rows read are noisy; empty when none is."""
    t = [r for r in rows if timed(r)]
    n = sum(is_noisy(r) for r in t)
    if not n:
        return ""
    return (f"{DAGGER} noisy timing ({n} of {len(t)} timed rows): {NOISY_WHY}; a figure built "
            "from one (a ratio, a change, a sum) is marked too; --drop-noisy leaves them out")


def threads_phrase(threads):
    """`1 thread`, `2 threads`."""
    return f"{threads} thread" + ("" if threads == "1" else "s")


def _natural(v):
    try:
        return (0, float(v), "")
    except ValueError:
        return (1, 0.0, v)


def pick(rows, col, want, prefer, what, option):
    """Rows with `col == want`; without `want`, the value most rows have, ties broken in
    favour of `prefer`, then by the smallest value (so the same CSV always gives the same
    choice). Prints what was picked and why."""
    counts = {}
    for r in rows:
        v = r.get(col, "")
        counts[v] = counts.get(v, 0) + 1
    if not counts:
        return rows, want
    if want is not None:
        if want not in counts:
            sys.exit(f"error: {option} {want}: no such rows (values: "
                     f"{', '.join(sorted(counts, key=_natural))})")
        print(f"{what}: {want} ({option})")
        return [r for r in rows if r.get(col, "") == want], want
    top = max(counts.values())
    tied = sorted((v for v, n in counts.items() if n == top), key=_natural)
    choice = prefer if prefer in tied else tied[0]
    if len(counts) > 1:
        others = ", ".join(v for v in sorted(counts, key=_natural) if v != choice)
        why = "most rows" + (f", tie broken in favour of {prefer}" if len(tied) > 1 and choice == prefer
                             else ", tie broken by order" if len(tied) > 1 else "")
        print(f"{what}: {choice} ({why}; also in the CSV: {others}; choose with {option})")
    else:
        print(f"{what}: {choice} (the only one in the rows)")
    return [r for r in rows if r.get(col, "") == choice], choice
