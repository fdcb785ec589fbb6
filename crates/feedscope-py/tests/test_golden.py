"""The golden reports from Python: every use case the binding offers, run on the fixed inputs of
``crates/feedscope-app/tests/golden/inputs/`` and compared with the very JSON files the Rust
test ``crates/feedscope-app/tests/golden.rs`` pins (``../<case>.json``).

``to_dict()`` is the serde form of the application layer's report, so it must be the golden
file: same keys, same array lengths, same strings, numbers within the Rust test's tolerance.
Both sides normalise alike: the inputs folder, the import fixtures folder and the run's scratch
folder, each followed by a path separator, are cut out of every string, and every ``added_utc``
(the wall-clock time a test was stored) becomes ``"<wall clock>"``. To change a golden file,
bless it from Rust (``FEEDSCOPE_BLESS=1 cargo test -p feedscope-app --test golden``); this
suite never writes one.

Not bound in Python, so compared only by the Rust test: ``import`` (docs/python.md, "Not bound
yet").
"""

import json
import math
import os

import pytest

import feedscope
from conftest import REPO

GOLDEN = REPO / "crates" / "feedscope-app" / "tests" / "golden"
INPUTS = GOLDEN / "inputs"
# Spelt as golden.rs spells it (from the app crate's folder), so that the same text is cut.
IMPORT_FIXTURES = (REPO / "crates" / "feedscope-app" / ".." / "feedscope-cli" / "tests" / "data"
                   / "import")

# The cases only the Rust test runs (the binding has no such function).
RUST_ONLY = {"import"}

# The history's tests, as golden.rs's HISTORY: trace, kind, time, reference.
HISTORY = [
    ("strokes.csv", "strokes", "2026-11-02T08:00:00Z", True),
    ("strokes_2.csv", "strokes", "2026-11-09T08:00:00Z", False),
    ("triangle.csv", "triangle", "2026-11-09T09:00:00Z", False),
    ("strokes_worn.csv", "strokes", "2026-11-16T08:00:00Z", False),
]


def close(a, b):
    """golden.rs's `close`: a relative 1e-9 plus an absolute 1e-12 (the reason is there)."""
    return abs(a - b) <= 1e-12 + 1e-9 * max(abs(a), abs(b))


def normalised(value, roots):
    """golden.rs's `normalised`: the roots cut out of every string, `added_utc` made
    "<wall clock>"."""
    if isinstance(value, str):
        for root in roots:
            value = value.replace(f"{root}{os.sep}", "")
        return value
    if isinstance(value, list):
        return [normalised(v, roots) for v in value]
    if isinstance(value, dict):
        return {k: "<wall clock>" if k == "added_utc" else normalised(v, roots)
                for k, v in value.items()}
    return value


def is_number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def first_difference(got, want, path="$"):
    """golden.rs's `first_difference`: where `got` first differs from `want`, or None."""
    if is_number(got) and is_number(want):
        if math.isfinite(got) and close(got, want):
            return None
        return f"{path}: {got!r} here, {want!r} in the golden file"
    if isinstance(got, list) and isinstance(want, list):
        if len(got) != len(want):
            return f"{path}: {len(got)} elements here, {len(want)} in the golden file"
        for k, (g, w) in enumerate(zip(got, want)):
            d = first_difference(g, w, f"{path}[{k}]")
            if d:
                return d
        return None
    if isinstance(got, dict) and isinstance(want, dict):
        for k in sorted(want):
            if k not in got:
                return f"{path}.{k}: missing here"
        for k in sorted(got):
            if k not in want:
                return f"{path}.{k}: not in the golden file"
        for k in sorted(want):
            d = first_difference(got[k], want[k], f"{path}.{k}")
            if d:
                return d
        return None
    if type(got) is type(want) and got == want:
        return None
    return f"{path}: {got!r} here, {want!r} in the golden file"


