#!/usr/bin/env python3
"""`estimate` on the 10 M-samples-per-channel trace from Python against the binary.

The trace is the one of scripts/bench-e2e.sh (target/bench-data/trace_10m.csv, ≈ 640 MB, long
layout, made by `cargo bench -p feedscope-io --bench read_csv` when missing). Each run is a fresh
process, timed from outside (wall clock, and peak RSS from /usr/bin/time when present), with the
file read once before it so that it comes from the page cache (as bench-e2e.sh does):

- binary: `feedscope estimate TRACE --axis AXIS -o OUT.csv --no-plot --format json`, which reads,
  estimates and writes the friction CSV (≈ 10 M rows) and the JSON summary;
- Python: `feedscope.read_trace(TRACE, axis=axis)` then `feedscope.estimate(trace, axis)` in the
  interpreter running this script (feedscope must be installed there), which reads and
  estimates and keeps the result in memory as numpy arrays, writing nothing. The import of
  feedscope and numpy is inside the timed process; the script also prints the read and estimate
  times measured inside it.

Usage: python3 scripts/bench-python.py [--runs N]   (FEEDSCOPE_BIN overrides the binary)
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "target" / "bench-data" / "trace_10m.csv"
AXIS = ROOT / "target" / "bench-data" / "axis.toml"
BIN = Path(os.environ.get("FEEDSCOPE_BIN", ROOT / "target" / "release" / "feedscope"))

PY_RUN = """
import sys, time
t0 = time.perf_counter()
import feedscope
axis = feedscope.Axis.load(sys.argv[2])
t1 = time.perf_counter()
trace = feedscope.read_trace(sys.argv[1], axis=axis)
t2 = time.perf_counter()
result = feedscope.estimate(trace, axis)
t3 = time.perf_counter()
points = sum(len(s) for s in result.strokes)
print(f"{t1 - t0:.3f} {t2 - t1:.3f} {t3 - t2:.3f} {len(result.strokes)} {points}")
"""


def warm(path):
    """Read the file once so that the run reads it from the page cache."""
    with open(path, "rb") as f:
        while f.read(1 << 24):
            pass


def timed(cmd):
    """Wall time (s), peak RSS (MiB or None) and stdout of a command."""
    gnu_time = shutil.which("time") or ("/usr/bin/time" if Path("/usr/bin/time").exists() else None)
    with tempfile.NamedTemporaryFile("r") as tf:
        full = [gnu_time, "-f", "%M", "-o", tf.name, *cmd] if gnu_time else cmd
        t = time.perf_counter()
        p = subprocess.run(full, capture_output=True, text=True)
        wall = time.perf_counter() - t
        if p.returncode != 0:
            sys.exit(f"{' '.join(map(str, cmd))} failed:\n{p.stderr}")
        rss = None
        if gnu_time:
            try:
                rss = int(tf.read().strip().splitlines()[-1]) / 1024
            except (ValueError, IndexError):
                rss = None
    return wall, rss, p.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="runs of each (default 3)")
    args = ap.parse_args()
    if not DATA.exists():
        print("making the 10 M-sample trace (cargo bench -p feedscope-io --bench read_csv)")
        subprocess.run(["cargo", "bench", "-p", "feedscope-io", "--bench", "read_csv", "--",
                        "--warm-up-time", "1", "--measurement-time", "1"], cwd=ROOT, check=True,
                       stdout=subprocess.DEVNULL)
    if not BIN.exists():
        subprocess.run(["cargo", "build", "--release", "-q", "-p", "feedscope-cli"], cwd=ROOT,
                       check=True)
    rows = sum(1 for _ in open(DATA, "rb")) - 1
    print(f"trace: {DATA} ({DATA.stat().st_size / 1e6:.0f} MB, {rows} rows: both channels)")
    out = Path(tempfile.mkdtemp())
    best = {}
    try:
        for run in range(args.runs):
            warm(DATA)
            wall, rss, _ = timed([str(BIN), "estimate", str(DATA), "--axis", str(AXIS),
                                  "-o", str(out / "friction.csv"), "--no-plot", "--format", "json"])
            best["binary"] = min(best.get("binary", wall), wall)
            print(f"run {run} binary: {wall:.2f} s wall, peak RSS {rss and round(rss)} MiB")
            (out / "friction.csv").unlink(missing_ok=True)
            warm(DATA)
            wall, rss, stdout = timed([sys.executable, "-c", PY_RUN, str(DATA), str(AXIS)])
            imp, read, est, strokes, points = stdout.split()
            best["python"] = min(best.get("python", wall), wall)
            print(f"run {run} python: {wall:.2f} s wall (import {imp} s, read_trace {read} s, "
                  f"estimate {est} s; {strokes} strokes, {points} points), peak RSS "
                  f"{rss and round(rss)} MiB")
    finally:
        shutil.rmtree(out, ignore_errors=True)
    ratio = best["python"] / best["binary"]
    print(f"best of {args.runs}: binary {best['binary']:.2f} s, python {best['python']:.2f} s, "
          f"python/binary = {ratio:.3f}")


if __name__ == "__main__":
    main()
