"""read_trace + estimate against `feedscope estimate` on the twin's traces: the same numbers
to the last printed digit, and the same JSON summary."""

import json

import numpy as np
import pytest

import feedscope
from conftest import fixed, printed, read_csv

# Columns of the friction CSV and their decimals (feedscope-io friction_csv::format_stroke).
DECIMALS = {
    "position_mm": 6,
    "time_s": 6,
    "velocity_mm_s": 4,
    "accel_mm_s2": 3,
    "current_a": 6,
    "torque_nm": 6,
    "friction_n": 4,
}


def python_estimate(d):
    axis = feedscope.Axis.load(d / "sim" / "axis.toml")
    trace = feedscope.read_trace(d / "sim" / "trace.csv", axis=axis)
    return feedscope.estimate(trace, axis)


def check_against_cli(d, effort):
    result = python_estimate(d)
    header, cols = read_csv(d / "friction.csv")
    assert header == ["stroke", "direction", "position_mm", "time_s", "velocity_mm_s",
                      "accel_mm_s2", effort, "friction_n"]
    assert result.effort_kind == effort
    strokes = np.array([int(s) for s in cols["stroke"]])
    assert [s.stroke for s in result.strokes] == sorted(set(strokes.tolist()))
    for s in result.strokes:
        rows = strokes == s.stroke
        assert len(s) == rows.sum() == len(s.friction_n)
        assert {cols["direction"][k] for k in np.flatnonzero(rows)} == {s.direction}
        for name, dec in DECIMALS.items():
            if name not in header:
                continue
            ours = getattr(s, name)
            assert ours is not None, name
            theirs = printed(np.array(cols[name])[rows])
            mismatch = np.flatnonzero(fixed(ours, dec) != theirs)
            assert mismatch.size == 0, (
                f"stroke {s.stroke} {name}: {mismatch.size} values differ in print, first at "
                f"{mismatch[0]}: {ours[mismatch[0]]!r} vs {np.array(cols[name])[rows][mismatch[0]]}"
            )
    # The JSON summary: every key and number the same (the source path is spelt alike).
    cli = json.loads((d / "friction.json").read_text())
    ours = result.to_dict()
    assert ours == cli
    return result


def test_estimate_current_trace_matches_cli(twin):
    r = check_against_cli(twin, "current_a")
    assert len(r.strokes) == 2
    assert [s.direction for s in r.strokes] == ["forward", "backward"]


def test_estimate_torque_wide_trace_matches_cli(torque_twin):
    r = check_against_cli(torque_twin, "torque_nm")
    assert r.strokes[0].current_a is None
    assert r.strokes[0].torque_nm is r.strokes[0].torque_nm  # the same array each time


def test_estimate_options_match_cli(twin):
    """Non-default options reach the library as the CLI's flags do."""
    from conftest import run_cli

    out = twin / "opts.csv"
    run_cli("estimate", twin / "sim" / "trace.csv", "--axis", twin / "sim" / "axis.toml",
            "-o", out, "--no-plot", "--samples-per-lead", "256", "--end-condition", "natural",
            "--position-cutoff-hz", "off", "--time-of-position", "knot-spline")
    axis = feedscope.Axis.load(twin / "sim" / "axis.toml")
    trace = feedscope.read_trace(twin / "sim" / "trace.csv", axis=axis)
    r = feedscope.estimate(trace, axis, samples_per_lead=256, end_condition="natural",
                           position_cutoff_hz="off", time_of_position="knot-spline")
    _, cols = read_csv(out)
    friction = np.concatenate([s.friction_n for s in r.strokes])
    assert np.array_equal(fixed(friction, 4), printed(cols["friction_n"]))
    cli = json.loads(out.with_suffix(".json").read_text())
    assert r.to_dict() == cli


def test_stroke_arrays_are_read_only_and_shaped(twin):
    r = python_estimate(twin)
    s = r.strokes[0]
    for name in ["position_mm", "time_s", "velocity_mm_s", "accel_mm_s2", "current_a",
                 "friction_n", "effort"]:
        a = getattr(s, name)
        assert isinstance(a, np.ndarray) and a.dtype == np.float64 and a.ndim == 1
        assert len(a) == len(s)
        assert not a.flags.writeable
    with pytest.raises(ValueError):
        s.friction_n[0] = 0.0
    # Units: positions in mm along the lathe's 410 mm travel, feed 100 mm/min ≈ 1.667 mm/s.
    assert 0 <= s.position_mm.min() and s.position_mm.max() <= 410
    assert abs(np.median(s.velocity_mm_s) - 100 / 60) < 0.01
    assert s.kind == "measuring" and s.feed_mm_min == pytest.approx(100, rel=1e-3)
    assert isinstance(s.warnings, list) and isinstance(s.noise_floor, dict)
    d = s.to_dict()
    assert d["stroke"] == 0 and d["friction_n"] is s.friction_n
    assert "Stroke(0 measuring forward" in repr(s)
    assert "EstimateResult(2 strokes" in repr(r)


