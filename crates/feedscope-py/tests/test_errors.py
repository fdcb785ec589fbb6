"""Bad input raises the exception of its kind, with the binary's message; numpy arguments of
the wrong dtype, shape or length are refused clearly."""

import numpy as np
import pytest

import feedscope
from conftest import cli_error

GOOD_AXIS = """\
lead_mm = 10
table_mass_kg = 425
inertia_kgm2 = 0.004
damping_nms_per_rad = 0.002
torque_constant_nm_per_a = 1.82
"""


@pytest.fixture
def files(tmp_path):
    (tmp_path / "axis.toml").write_text(GOOD_AXIS)
    rows = "\n".join(f"{k * 0.01:.2f},{k * 0.1:.3f},{1 + 0.01 * k:.3f}" for k in range(50))
    (tmp_path / "good.csv").write_text("time_s,position_mm,current_a\n" + rows + "\n")
    return tmp_path


def same_error(tmp_path, trace_name, content, exc=feedscope.BadInputError, axis="axis.toml"):
    """The CLI's `estimate` and Python's read_trace + estimate fail alike on a file."""
    path = tmp_path / trace_name
    if content is not None:
        path.write_text(content)
    message, code = cli_error("estimate", path, "--axis", tmp_path / axis,
                              "-o", tmp_path / "out.csv", "--no-plot")
    with pytest.raises(exc) as info:
        a = feedscope.Axis.load(tmp_path / axis)
        feedscope.estimate(feedscope.read_trace(path, axis=a), a)
    assert str(info.value).rstrip("\n") == message
    assert isinstance(info.value, feedscope.FeedscopeError)
    return message, code


def test_missing_file(files):
    message, code = same_error(files, "nope.csv", None)
    assert code == 2 and "nope.csv" in message


def test_not_a_number_names_the_line(files):
    message, code = same_error(
        files, "bad.csv",
        "time_s,position_mm,current_a\n0,0,1\n0.01,0.1,1\n0.02,abc,1\n0.03,0.3,1\n")
    assert code == 2 and "bad.csv:4" in message and "abc" in message


def test_time_not_increasing(files):
    message, code = same_error(
        files, "back.csv",
        "time_s,position_mm,current_a\n0,0,1\n0.01,0.1,1\n0.005,0.2,1\n0.03,0.3,1\n0.04,0.4,1\n")
    assert code == 2 and "back.csv:4" in message


def test_nan_in_file(files):
    message, code = same_error(
        files, "nan.csv",
        "time_s,position_mm,current_a\n0,0,1\n0.01,NaN,1\n0.02,0.2,1\n0.03,0.3,1\n0.04,0.4,1\n")
    assert code == 2 and "nan.csv:3" in message


def test_missing_column(files):
    message, code = same_error(files, "nocol.csv", "time_s,position_mm\n0,0\n1,1\n2,2\n3,3\n")
    assert code == 2 and "nocol.csv" in message


def test_bad_axis_key_names_the_key(files):
    (files / "bad_axis.toml").write_text(GOOD_AXIS + "lead_inch = 3\n")
    message, code = same_error(files, "good.csv", None, axis="bad_axis.toml")
    assert code == 2 and "lead_inch" in message
    with pytest.raises(feedscope.BadInputError, match="lead_inch"):
        feedscope.Axis(lead_mm=10, table_mass_kg=425, inertia_kgm2=0.004,
                       damping_nms_per_rad=0.002, torque_constant_nm_per_a=1.82, lead_inch=3)


def test_axis_value_out_of_range(files):
    (files / "neg.toml").write_text(GOOD_AXIS.replace("lead_mm = 10", "lead_mm = -10"))
    message, code = same_error(files, "good.csv", None, axis="neg.toml")
    assert code == 2 and "lead_mm" in message


def test_no_steady_stroke(files):
    # The position creeps 0.05 mm in all: no stroke of 1 mm, the estimate refuses, as the CLI.
    rows = "\n".join(f"{k * 0.01:.2f},{k * 0.001:.3f},{1 + 0.01 * k:.3f}" for k in range(50))
    message, code = same_error(files, "tiny.csv", "time_s,position_mm,current_a\n" + rows + "\n")
    assert code == 2 and message.startswith("no steady stroke found")


def test_axis_keyword_matches_file(files):
    a = feedscope.Axis(lead_mm=10, table_mass_kg=425, inertia_kgm2=0.004,
                       damping_nms_per_rad=0.002, torque_constant_nm_per_a=1.82)
    b = feedscope.Axis.load(files / "axis.toml")
    assert a.to_dict() == b.to_dict()
    assert a.lead_mm == 10 and a.table_mass_kg == 425 and a.screw_diameter_mm is None
    assert "lead_mm=10.0" in repr(a)
    with pytest.raises(AttributeError):
        a.no_such_key


def test_estimate_parameters(files):
    a = feedscope.Axis.load(files / "axis.toml")
    tr = feedscope.read_trace(files / "good.csv")
    with pytest.raises(feedscope.BadInputError, match="samples_per_lead"):
        feedscope.estimate(tr, a, samples_per_lead=0)
    with pytest.raises(ValueError, match="end_condition"):
        feedscope.estimate(tr, a, end_condition="clamped")
    with pytest.raises(feedscope.BadInputError, match="position_cutoff_hz"):
        feedscope.estimate(tr, a, position_cutoff_hz=-3.0)
    with pytest.raises(TypeError):
        feedscope.estimate(tr, a, position_cutoff_hz=[1])
    with pytest.raises(ValueError, match="effort"):
        feedscope.read_trace(files / "good.csv", effort="voltage")


