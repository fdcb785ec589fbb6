"""dynamics against `feedscope dynamics` on examples/drive.toml."""

import json

import numpy as np
import pytest

import feedscope
from conftest import REPO, cli_error, read_csv, run_cli

DRIVE = REPO / "examples" / "drive.toml"


def test_dynamics_matches_cli(tmp_path):
    run_cli("dynamics", "--config", DRIVE, "--out", tmp_path)
    r = feedscope.dynamics(DRIVE)
    assert r.to_dict() == json.loads((tmp_path / "dynamics.json").read_text())
    # frequency_vs_feed.csv is written with Rust's shortest round-trip text: float() is exact.
    _, cols = read_csv(tmp_path / "frequency_vs_feed.csv")
    modes = max(int(m) for m in cols["mode"])
    f = np.array([float(x) for x in cols["frequency_hz"]]).reshape(-1, modes)
    feeds = np.array([float(x) for x in cols["feed_mm_min"]])[::modes]
    assert np.array_equal(r.frequency_vs_feed_hz, f)
    assert np.array_equal(r.feed_mm_min, feeds)
    assert r.peak_first_hz == pytest.approx(f[:, 0].max())
    assert "DynamicsResult(" in repr(r)


def test_dynamics_from_dict_and_errors(tmp_path):
    tomllib = pytest.importorskip("tomllib")
    cfg = tomllib.loads(DRIVE.read_text())
    a = feedscope.dynamics(cfg).to_dict()
    b = feedscope.dynamics(DRIVE).to_dict()
    assert a == b
    bad = tmp_path / "bad.toml"
    bad.write_text(DRIVE.read_text() + "\nspeed_of_light_mm_min = 3\n")
    message, code = cli_error("dynamics", "--config", bad, "--out", tmp_path / "o")
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.dynamics(bad)
    assert str(info.value).rstrip("\n") == message and code == 2
    message, code = cli_error("dynamics", "--config", tmp_path / "none.toml", "--out", tmp_path / "o")
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.dynamics(tmp_path / "none.toml")
    assert str(info.value).rstrip("\n") == message and code == 2