def test_to_pandas(twin):
    pd = pytest.importorskip("pandas")
    r = python_estimate(twin)
    df = r.to_pandas()
    _, cols = read_csv(twin / "friction.csv")
    assert list(df.columns) == ["stroke", "direction", "position_mm", "time_s", "velocity_mm_s",
                                "accel_mm_s2", "current_a", "friction_n"]
    assert len(df) == len(cols["stroke"])
    assert np.array_equal(fixed(df["friction_n"].to_numpy(), 4), printed(cols["friction_n"]))
    assert isinstance(df, pd.DataFrame)


def test_to_pandas_without_pandas(twin, monkeypatch):
    """pandas is optional: without it, to_pandas() says what to install."""
    import sys

    r = python_estimate(twin)
    monkeypatch.setitem(sys.modules, "pandas", None)  # `import pandas` now fails
    with pytest.raises(ImportError, match="pip install pandas"):
        r.to_pandas()


def test_trace_from_arrays_gives_the_same_estimate(torque_twin):
    """A trace built from numpy arrays of a file's numbers estimates exactly as the file (the
    same mm → m conversion as the reader; Python's float() and the reader both round
    correctly)."""
    axis = feedscope.Axis.load(torque_twin / "sim" / "axis.toml")
    read = feedscope.read_trace(torque_twin / "sim" / "trace.csv", axis=axis)
    header, cols = read_csv(torque_twin / "sim" / "trace.csv")
    assert header == ["time_s", "position_mm", "torque_nm"]
    col = {k: np.array([float(x) for x in v]) for k, v in cols.items()}
    built = feedscope.Trace(time_s=col["time_s"], position_mm=col["position_mm"],
                            torque_nm=col["torque_nm"])
    assert np.array_equal(built.position_mm, read.position_mm)
    assert np.array_equal(built.torque_nm, read.torque_nm)
    a = feedscope.estimate(read, axis)
    b = feedscope.estimate(built, axis)
    assert len(a.strokes) == len(b.strokes) == 2
    for s, t in zip(a.strokes, b.strokes):
        assert np.array_equal(s.friction_n, t.friction_n)
        assert np.array_equal(s.position_mm, t.position_mm)


def test_separate_channel_clocks(twin):
    """Channels with their own time vectors (asynchronous polling, the long layout)."""
    axis = feedscope.Axis.load(twin / "sim" / "axis.toml")
    read = feedscope.read_trace(twin / "sim" / "trace.csv", axis=axis)
    header, cols = read_csv(twin / "sim" / "trace.csv")
    assert header == ["time_s", "channel", "value"]
    ch = np.array(cols["channel"])
    t = np.array([float(x) for x in cols["time_s"]])
    v = np.array([float(x) for x in cols["value"]])
    pos, cur = ch == "position_mm", ch == "current_a"
    assert not np.array_equal(t[pos], t[cur])
    built = feedscope.Trace(position_time_s=t[pos], position_mm=v[pos],
                            effort_time_s=t[cur], current_a=v[cur])
    a = feedscope.estimate(read, axis)
    b = feedscope.estimate(built, axis)
    assert len(a.strokes) == len(b.strokes) == 2
    for s, u in zip(a.strokes, b.strokes):
        assert np.array_equal(s.friction_n, u.friction_n)


def test_estimate_with_program_matches_cli(tmp_path):
    """`program=` labels the strokes with the NC program's blocks, as `--program`."""
    from conftest import run_cli

    run_cli("plan", "strokes", "--from", "10", "--to", "100", "--feeds", "500,1500",
            "--repeats", "1", "--sample-rate-hz", "500", "-o", tmp_path / "p.nc")
    (tmp_path / "sim.toml").write_text(
        '[motion]\nstart_mm = 10.0\nprogram_file = "p.nc"\n\n[sampling]\n'
        'mode = "synchronous"\neffort_kind = "torque_nm"\nsynchronous_rate_hz = 500.0\n')
    run_cli("simulate", "--config", tmp_path / "sim.toml", "--out", tmp_path / "sim")
    run_cli("estimate", tmp_path / "sim" / "trace.csv", "--axis", tmp_path / "sim" / "axis.toml",
            "-o", tmp_path / "f.csv", "--no-plot", "--program", tmp_path / "p.nc")
    axis = feedscope.Axis.load(tmp_path / "sim" / "axis.toml")
    trace = feedscope.read_trace(tmp_path / "sim" / "trace.csv", axis=axis)
    r = feedscope.estimate(trace, axis, program=tmp_path / "p.nc")
    assert r.to_dict() == json.loads((tmp_path / "f.json").read_text())
    assert all(s.summary.get("program_line") for s in r.strokes)
    with pytest.raises(feedscope.BadInputError, match="no block moves axis X"):
        feedscope.estimate(trace, axis, program=tmp_path / "p.nc", program_axis="X")
