"""analyze against `feedscope analyze` on the twin's trace: analysis.json, the analysed
friction CSV (IAFV, FFS) and components.csv, to the last printed digit."""

import json

import numpy as np
import pytest

import feedscope
from conftest import cli_error, fixed, printed, read_csv, run_cli


@pytest.fixture(scope="module")
def analyzed(twin):
    out = twin / "analysis"
    run_cli("analyze", twin / "sim" / "trace.csv", "--axis", twin / "sim" / "axis.toml",
            "--out", out)
    axis = feedscope.Axis.load(twin / "sim" / "axis.toml")
    trace = feedscope.read_trace(twin / "sim" / "trace.csv", axis=axis)
    return out, feedscope.analyze(trace, axis)


def test_analysis_json_matches_cli(analyzed):
    out, result = analyzed
    assert result.to_dict() == json.loads((out / "analysis.json").read_text())
    assert len(result) == 2


def test_iafv_and_ffs_match_cli(analyzed):
    out, result = analyzed
    header, cols = read_csv(out / "friction.csv")
    assert header == ["stroke", "direction", "position_mm", "friction_n", "iafv_n", "ffs_n"]
    iafv = np.concatenate([p.iafv_n for p in result.strokes])
    ffs = np.concatenate([p.ffs_n for p in result.strokes])
    friction = np.concatenate([p.stroke.friction_n for p in result.strokes])
    assert np.array_equal(fixed(iafv, 4), printed(cols["iafv_n"]))
    assert np.array_equal(fixed(ffs, 4), printed(cols["ffs_n"]))
    assert np.array_equal(fixed(friction, 4), printed(cols["friction_n"]))
    # FFS = friction − IAFV, on the same grid.
    for p in result.strokes:
        assert np.allclose(p.ffs_n, p.stroke.friction_n - p.iafv_n, rtol=0, atol=1e-9)


def test_components_match_cli(analyzed):
    out, result = analyzed
    _, cols = read_csv(out / "components.csv")
    ours = []
    for p in result.strokes:
        spectra = {s["segment"]: s for s in p.fluctuation["spectra"]}
        for c in p.components:
            sp = spectra[c["segment"]]
            ours.append(f"{p.stroke.stroke},{p.stroke.direction},{c['segment']},"
                        f"{sp['start_mm']:.3f},{sp['end_mm']:.3f},{c['order']:.4f},"
                        f"{c['amplitude_n']:.4f},{c['floor_n']:.4f},{c['cause']},"
                        f"{str(c['trusted']).lower()}")
    text = (out / "components.csv").read_text().splitlines()[1:]
    assert ours == text
    assert len(ours) > 0
    # The twin's order-1 shaft ripple is found in the backward stroke (18 N there).
    back = [c for c in result.strokes[1].components if abs(c["order"] - 1.0) < 0.05]
    assert back


def test_analyze_options_and_errors(twin, tmp_path):
    axis = feedscope.Axis.load(twin / "sim" / "axis.toml")
    trace = feedscope.read_trace(twin / "sim" / "trace.csv", axis=axis)
    out = tmp_path / "a"
    run_cli("analyze", twin / "sim" / "trace.csv", "--axis", twin / "sim" / "axis.toml",
            "--out", out, "--breaks", "150", "--orders", "3,4", "--segments", "4")
    r = feedscope.analyze(trace, axis, breaks_mm=[150.0], orders=[3, 4], segments=4)
    assert r.to_dict() == json.loads((out / "analysis.json").read_text())
    with pytest.raises(feedscope.BadInputError, match="one order per interval"):
        feedscope.analyze(trace, axis, breaks_mm=[150.0], orders=[3])
    with pytest.raises(feedscope.BadInputError, match="segments must be at least 1"):
        feedscope.analyze(trace, axis, segments=0)
    # A breakpoint outside the strokes fails as in the CLI, with its message.
    message, code = cli_error("analyze", twin / "sim" / "trace.csv", "--axis",
                              twin / "sim" / "axis.toml", "--out", tmp_path / "b",
                              "--breaks", "900", "--orders", "3,4")
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.analyze(trace, axis, breaks_mm=[900.0], orders=[3, 4])
    assert str(info.value).rstrip("\n") == message and code == 2
