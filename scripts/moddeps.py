#!/usr/bin/env python3
"""List the module-level dependencies of a crate's top-level modules and report cycles.

Usage: scripts/moddeps.py [crates/feedscope/src] [--tests]

A dependency is a path `crate::<module>` (also inside `use crate::{a, b}` groups) in code;
comment lines (`//`, `//!`, `///`, so doc links too) are skipped. Code under `#[cfg(test)]`
and files named `tests.rs` or under `tests/` count only with `--tests`.
"""
import os
import re
import sys
from collections import defaultdict

args = [a for a in sys.argv[1:] if not a.startswith("--")]
with_tests = "--tests" in sys.argv
root = args[0] if args else "crates/feedscope/src"

mods = set()
for name in os.listdir(root):
    if name.endswith(".rs") and name not in ("lib.rs", "main.rs"):
        mods.add(name[:-3])
    elif os.path.isdir(os.path.join(root, name)):
        mods.add(name)

deps = defaultdict(lambda: defaultdict(int))
for dirpath, _, files in os.walk(root):
    for f in files:
        if not f.endswith(".rs"):
            continue
        path = os.path.join(dirpath, f)
        rel = os.path.relpath(path, root)
        top = rel.split(os.sep)[0]
        top = top[:-3] if top.endswith(".rs") else top
        if top not in mods:
            continue
        is_test_file = f == "tests.rs" or f"{os.sep}tests{os.sep}" in rel
        if is_test_file and not with_tests:
            continue
        # Keep the code lines; drop comments and, unless --tests, the item that follows a
        # `#[cfg(test)]` (a one-line `mod tests;` or a braced block, tracked by brace depth).
        code = []
        pending, depth = False, 0
        for line in open(path, encoding="utf-8").read().splitlines():
            s = line.strip()
            if s.startswith("//"):
                continue
            if depth > 0:
                depth += s.count("{") - s.count("}")
                continue
            if s.startswith("#[cfg(test)]") and not with_tests:
                pending = True
                continue
            if pending and not s.startswith("#["):
                pending = False
                depth = s.count("{") - s.count("}")
                continue
            code.append(s)
        text = "\n".join(code)
        for m in re.finditer(r"crate::(\w+)", text):
            if m.group(1) in mods and m.group(1) != top:
                deps[top][m.group(1)] += 1
        # `use crate::{a, b::C}` groups, possibly over several lines
        for m in re.finditer(r"crate::\{([^}]*)\}", text):
            for part in m.group(1).split(","):
                name = part.strip().split("::")[0]
                if name in mods and name != top:
                    deps[top][name] += 1

for m in sorted(mods):
    ds = sorted(deps[m])
    print(f"{m:10} -> {', '.join(ds) if ds else '(none)'}")

# strongly connected components (Tarjan)
index, low, stack, on, sccs, counter = {}, {}, [], set(), [], [0]
def visit(v):
    index[v] = low[v] = counter[0]; counter[0] += 1
    stack.append(v); on.add(v)
    for w in deps[v]:
        if w not in index:
            visit(w); low[v] = min(low[v], low[w])
        elif w in on:
            low[v] = min(low[v], index[w])
    if low[v] == index[v]:
        comp = []
        while True:
            w = stack.pop(); on.discard(w); comp.append(w)
            if w == v:
                break
        sccs.append(comp)
for m in sorted(mods):
    if m not in index:
        visit(m)
cycles = [sorted(c) for c in sccs if len(c) > 1]
print()
if cycles:
    for c in cycles:
        print("cycle:", " <-> ".join(c))
    sys.exit(1)
print("no cycles")
