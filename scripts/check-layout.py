#!/usr/bin/env python3
"""The layout rules of ARCHITECTURE.md, checked on the sources (CI runs this):

1. No import circle between the files (modules) of any crate: `use crate::a::b` and
   `crate::a::b::x` paths and `super::x` make edges; a module's own children and parent are
   not edges (Rust's `mod` tree), comments and `#[cfg(test)] mod tests` are skipped.
2. The harness and the CLI reach a structure only through the registry: no file of
   crates/harness/src or crates/cli/src but crates/harness/src/registry.rs names a structure
   crate (tb_bvh, tb_kdtree, tb_multikd, tb_sparse, tb_rtree, tb_grid, tb_peers).
3. No function in the harness or the CLI over 100 lines, but those listed in LONG with their
   present length, which they may not exceed (split them and remove the line).

Exit 1 with one line per violation. `--list` prints every module's edges.
"""

import os
import re
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
STRUCTURE_CRATES = ("tb_bvh", "tb_kdtree", "tb_multikd", "tb_sparse", "tb_rtree", "tb_grid", "tb_peers")
MAX_FN_LINES = 100
# Functions over MAX_FN_LINES when this check was written (2026-11-27), and their lengths:
# a ceiling, not a licence.
LONG = {}


def code_of(text):
    """The text without `#[cfg(test)] mod tests` and without comment lines."""
    text = re.split(r"#\[cfg\(test\)\]\s*mod tests", text)[0]
    return "\n".join(l for l in text.split("\n") if not l.strip().startswith("//"))


def modules(src):
    """Module path (`a::b`, `` for the crate root) -> code, for the .rs files under src."""
    out = {}
    for dp, _, files in os.walk(src):
        for f in files:
            if f.endswith(".rs"):
                p = os.path.join(dp, f)
                rel = os.path.relpath(p, src)[:-3].replace(os.sep, "/")
                if rel in ("lib", "main"):
                    mod = ""
                else:
                    mod = re.sub(r"/mod$", "", rel).replace("/", "::")
                with open(p, encoding="utf-8") as fh:
                    out[mod] = code_of(fh.read())
    return out


def paths_in(code):
    """The `crate::…` paths of the code, groups `{a, b::c}` expanded, `as` renames dropped."""
    out = []
    for m in re.finditer(r"\bcrate::((?:[A-Za-z_][A-Za-z0-9_]*::)*)(\{[^}]*\}|[A-Za-z_][A-Za-z0-9_]*)", code):
        base, tail = m.group(1).rstrip(":"), m.group(2)
        if tail.startswith("{"):
            for part in tail[1:-1].split(","):
                part = re.sub(r"\s+as\s+\w+", "", part).strip()
                if part and part != "self":
                    out.append(f"{base}::{part}" if base else part)
            if "self" in tail and base:
                out.append(base)
        else:
            out.append(f"{base}::{tail}" if base else tail)
    return out


def edges(mods):
    names = set(mods)

    def resolve(path):
        parts = path.split("::")
        for i in range(len(parts), 0, -1):
            m = "::".join(parts[:i])
            if m in names:
                return m
        return None

    g = {m: set() for m in mods}
    for m, code in mods.items():
        targets = [resolve(p) for p in paths_in(code)]
        parent = "::".join(m.split("::")[:-1])
        for s in re.finditer(r"\bsuper::([A-Za-z_][A-Za-z0-9_]*)", code):
            targets.append(resolve(f"{parent}::{s.group(1)}" if parent else s.group(1)))
        for t in targets:
            if t and t != m and not m.startswith(t + "::") and not t.startswith(m + "::") and t != "":
                g[m].add(t)
    return g


def cycles(g):
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(g[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def functions(path):
    """(name, first line, lines) of every fn outside `#[cfg(test)]` in the file."""
    with open(path, encoding="utf-8") as fh:
        lines = fh.read().split("\n")
    out, i = [], 0
    while i < len(lines):
        if re.match(r"\s*#\[cfg\(test\)\]", lines[i]):
            break
        m = re.match(r"\s*(?:pub(?:\([a-z]+\))?\s+)?(?:const\s+)?(?:unsafe\s+)?fn\s+(\w+)", lines[i])
        if not m:
            i += 1
            continue
        depth, started, j = 0, False, i
        while j < len(lines):
            code = re.sub(r'"(?:\\.|[^"\\])*"', '""', lines[j].split("//")[0])
            for ch in code:
                if ch == "{":
                    depth += 1
                    started = True
                elif ch == "}":
                    depth -= 1
            if started and depth == 0:
                break
            if not started and code.rstrip().endswith(";"):
                break
            j += 1
        if started:
            out.append((m.group(1), i + 1, j - i + 1))
        i = j + 1
    return out


def main():
    problems = []
    crates = os.path.join(ROOT, "crates")
    for c in sorted(os.listdir(crates)):
        src = os.path.join(crates, c, "src")
        if not os.path.isdir(src):
            continue
        g = edges(modules(src))
        if "--list" in sys.argv:
            for m in sorted(g):
                print(f"{c}: {m or '(root)'} -> {', '.join(sorted(g[m]))}")
        for comp in cycles(g):
            problems.append(f"crates/{c}: import circle between {', '.join(comp)}")
    for d in ("crates/harness/src", "crates/cli/src"):
        for dp, _, files in os.walk(os.path.join(ROOT, d)):
            for f in sorted(files):
                if not f.endswith(".rs"):
                    continue
                p = os.path.join(dp, f)
                rel = os.path.relpath(p, ROOT).replace(os.sep, "/")
                with open(p, encoding="utf-8") as fh:
                    code = code_of(fh.read())
                if rel != "crates/harness/src/registry.rs":
                    for name in STRUCTURE_CRATES:
                        if re.search(rf"\b{name}::", code):
                            problems.append(f"{rel}: names {name} (reach structures through the registry)")
                for name, line, n in functions(p):
                    limit = LONG.get((rel, name), MAX_FN_LINES)
                    if n > limit:
                        problems.append(f"{rel}:{line}: fn {name} is {n} lines (at most {limit})")
    for p in problems:
        print(p)
    if problems:
        sys.exit(1)
    print(f"layout: no import circle, structures only through the registry, functions within {MAX_FN_LINES} lines ({len(LONG)} listed longer)")


if __name__ == "__main__":
    main()
