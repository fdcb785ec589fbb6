"""identify against `feedscope identify` on a twin's triangular-wave test (planned by
`feedscope plan triangle`, simulated by `feedscope simulate`)."""

import json

import numpy as np
import pytest

import feedscope
from conftest import cli_error, run_cli

SIM = """\
seed = 5

[motion]
start_mm = 120.0
program_file = "prog.nc"

[sampling]
mode = "synchronous"
effort_kind = "torque_nm"
synchronous_rate_hz = 1000.0
"""


GROUPS = """\
seed = 6

[motion]
start_mm = 120.0
""" + "".join(f"""
[[motion.stroke]]
to_mm = {to}
feed_mm_min = {feed}
dwell_s = 0.3
""" for feed in (300.0, 1000.0, 2500.0) for to in (200.0, 120.0)) + """
[sampling]
mode = "synchronous"
effort_kind = "torque_nm"
synchronous_rate_hz = 1000.0
"""


@pytest.fixture(scope="module")
def triangle(tmp_path_factory):
    d = tmp_path_factory.mktemp("triangle")
    run_cli("plan", "triangle", "--from", "120", "--to", "200", "--feed-max", "3000",
            "--levels", "6", "--cruise-s", "0.5", "--sample-rate-hz", "1000", "-o", d / "prog.nc")
    (d / "sim.toml").write_text(SIM)
    run_cli("simulate", "--config", d / "sim.toml", "--layout", "wide", "--out", d / "sim")
    (d / "groups.toml").write_text(GROUPS)
    run_cli("simulate", "--config", d / "groups.toml", "--layout", "wide", "--out", d / "groups")
    return d


def test_identify_matches_cli(triangle):
    d = triangle
    run_cli("identify", d / "sim" / "trace.csv", "--axis", d / "sim" / "axis.toml",
            "-o", d / "ident.json", "--no-plot")
    axis = feedscope.Axis.load(d / "sim" / "axis.toml", for_identification=True)
    trace = feedscope.read_trace(d / "sim" / "trace.csv", axis=axis)
    r = feedscope.identify(trace, axis)
    assert r.to_dict() == json.loads((d / "ident.json").read_text())
    # The twin's truth: the simulated friction at the force side, within what 9 s of data
    # resolve (Fc 250-300 N between the directions' levels, J of the axis file).
    truth = feedscope.simulate(d / "sim.toml").truth()
    assert r.to_dict()["axis_j_total_kgm2"] == pytest.approx(r.motor["j_total_kgm2"], rel=0.02)
    assert 240 < r.force["fc_n"] < 320
    assert r.force["fs_n"] > r.force["fc_n"]
    assert truth["seed"] == 5
    assert r.used.dtype == np.bool_ and len(r.used) == len(r.time_s) == len(r.computed_torque_nm)
    rms = np.sqrt(np.mean((r.measured_torque_nm - r.computed_torque_nm)[r.used] ** 2))
    assert rms == pytest.approx(r.diagnostics["residual_rms_nm"], rel=1e-6)
    assert "IdentifyResult(J" in repr(r)


def test_identify_options_and_compare_match_cli(triangle, twin, tmp_path):
    d = triangle
    run_cli("identify", d / "sim" / "trace.csv", "--axis", d / "sim" / "axis.toml",
            "-o", d / "ident2.json", "--no-plot", "--delta", "1.5", "--no-offset",
            "--compare", d / "groups" / "trace.csv")
    axis = feedscope.Axis.load(d / "sim" / "axis.toml")
    trace = feedscope.read_trace(d / "sim" / "trace.csv", axis=axis)
    groups = feedscope.read_trace(d / "groups" / "trace.csv", axis=axis)
    r = feedscope.identify(trace, axis, delta=1.5, fit_offset=False, compare=groups)
    assert r.to_dict() == json.loads((d / "ident2.json").read_text())
    assert r.compare["difference_percent"].keys() == {"tc", "ts", "vs", "sigma"}
    assert len(r.compare["groups"]) >= 6
    # Groups of one feed only (the stroke twin): refused as by the CLI.
    message, code = cli_error("identify", d / "sim" / "trace.csv", "--axis",
                              d / "sim" / "axis.toml", "-o", tmp_path / "x.json", "--no-plot",
                              "--compare", twin / "sim" / "trace.csv")
    one_feed = feedscope.read_trace(twin / "sim" / "trace.csv", axis=axis)
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.identify(trace, axis, compare=one_feed)
    assert str(info.value).rstrip("\n") == message and code == 2


def test_identify_error_matches_cli(twin, tmp_path):
    """The stroke test's trace has one feed only: not identifiable, as the CLI says."""
    message, code = cli_error("identify", twin / "sim" / "trace.csv", "--axis",
                              twin / "sim" / "axis.toml", "-o", tmp_path / "i.json")
    axis = feedscope.Axis.load(twin / "sim" / "axis.toml")
    trace = feedscope.read_trace(twin / "sim" / "trace.csv", axis=axis)
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.identify(trace, axis)
    assert str(info.value).rstrip("\n") == message and code == 2