def check(case, report, scratch=None):
    roots = [INPUTS, IMPORT_FIXTURES] + ([scratch] if scratch else [])
    got = normalised(report, roots)
    path = GOLDEN / f"{case}.json"
    want = json.loads(path.read_text())
    d = first_difference(got, want)
    assert d is None, (
        f"the {case} report from Python differs from {path}: {d} (the binding re-types the "
        "layout, or the golden file is stale: `FEEDSCOPE_BLESS=1 cargo test -p feedscope-app "
        "--test golden` rewrites it from Rust)")


def test_the_comparison_is_golden_rs_s():
    want = {"a": [1.0, {"b": 2.5}], "c": "x", "n": None, "t": True}
    assert first_difference(json.loads(json.dumps(want)), want) is None
    assert first_difference({**want, "a": [1.0, {"b": 2.5 * (1 + 1e-12)}]}, want) is None
    d = first_difference({**want, "a": [1.0, {"b": 2.5 * (1 + 1e-8)}]}, want)
    assert d.startswith("$.a[1].b: "), d
    assert first_difference({**want, "t": 1}, want).startswith("$.t: ")
    assert first_difference({**want, "n": 0}, want).startswith("$.n: ")
    n = normalised({"source": f"/scratch{os.sep}t.csv: cut", "added_utc": "2026"}, ["/scratch"])
    assert n == {"source": "t.csv: cut", "added_utc": "<wall clock>"}


def test_every_golden_case_is_compared_here():
    """A golden case added in Rust is run here too, or named as not bound."""
    cases = {p.stem for p in GOLDEN.glob("*.json")}
    here = {"estimate", "analyze", "map", "map_stribeck", "fit_stribeck", "identify",
            "identify_compare", "history_add", "history_trend"}
    assert cases == here | RUST_ONLY


@pytest.fixture(scope="module")
def strokes():
    axis = feedscope.Axis.load(INPUTS / "axis.toml")
    return feedscope.read_trace(INPUTS / "strokes.csv", axis=axis), axis


def test_estimate(strokes):
    trace, axis = strokes
    check("estimate", feedscope.estimate(trace, axis).to_dict())


def test_analyze(strokes):
    trace, axis = strokes
    check("analyze", feedscope.analyze(trace, axis).to_dict())


def test_map():
    axis = feedscope.Axis.load(INPUTS / "map" / "axis.toml")
    r = feedscope.map(INPUTS / "map" / "index.csv", axis)
    check("map", r.to_dict())
    check("map_stribeck", r.stribeck())


def test_fit_stribeck():
    axis = feedscope.Axis.load(INPUTS / "axis.toml")
    r = feedscope.fit_stribeck(INPUTS / "stribeck.csv", axis=axis, noise_n=2.0)
    check("fit_stribeck", r.to_dict())


@pytest.fixture(scope="module")
def triangle():
    axis = feedscope.Axis.load(INPUTS / "axis.toml", for_identification=True)
    return feedscope.read_trace(INPUTS / "triangle.csv", axis=axis), axis


def test_identify(triangle):
    trace, axis = triangle
    check("identify", feedscope.identify(trace, axis).to_dict())


def test_identify_with_compare(triangle):
    trace, axis = triangle
    groups = feedscope.read_trace(INPUTS / "groups.csv", axis=axis)
    check("identify_compare", feedscope.identify(trace, axis, compare=groups).to_dict())


def test_history_add_and_trend(tmp_path):
    h = feedscope.History(tmp_path / "history.db")
    added = [
        h.add(INPUTS / trace, INPUTS / "axis.toml", kind, time=time, machine="lathe",
              reference=reference).to_dict()
        for trace, kind, time, reference in HISTORY
    ]
    check("history_add", added, tmp_path)
    trend = h.trend(machine="lathe", baseline_tests=2, profile_baseline_tests=2)
    check("history_trend", trend.to_dict(), tmp_path)
