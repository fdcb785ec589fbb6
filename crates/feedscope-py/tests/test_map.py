"""map against `feedscope map` on a small test set of the twin: map.json and stribeck.json,
with failed runs listed by name."""

import json

import pytest

import feedscope
from conftest import cli_error, run_cli

FEEDS = [15.0, 45.0, 135.0, 400.0]


@pytest.fixture(scope="module")
def test_set(tmp_path_factory):
    """4 feeds × 2 repeats of 25 → 45 mm and back (as the CLI's own map tests), a missing and
    a malformed run, the index and the axis file."""
    d = tmp_path_factory.mktemp("map")
    (d / "runs").mkdir()
    index = "# test set\nfile,feed_mm_min,repeat,operator\n"
    for i, f in enumerate(FEEDS):
        for r in (1, 2):
            sim = feedscope.simulate({
                "seed": 100 + 10 * i + r,
                "dynamics": {"mode": "ideal"},
                "motion": {"start_mm": 25.0, "stroke": [
                    {"to_mm": 45.0, "feed_mm_min": f, "dwell_s": 0.5},
                    {"to_mm": 25.0, "feed_mm_min": f, "dwell_s": 0.0}]},
                "sampling": {"position": {"interval_ms": 20.0, "jitter_ms": 0.5},
                             "effort": {"interval_ms": 20.0, "jitter_ms": 0.5,
                                        "start_offset_ms": 10.0}},
                "truth": {"interval_ms": 1000.0},
            })
            name = f"runs/f{f}_r{r}.csv"
            sim.trace.write(d / name)
            index += f"{name},{f},{r},sim\n"
    (d / "runs" / "bad.csv").write_text("time_s,channel,value\n0.0,position_mm,x\n")
    index += "runs/missing.csv,45,3,sim\nruns/bad.csv,135,3,sim\n"
    (d / "index.csv").write_text(index)
    (d / "axis.toml").write_text(sim.axis.to_toml())
    return d


def test_map_matches_cli(test_set):
    d = test_set
    run_cli("map", d / "index.csv", "--axis", d / "axis.toml", "--out", d / "m")
    axis = feedscope.Axis.load(d / "axis.toml")
    r = feedscope.map(d / "index.csv", axis)
    assert r.to_dict() == json.loads((d / "m" / "map.json").read_text())
    assert r.stribeck() == json.loads((d / "m" / "stribeck.json").read_text())
    assert sorted(f["file"] for f in r.failed) == ["runs/bad.csv", "runs/missing.csv"]
    assert r.summary["runs_ok"] == 8
    assert "MapResult(8 of 10 runs mapped" in repr(r)


def test_map_options_match_cli(test_set, tmp_path):
    d = test_set
    run_cli("map", d / "index.csv", "--axis", d / "axis.toml", "--out", tmp_path / "m",
            "--positions", "30,40", "--feed-order", "1", "--feed-scale", "linear",
            "--position-step-mm", "2")
    axis = feedscope.Axis.load(d / "axis.toml")
    r = feedscope.map(d / "index.csv", axis, positions_mm=[30, 40], feed_order=1,
                      feed_scale="linear", position_step_mm=2)
    assert r.to_dict() == json.loads((tmp_path / "m" / "map.json").read_text())
    assert r.stribeck() == json.loads((tmp_path / "m" / "stribeck.json").read_text())


def test_map_errors(test_set, tmp_path):
    d = test_set
    axis = feedscope.Axis.load(d / "axis.toml")
    # A position outside the mapped span: refused as by the CLI (its message names the flag,
    # Python's the keyword; the library's part is the same).
    message, code = cli_error("map", d / "index.csv", "--axis", d / "axis.toml", "--out",
                              tmp_path / "m", "--positions", "5")
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.map(d / "index.csv", axis, positions_mm=[5.0])
    assert code == 2
    assert str(info.value).split(": ", 1)[1] == message.split(": ", 1)[1]
    (tmp_path / "bad_index.csv").write_text("file,feed_mm_min,repeat\nruns/a.csv,fast,1\n")
    message, code = cli_error("map", tmp_path / "bad_index.csv", "--axis", d / "axis.toml",
                              "--out", tmp_path / "m")
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.map(tmp_path / "bad_index.csv", axis)
    assert str(info.value).rstrip("\n") == message and code == 2
    with pytest.raises(ValueError, match="feed_scale"):
        feedscope.map(d / "index.csv", axis, feed_scale="cubic")
