#!/usr/bin/env python3
"""The variation between processes, A/B: run one config in alternating processes (A B A B ...),
each arm with its own environment or `--set` edits, then print per timed row the spread of its
median between the processes of each arm (docs/variation.md).

    python3 scripts/variation.py --exe target/release/trace-bench --config configs/variation.toml \
        --arm off:env:TRACE_BENCH_HUGEPAGES=0 --arm on: --n 8 --out results/variation-huge

An arm is `NAME:` (no change), `NAME:env:K=V[,K=V]` or `NAME:set:KEY=V[;KEY=V]`. `--summary`
with an existing `--out` only prints. Standard library only.
"""

import argparse
import csv
import math
import os
import statistics
import subprocess
import sys
from pathlib import Path

KEY = ("scene", "structure", "params", "traversal", "ray_kind", "threads")


def parse_arm(text):
    name, _, rest = text.partition(":")
    env, sets = {}, []
    if rest.startswith("env:"):
        for kv in rest[4:].split(","):
            k, _, v = kv.partition("=")
            env[k] = v
    elif rest.startswith("set:"):
        sets = [s for s in rest[4:].split(";") if s]
    elif rest:
        sys.exit(f"arm {text!r}: expected NAME:, NAME:env:K=V or NAME:set:KEY=V")
    return name, env, sets


def run(args, arms):
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for i in range(args.n):
        for name, env, sets in arms:
            d = out / f"{name}-{i:02d}"
            if (d / "results.csv").exists():
                continue
            cmd = [args.exe, "run", args.config, "--out", str(d), "-q"]
            for s in sets:
                cmd += ["--set", s]
            e = dict(os.environ, **env)
            print(f"{name} {i + 1}/{args.n}: {' '.join(cmd)}", file=sys.stderr)
            subprocess.run(cmd, env=e, check=True, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)


def rows(folder):
    with open(folder / "results.csv", newline="") as f:
        for r in csv.DictReader(f):
            if r.get("trace_ms_median"):
                yield tuple(r[k] for k in KEY), r


def spread(xs):
    """max/min and the standard deviation of the logs (a relative spread)."""
    logs = [math.log(x) for x in xs]
    sd = statistics.stdev(logs) if len(logs) > 1 else 0.0
    return max(xs) / min(xs), sd


def summary(args, arms):
    out = Path(args.out)
    names = [a[0] for a in arms]
    # arm -> row key -> [median per process]; arm -> row key -> [ratio to the process's first row]
    med = {n: {} for n in names}
    rel = {n: {} for n in names}
    within = {n: [] for n in names}
    for n in names:
        for d in sorted(out.glob(f"{n}-*")):
            if not (d / "results.csv").exists():
                continue
            rs = list(rows(d))
            base = {}
            for k, r in rs:
                m = float(r["trace_ms_median"])
                med[n].setdefault(k, []).append(m)
                within[n].append(float(r["trace_ms_ci"] or 0))
                # Paired: each row against the first row of its timing group (same rays).
                g = r.get("timing_group", "")
                if g not in base:
                    base[g] = (k, m)
                elif base[g][0] != k:
                    rel[n].setdefault((k, base[g][0]), []).append(m / base[g][1])
    def label(k):
        width = [p for p in k[2].split(";") if p.startswith("width=")]
        return f"{k[0]} {k[1]} {' '.join(width)} {k[3]} {k[4]}"
    print(f"{'row':70} " + " ".join(f"{n + ' max/min':>14} {n + ' sd%':>9}" for n in names))
    agg = {n: ([], []) for n in names}
    for k in med[names[0]]:
        cells = []
        for n in names:
            xs = med[n].get(k, [])
            if len(xs) < 2:
                cells.append(f"{'-':>14} {'-':>9}")
                continue
            mm, sd = spread(xs)
            agg[n][0].append(math.log(mm))
            agg[n][1].append(sd)
            cells.append(f"{mm:14.3f} {100 * sd:9.1f}")
        print(f"{label(k)[:70]:70} " + " ".join(cells))
    print()
    for n in names:
        lm, sd = agg[n]
        procs = len(list(out.glob(f"{n}-*")))
        print(f"{n}: {procs} processes; rows' median max/min, geometric mean {math.exp(statistics.mean(lm)):.3f}, "
              f"worst {math.exp(max(lm)):.3f}; sd of log median, mean {100 * statistics.mean(sd):.1f} %; "
              f"within-run 95 % CI half-width, median {100 * statistics.median(within[n]):.1f} %")
    print()
    for n in names:
        rs = [spread(xs) for xs in rel[n].values() if len(xs) > 1]
        if rs:
            print(f"{n}: paired ratios (row / first row of its timing group), {len(rs)}: max/min geometric mean "
                  f"{math.exp(statistics.mean(math.log(r[0]) for r in rs)):.3f}, worst {max(r[0] for r in rs):.3f}; "
                  f"sd of log, mean {100 * statistics.mean(r[1] for r in rs):.1f} %")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--exe", default="target/release/trace-bench")
    p.add_argument("--config", default="configs/variation.toml")
    p.add_argument("--arm", action="append", required=True)
    p.add_argument("--n", type=int, default=6, help="processes per arm")
    p.add_argument("--out", required=True)
    p.add_argument("--summary", action="store_true", help="only print the summary")
    args = p.parse_args()
    arms = [parse_arm(a) for a in args.arm]
    if not args.summary:
        run(args, arms)
    summary(args, arms)


if __name__ == "__main__":
    main()
