"""plan against `feedscope plan`: the same G-code, byte for byte, and the same summary."""

import json

import pytest

import feedscope
from conftest import cli_error, run_cli


def cli_plan(tmp_path, *args):
    out = tmp_path / "p.nc"
    p = run_cli("plan", *args, "-o", out, "--format", "json")
    summary = json.loads(p.stdout)
    summary.pop("output")
    return out.read_text(), summary


def test_strokes_program_matches_cli(twin, tmp_path):
    text, summary = cli_plan(tmp_path, "strokes", "--from", "10", "--to", "400",
                             "--feeds", "100,1000,3000", "--repeats", "2",
                             "--axis", twin / "sim" / "axis.toml")
    axis = feedscope.Axis.load(twin / "sim" / "axis.toml")
    p = feedscope.plan("strokes", from_mm=10, to_mm=400, feeds_mm_min=[100, 1000, 3000],
                       repeats=2, axis=axis)
    assert p.text == text
    assert p.to_dict() == summary
    assert p.feeds_mm_min == [100.0, 1000.0, 3000.0]
    assert p.run_time_s == pytest.approx(summary["run_time_s"])
    assert "Plan(strokes test, fanuc" in repr(p)
    p.write(tmp_path / "again.nc")
    assert (tmp_path / "again.nc").read_text() == text


def test_triangle_program_siemens_matches_cli(tmp_path):
    text, summary = cli_plan(tmp_path, "triangle", "--from", "120", "--to", "200",
                             "--feed-max", "3000", "--levels", "6", "--cruise-s", "0.5",
                             "--dialect", "siemens", "--sample-rate-hz", "1000")
    p = feedscope.plan_triangle(from_mm=120, to_mm=200, feed_max_mm_min=3000, levels=6,
                                cruise_s=0.5, dialect="siemens", sample_rate_hz=1000)
    assert p.text == text
    assert p.to_dict() == summary


def test_plan_errors_match_cli(tmp_path):
    message, code = cli_error("plan", "strokes", "--from", "0", "--to", "100", "--feeds",
                              "50000", "--feed-limit", "30000", "-o", tmp_path / "x.nc")
    with pytest.raises(feedscope.BadInputError) as info:
        feedscope.plan_strokes(0, 100, [50000], feed_limit_mm_min=30000)
    assert str(info.value).rstrip("\n") == message and code == 2
    with pytest.raises(feedscope.BadInputError, match="feed_max_mm_min or feed_limit_mm_min"):
        feedscope.plan_triangle(from_mm=0, to_mm=100)
    with pytest.raises(ValueError, match="dialect"):
        feedscope.plan_strokes(0, 100, [100], dialect="heidenhain")
    with pytest.raises(ValueError, match="strokes"):
        feedscope.plan("spiral")


@pytest.mark.parametrize("ramp,cli_ramp,jerk", [("bell", "bell", None),
                                                ("trapezoid", "trapezoid", None),
                                                ("jerk_limited", "jerk-limited", 5000.0)])
def test_ramp_and_jerk_match_cli(tmp_path, ramp, cli_ramp, jerk):
    extra = ["--jerk-mm-s3", str(jerk)] if jerk else []
    text, summary = cli_plan(tmp_path, "strokes", "--from", "10", "--to", "60",
                             "--feeds", "3000", "--ramp", cli_ramp, *extra)
    p = feedscope.plan_strokes(10, 60, [3000], ramp=ramp, jerk_mm_s3=jerk)
    assert p.text == text
    assert p.to_dict() == summary
    assert summary["ramp"] == ramp and summary["jerk_mm_s3"] == jerk


def test_ramp_changes_the_run_time_and_bad_ramps_are_refused():
    # A gentle jerk lengthens every ramp: the run time grows, the moves do not change (only
    # the header's comments on run time and ramps do).
    fast = feedscope.plan_strokes(10, 60, [3000], jerk_mm_s3=100000.0)
    slow = feedscope.plan_strokes(10, 60, [3000], jerk_mm_s3=2000.0)
    assert slow.run_time_s > fast.run_time_s
    blocks = lambda p: [l for l in p.text.splitlines() if not l.startswith("(")]
    assert blocks(slow) == blocks(fast)
    assert "JERK 2000 MM/S3" in slow.text
    with pytest.raises(ValueError, match="ramp must be"):
        feedscope.plan_strokes(10, 60, [3000], ramp="scurve")
    with pytest.raises(feedscope.BadInputError, match="only to ramp=\"jerk_limited\""):
        feedscope.plan_triangle(from_mm=0, to_mm=100, feed_max_mm_min=1000, ramp="bell",
                                jerk_mm_s3=1000.0)
    with pytest.raises(feedscope.BadInputError, match="jerk_mm_s3"):
        feedscope.plan_strokes(10, 60, [3000], jerk_mm_s3=-1.0)


def test_triangle_too_fast_for_the_polling_warns_as_cli(tmp_path):
    _, summary = cli_plan(tmp_path, "triangle", "--from", "120", "--to", "200",
                          "--feed-max", "3000", "--sample-interval-ms", "72")
    p = feedscope.plan_triangle(from_mm=120, to_mm=200, feed_max_mm_min=3000,
                                sample_interval_ms=72)
    assert len(p.warnings) == 1 and "cannot be identified" in p.warnings[0]
    assert p.warnings == summary["warnings"]
    assert p.to_dict() == summary


def test_sampling_keywords_are_checked_and_named():
    # The app's PlanRequest.validate(): an interval or a rate that is no positive number is
    # refused naming the keyword (before, a zero interval gave infinite sample counts).
    for kw in ({"sample_interval_ms": 0.0}, {"sample_interval_ms": float("nan")},
               {"sample_rate_hz": -5.0}):
        with pytest.raises(feedscope.BadInputError, match=f"{next(iter(kw))} .*must be > 0"):
            feedscope.plan_strokes(10, 60, [3000], **kw)
