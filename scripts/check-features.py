#!/usr/bin/env python3
"""Check that every workspace member, built alone, uses the features of the whole workspace.

Cargo unifies dependency features over the packages one command selects; the workspace-hack
crate (crates/feedscope-hack, made by cargo-hakari) gives every third-party crate the union of
its features, so that `cargo test -p X`, `cargo run -p feedscope-fuzz` and maturin's build of
feedscope-py reuse the build of `cargo test --workspace` instead of building serde, tokio and all
above them again. This script compares `cargo tree` feature sets (no build, a second or two per
member) and fails, naming the crates, when a dependency change left the hack stale; the fix is
`cargo hakari generate` (cargo install cargo-hakari).

PyO3 is left out on purpose (.config/hakari.toml): its `extension-module` feature, which only
maturin sets, must not reach the workspace's test binaries.
"""
import json
import subprocess
import sys

EXEMPT = {"pyo3", "pyo3-ffi", "pyo3-build-config", "pyo3-macros", "pyo3-macros-backend"}


def cargo(*args):
    run = subprocess.run(["cargo", *args], capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"check-features: `cargo {' '.join(args)}` failed:\n{run.stderr}")
    return run.stdout


def features(*selection):
    out = cargo("tree", "--locked", "-e", "normal,build,dev", "--prefix", "none",
                "-f", "{p}|{f}", *selection)
    seen = {}
    for line in out.splitlines():
        line = line.replace(" (*)", "").replace(" (proc-macro)", "").strip()
        if "|" not in line:
            continue
        pkg, feats = line.split("|", 1)
        seen.setdefault(pkg, set()).add(feats)
    return seen


def main():
    meta = json.loads(cargo("metadata", "--locked", "--no-deps", "--format-version", "1"))
    members = [p["name"] for p in meta["packages"]]
    workspace = features("--workspace")
    stale = []
    for m in members:
        for pkg, feats in features("-p", m).items():
            if pkg.split(" ")[0] in EXEMPT or pkg.split(" ")[0] in members:
                continue
            if not feats <= workspace.get(pkg, set()):
                stale.append(f"{m}: {pkg} [{' '.join(sorted(feats))}]")
    if stale:
        print("these crates get other features when one member is built alone than in the "
              "workspace build; run `cargo hakari generate` (cargo install cargo-hakari):",
              file=sys.stderr)
        for s in stale:
            print("  " + s, file=sys.stderr)
        return 1
    print(f"features unified: {len(members)} members, {len(workspace)} packages")
    return 0


if __name__ == "__main__":
    sys.exit(main())
