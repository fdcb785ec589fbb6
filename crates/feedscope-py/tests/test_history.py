"""History against `feedscope history`: the same indicators stored, the same trends."""

import json

import pytest

import feedscope
from conftest import TORQUE_CONFIG, cli_error, run_cli

SEEDS = range(1, 7)  # six weekly tests: the baseline takes the first five


@pytest.fixture(scope="module")
def weeks(tmp_path_factory):
    d = tmp_path_factory.mktemp("history")
    (d / "sim.toml").write_text(TORQUE_CONFIG)
    for s in SEEDS:
        run_cli("simulate", "--config", d / "sim.toml", "--seed", s, "--out", d / f"w{s}")
    return d


def time_of(s):
    return f"2026-10-{s:02d}T08:00:00Z"


def without_added(report):
    """`added_utc`, when a row shows it, is the wall-clock time of the insert: it differs
    between two databases."""
    for t in report["tests"]:
        t.pop("added_utc", None)
    return report


def test_add_and_trend_match_cli(weeks):
    d = weeks
    h = feedscope.History(d / "py.db")
    for s in SEEDS:
        p = run_cli("history", "--db", d / "cli.db", "add", d / f"w{s}" / "trace.csv",
                    "--axis", d / f"w{s}" / "axis.toml", "--kind", "strokes",
                    "--time", time_of(s), "--machine", "lathe", "--format", "json")
        e = h.add(d / f"w{s}" / "trace.csv", d / f"w{s}" / "axis.toml", "strokes",
                  time=time_of(s), machine="lathe")
        assert e.to_dict() == json.loads(p.stdout)
        assert not e.duplicate and e.id == s
    # The same trace again is a duplicate, as in the CLI.
    again = h.add(d / "w1" / "trace.csv", d / "w1" / "axis.toml", "strokes",
                  time=time_of(1), machine="lathe")
    assert again.duplicate and again.id == 1
    cli = json.loads(run_cli("history", "--db", d / "cli.db", "trend", "--machine", "lathe",
                             "--format", "json").stdout)
    ours = h.trend(machine="lathe")
    assert without_added(ours.to_dict()) == without_added(cli)
    # What Python stored reads back in the binary as the binary's own.
    cli_on_py = json.loads(run_cli("history", "--db", d / "py.db", "trend", "--machine", "lathe",
                                   "--format", "json").stdout)
    assert without_added(cli_on_py) == without_added(json.loads(json.dumps(cli)))
    assert len(h.list(machine="lathe")) == 6
    assert ours.trends and ours.diagnosis
    assert isinstance(ours.warning, bool)
    assert "TrendResult(lathe simulated lathe Z: 6 tests" in repr(ours)


def test_history_errors(weeks, tmp_path):
    d = weeks
    h = feedscope.History(tmp_path / "h.db")
    with pytest.raises(feedscope.BadInputError, match="holds no tests yet"):
        h.trend()
    h.add(d / "w1" / "trace.csv", d / "w1" / "axis.toml", "strokes", time=time_of(1))
    with pytest.raises(feedscope.BadInputError, match='no machine "mill"'):
        h.trend(machine="mill")
    with pytest.raises(feedscope.BadInputError, match="RFC 3339"):
        h.add(d / "w2" / "trace.csv", d / "w2" / "axis.toml", "strokes", time="last tuesday")
    with pytest.raises(ValueError, match="kind"):
        h.add(d / "w2" / "trace.csv", d / "w2" / "axis.toml", "spiral")
    # A file that is not a database: bad input naming it, as the CLI.
    (tmp_path / "not.db").write_text("hello, I am a text file, not SQLite\n" * 100)
    message, code = cli_error("history", "--db", tmp_path / "not.db", "list")
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.History(tmp_path / "not.db")
    assert str(info.value).rstrip("\n") == message and code == 2