def test_effort_choice_names_the_keyword(files):
    (files / "both.csv").write_text(
        "time_s,position_mm,current_a,torque_nm\n"
        + "\n".join(f"{k * 0.01:.2f},{k * 0.1:.2f},1,2" for k in range(20)) + "\n")
    with pytest.raises(feedscope.BadInputError, match='effort="current" or effort="torque"'):
        feedscope.read_trace(files / "both.csv")
    assert feedscope.read_trace(files / "both.csv", effort="torque").effort_kind == "torque_nm"


# numpy arguments

T = np.arange(10) * 0.01
Z = np.arange(10) * 0.5
I = np.ones(10)


def test_dtype_is_refused_clearly():
    with pytest.raises(TypeError, match=r"position_mm must be a 1-D numpy array of float64, got dtype int64"):
        feedscope.Trace(time_s=T, position_mm=np.arange(10), current_a=I)
    with pytest.raises(TypeError, match="float32"):
        feedscope.Trace(time_s=T.astype(np.float32), position_mm=Z, current_a=I)
    with pytest.raises(TypeError, match="got list"):
        feedscope.Trace(time_s=list(T), position_mm=Z, current_a=I)


def test_shape_is_refused_clearly():
    with pytest.raises(TypeError, match=r"2 dimensions with shape \[10, 1\]"):
        feedscope.Trace(time_s=T, position_mm=Z.reshape(10, 1), current_a=I)


def test_length_nan_and_order():
    with pytest.raises(feedscope.BadInputError, match="current_a has 9 samples but its times time_s have 10"):
        feedscope.Trace(time_s=T, position_mm=Z, current_a=I[:9])
    bad = Z.copy()
    bad[3] = np.nan
    with pytest.raises(feedscope.BadInputError, match=r"position_mm\[3\] is NaN"):
        feedscope.Trace(time_s=T, position_mm=bad, current_a=I)
    back = T.copy()
    back[5] = back[4]
    with pytest.raises(feedscope.BadInputError, match=r"time_s\[5\] = 0.04 s does not come after"):
        feedscope.Trace(time_s=back, position_mm=Z, current_a=I)
    with pytest.raises(feedscope.BadInputError, match="at least 4"):
        feedscope.Trace(time_s=T[:3], position_mm=Z[:3], current_a=I[:3])
    with pytest.raises(feedscope.BadInputError, match="never moves"):
        feedscope.Trace(time_s=T, position_mm=np.zeros(10), current_a=I)


def test_channel_arguments():
    with pytest.raises(TypeError, match="not both"):
        feedscope.Trace(time_s=T, position_mm=Z, current_a=I, torque_nm=I)
    with pytest.raises(TypeError, match="effort channel"):
        feedscope.Trace(time_s=T, position_mm=Z)
    with pytest.raises(TypeError, match="time stamps"):
        feedscope.Trace(position_mm=Z, current_a=I)
    # A strided view (a column of a 2-D array) is accepted.
    m = np.stack([T, Z, I], axis=1)
    tr = feedscope.Trace(time_s=m[:, 0], position_mm=m[:, 1], current_a=m[:, 2])
    # mm → m → mm may move the last bit.
    assert np.allclose(tr.position_mm, Z, rtol=1e-15, atol=0) and tr.effort_kind == "current_a"


def test_glitch_is_dropped_and_a_jump_refused():
    t = np.arange(400) * 0.01
    z = t * 10.0
    g = z.copy()
    g[200] = 1e6  # a logger glitch, 1 km away for one sample
    tr = feedscope.Trace(time_s=t, position_mm=g, current_a=np.ones(400))
    assert len(tr.position_mm) == 399
    assert tr.dropped_position[0]["time_s"] == pytest.approx(2.0)
    # The reader's diagnostic in its serde form, as the reports' warnings.
    [w] = tr.warnings
    assert w["code"] == "position-glitches-dropped" and "dropped" in w["message"], w
    assert tr.to_dict()["warnings"] == tr.warnings
    j = z.copy()
    j[200:] += 1e5  # a jump that stays
    with pytest.raises(feedscope.BadInputError, match="does not come back"):
        feedscope.Trace(time_s=t, position_mm=j, current_a=np.ones(400))


def test_damaged_parquet_is_bad_input(tmp_path):
    """A cut Parquet file is refused as by the binary (its decoder's panics are caught by the
    reader and reported as errors naming the file)."""
    t = np.arange(5000) * 0.001
    tr = feedscope.Trace(time_s=t, position_mm=20.0 * t, current_a=np.sin(t))
    tr.write(tmp_path / "t.parquet")
    data = (tmp_path / "t.parquet").read_bytes()
    (tmp_path / "cut.parquet").write_bytes(data[: len(data) // 2] + data[-8:])
    (tmp_path / "axis.toml").write_text(GOOD_AXIS)
    message, code = same_error(tmp_path, "cut.parquet", None)
    assert code == 2 and "cut.parquet" in message
