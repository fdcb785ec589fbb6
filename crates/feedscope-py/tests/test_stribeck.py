"""fit_stribeck against `feedscope fit-stribeck`: stribeck.json, from a file and from arrays."""

import json

import numpy as np
import pytest

import feedscope
from conftest import cli_error, run_cli


def stribeck_table(path, seed=3):
    """A steady-speed table of a known Stribeck curve (Fc 200 N, Fs 280 N, vs 60 mm/min,
    δ 2, σ 3000 N·s/m) with 0.5 N of noise, both directions, 14 feeds."""
    rng = np.random.RandomState(seed)
    feeds = np.array([5, 10, 20, 30, 45, 60, 80, 120, 200, 400, 800, 1500, 3000, 6000.0])
    v = feeds / 60000.0
    f = 200 + 80 * np.exp(-((feeds / 60) ** 2)) + 3000 * v
    rows = []
    for sign, name in [(1, "forward"), (-1, "backward")]:
        for fe, fr in zip(feeds, f + rng.normal(0, 0.5, f.size)):
            rows.append((float(sign * fe), float(fr), name))
    path.write_text("feed_mm_min,force_n,direction\n"
                    + "".join(f"{a!r},{b!r},{c}\n" for a, b, c in rows))
    return rows


@pytest.mark.parametrize("delta", ["2", "free"])
def test_fit_matches_cli(tmp_path, delta):
    rows = stribeck_table(tmp_path / "t.csv")
    run_cli("fit-stribeck", tmp_path / "t.csv", "--out", tmp_path / "out", "--delta", delta)
    cli = json.loads((tmp_path / "out" / "stribeck.json").read_text())
    d = 2.0 if delta == "2" else "free"
    r = feedscope.fit_stribeck(tmp_path / "t.csv", delta=d)
    assert r.to_dict() == cli
    # The same table as arrays: the same fit (source aside).
    a = feedscope.fit_stribeck(feed_mm_min=np.array([x[0] for x in rows]),
                               force_n=np.array([x[1] for x in rows]),
                               direction=[x[2] for x in rows], delta=d)
    ours = a.to_dict()
    assert ours.pop("source") == "arrays"
    cli.pop("source")
    assert ours == cli
    fwd = r.direction("forward")
    assert fwd["model"] == "stribeck"
    # The curve it was made from, within a few standard errors.
    assert abs(fwd["params"]["fc_n"] - 200) < 5
    assert abs(fwd["params"]["vs_mm_min"] - 60) < 10
    assert "forward: stribeck model" in repr(r)


def test_torque_table_needs_a_lead(tmp_path):
    (tmp_path / "t.csv").write_text("feed_mm_min,torque_nm\n100,0.3\n200,0.31\n400,0.33\n800,0.35\n")
    message, code = cli_error("fit-stribeck", tmp_path / "t.csv", "--out", tmp_path / "o")
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.fit_stribeck(tmp_path / "t.csv")
    assert str(info.value).rstrip("\n") == message and code == 2
    r = feedscope.fit_stribeck(tmp_path / "t.csv", lead_mm=10)
    run_cli("fit-stribeck", tmp_path / "t.csv", "--out", tmp_path / "o", "--lead-mm", "10")
    assert r.to_dict() == json.loads((tmp_path / "o" / "stribeck.json").read_text())


def test_one_feed_is_refused_as_in_cli(tmp_path):
    (tmp_path / "one.csv").write_text("feed_mm_min,force_n\n100,200\n100,201\n100,199\n")
    message, code = cli_error("fit-stribeck", tmp_path / "one.csv", "--out", tmp_path / "o")
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.fit_stribeck(tmp_path / "one.csv")
    assert str(info.value).rstrip("\n") == message and code == 2


def test_bad_arguments():
    with pytest.raises(feedscope.BadInputError, match="delta"):
        feedscope.fit_stribeck(feed_mm_min=np.array([1.0, 2.0]), force_n=np.array([1.0, 2.0]),
                               delta=-1.0)
    with pytest.raises(feedscope.BadInputError, match="equal length"):
        feedscope.fit_stribeck(feed_mm_min=np.array([1.0, 2.0]), force_n=np.array([1.0]))
    with pytest.raises(TypeError, match="dtype int64"):
        feedscope.fit_stribeck(feed_mm_min=np.array([1, 2]), force_n=np.array([1.0, 2.0]))
    with pytest.raises(TypeError):
        feedscope.fit_stribeck()
