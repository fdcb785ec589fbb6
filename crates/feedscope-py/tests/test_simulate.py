"""simulate against `feedscope simulate`, and the round trip simulate → estimate → truth."""

import json

import numpy as np
import pytest

import feedscope
from conftest import TORQUE_CONFIG, fixed, printed, read_csv, run_cli


def check_trace_against_csv(trace, path, layout):
    header, cols = read_csv(path)
    if layout == "long":
        ch = np.array(cols["channel"])
        t, v = np.array(cols["time_s"]), np.array(cols["value"])
        pos, eff = ch == "position_mm", ch == trace.effort_kind
        series = [(trace.position_time_s, t[pos]), (trace.position_mm, v[pos]),
                  (trace.effort_time_s, t[eff]), (trace.effort, v[eff])]
    else:
        series = [(trace.position_time_s, cols["time_s"]), (trace.position_mm, cols["position_mm"]),
                  (trace.effort, cols[trace.effort_kind])]
    for ours, text in series:
        assert np.array_equal(fixed(ours, 6), printed(text))


def check_truth(sim, d):
    assert sim.truth() == json.loads((d / "truth.json").read_text())
    _, cols = read_csv(d / "truth.csv")
    # truth.csv is written with Rust's shortest round-trip text: float() gives the same f64.
    for name in ["time_s", "position_mm", "velocity_mm_s", "accel_mm_s2", "friction_n"]:
        assert np.array_equal(getattr(sim, "truth_" + name), [float(x) for x in cols[name]]), name
    assert sim.axis.to_dict() == feedscope.Axis.load(d / "axis.toml").to_dict()


def test_default_twin_matches_cli(twin):
    sim = feedscope.simulate()
    check_trace_against_csv(sim.trace, twin / "sim" / "trace.csv", "long")
    check_truth(sim, twin / "sim")
    assert "Simulation(axis=\"simulated lathe Z\"" in repr(sim)


def test_config_file_and_dict_match_cli(torque_twin):
    sim = feedscope.simulate(torque_twin / "sim.toml")
    check_trace_against_csv(sim.trace, torque_twin / "sim" / "trace.csv", "wide")
    check_truth(sim, torque_twin / "sim")
    # The same config as a dict (the TOML's keys).
    tomllib = pytest.importorskip("tomllib")  # Python 3.11 and later
    cfg = tomllib.loads(TORQUE_CONFIG)
    again = feedscope.simulate(cfg)
    assert np.array_equal(again.trace.torque_nm, sim.trace.torque_nm)
    assert np.array_equal(again.trace.position_mm, sim.trace.position_mm)


def test_seed_matches_cli(tmp_path):
    run_cli("simulate", "--seed", "42", "--out", tmp_path)
    sim = feedscope.simulate(seed=42)
    check_trace_against_csv(sim.trace, tmp_path / "trace.csv", "long")
    assert sim.truth()["seed"] == 42


def test_bad_config_names_the_key(tmp_path):
    from conftest import cli_error

    (tmp_path / "bad.toml").write_text("[motion]\nfeed_inch = 3\n")
    message, code = cli_error("simulate", "--config", tmp_path / "bad.toml", "--out", tmp_path / "o")
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.simulate(tmp_path / "bad.toml")
    assert str(info.value).rstrip("\n") == message and code == 2 and "feed_inch" in message
    with pytest.raises(feedscope.BadInputError, match="feed_inch"):
        feedscope.simulate({"motion": {"feed_inch": 3}})
    assert "[sampling.position]" in feedscope.default_sim_config()


def test_round_trip_recovers_the_true_friction():
    """simulate → estimate → compare with the twin's own friction, in Python.

    The twin's friction varies by 15-25 N RMS along the travel (a 250-300 N level, bumps,
    screw-order ripple); at 72 ms polling the estimate follows it to about 2.2 N RMS. A bound of
    4 N RMS and 0.5 N on the mean catches a wrong unit, sign, inertia or torque-constant term
    (each worth tens of newtons here), while leaving room for the noise of another seed."""
    sim = feedscope.simulate()
    result = feedscope.estimate(sim.trace, sim.axis)
    assert [s.direction for s in result.strokes] == ["forward", "backward"]
    for s in result.strokes:
        model = sim.true_friction_n(s.position_mm, s.velocity_mm_s)
        # Independently of the model: the true state series, interpolated in time.
        states = np.interp(s.time_s, sim.truth_time_s, sim.truth_friction_n)
        for truth in (model, states):
            rms = np.sqrt(np.mean((s.friction_n - truth) ** 2))
            assert rms < 4.0, (s.direction, rms)
            assert abs(s.mean_friction_n - truth.mean()) < 0.5
            # The estimate must follow the variation, not only the level.
            assert np.std(truth) > 3 * rms
        sign = 1 if s.direction == "forward" else -1
        assert sign * s.mean_friction_n > 200


def test_trace_write_is_the_cli_file(twin, torque_twin, tmp_path):
    """Trace.write gives the binary's trace file byte for byte (long CSV, wide CSV), and a
    Parquet file that reads back to the same trace."""
    sim = feedscope.simulate()
    sim.trace.write(tmp_path / "long.csv")
    assert (tmp_path / "long.csv").read_bytes() == (twin / "sim" / "trace.csv").read_bytes()
    tsim = feedscope.simulate(torque_twin / "sim.toml")
    tsim.trace.write(tmp_path / "wide.csv", layout="wide")
    assert (tmp_path / "wide.csv").read_bytes() == (torque_twin / "sim" / "trace.csv").read_bytes()
    sim.trace.write(tmp_path / "t.parquet")
    back = feedscope.read_trace(tmp_path / "t.parquet")
    assert np.array_equal(back.position_mm, sim.trace.position_mm)
    assert np.array_equal(back.current_a, sim.trace.current_a)
    with pytest.raises(feedscope.BadInputError, match="same time stamps"):
        sim.trace.write(tmp_path / "w.csv", layout="wide")
    with pytest.raises(ValueError, match="layout"):
        sim.trace.write(tmp_path / "w.csv", layout="tall")
