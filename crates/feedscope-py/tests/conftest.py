"""Shared helpers: the CLI binary, the twin's traces made by it, and the CLI's number format.

The binary is ``$FEEDSCOPE_BIN``, by default ``target/release/feedscope`` of this repository
(``scripts/python-ci.sh`` builds it when missing).
"""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[3]
BIN = Path(os.environ.get("FEEDSCOPE_BIN", REPO / "target" / "release" / "feedscope"))

# A short synchronous torque trace in the wide layout: 1 kHz, two strokes at 1500 mm/min.
TORQUE_CONFIG = """\
seed = 7

[motion]
start_mm = 0.0

[[motion.stroke]]
to_mm = 120.0
feed_mm_min = 1500.0
dwell_s = 0.5

[[motion.stroke]]
to_mm = 0.0
feed_mm_min = 1500.0
dwell_s = 0.0

[sampling]
mode = "synchronous"
effort_kind = "torque_nm"
synchronous_rate_hz = 1000.0
"""


def run_cli(*args, check=True):
    """Run the binary; returns the CompletedProcess (text mode)."""
    if not BIN.exists():
        pytest.fail(f"feedscope binary not found at {BIN} (set FEEDSCOPE_BIN or build it)")
    p = subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(f"feedscope {' '.join(map(str, args))} failed:\n{p.stderr}")
    return p


def cli_error(*args):
    """The message and exit code of a failing CLI run: stderr's `error: ...` line."""
    p = run_cli(*args, check=False)
    assert p.returncode != 0, f"expected feedscope {args} to fail"
    # The message runs from `error: ` to the end (some span lines, e.g. TOML's caret display);
    # trailing line ends are dropped (compare with the exception's text, right-stripped too).
    at = p.stderr.find("error: ")
    assert at >= 0, p.stderr
    return p.stderr[at + len("error: "):].rstrip("\n"), p.returncode


def fixed(values, decimals):
    """The integers the CLI's fixed-decimal writer (feedscope-io `push_fixed`) prints for
    `values` with `decimals` decimals: |v·10^d| + 0.5 truncated, rounded half away from zero,
    with the same floating-point operations, so equality is equality of the printed text."""
    v = np.asarray(values, dtype=np.float64)
    a = np.abs(v * 10.0 ** decimals)
    n = np.floor(a + 0.5).astype(np.int64)
    return np.where(v < 0, -n, n)


def printed(column):
    """Printed fixed-decimal texts as the integers `fixed` gives (the decimal point dropped)."""
    return np.array([int(x.replace(".", "")) for x in column], dtype=np.int64)


def read_csv(path):
    """A CSV file (no quoting) as (header, columns as lists of strings); `#` lines skipped."""
    lines = [l for l in Path(path).read_text().splitlines() if l and not l.startswith("#")]
    header = lines[0].split(",")
    rows = [l.split(",") for l in lines[1:]]
    cols = {h: [r[k] for r in rows] for k, h in enumerate(header)}
    return header, cols


@pytest.fixture(scope="session")
def twin(tmp_path_factory):
    """The default twin (lathe Z, asynchronous 72 ms polling, current) simulated by the CLI,
    and the CLI's estimate of its trace."""
    d = tmp_path_factory.mktemp("twin")
    run_cli("simulate", "--out", d / "sim")
    run_cli("estimate", d / "sim" / "trace.csv", "--axis", d / "sim" / "axis.toml",
            "-o", d / "friction.csv", "--no-plot")
    return d


@pytest.fixture(scope="session")
def torque_twin(tmp_path_factory):
    """A synchronous torque twin in the wide layout, simulated and estimated by the CLI."""
    d = tmp_path_factory.mktemp("torque")
    (d / "sim.toml").write_text(TORQUE_CONFIG)
    run_cli("simulate", "--config", d / "sim.toml", "--layout", "wide", "--out", d / "sim")
    run_cli("estimate", d / "sim" / "trace.csv", "--axis", d / "sim" / "axis.toml",
            "-o", d / "friction.csv", "--no-plot")
    return d
