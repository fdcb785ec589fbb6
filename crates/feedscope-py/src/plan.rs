//! `feedscope.plan`: NC programs (G-code) for the friction tests, as `feedscope plan`.
use feedscope::plan::gcode::{Dialect, FanucMachine};
use feedscope::sim::RampShape;
use feedscope_app::plan::{PlanReport, PlanRequest, PlanTest, StrokesTest, TriangleTest};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::axis::Axis;
use crate::convert::to_py;
use crate::errors::py_err;
use crate::front::Keywords;

/// A value's serde name (`"strokes"`, `"fanuc"`), as the summary spells it.
fn serde_name(v: &impl serde::Serialize) -> String {
    serde_json::to_value(v)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| "-".to_string())
}

/// An NC program of a friction test: `text` (the G-code, as `feedscope plan` writes it) and
/// its summary (`run_time_s` (s), `samples_per_channel`, `feeds_mm_min`, `span_mm`, `moves`,
/// `notes`, `ramp` and `jerk_mm_s3` the run time assumes, ...): the app's `PlanReport`, as the
/// binary's `--format json` prints it.
#[pyclass(module = "feedscope", frozen)]
pub struct Plan {
    /// The program text.
    #[pyo3(get)]
    text: String,
    report: PlanReport,
}

#[pymethods]
impl Plan {
    /// Expected run time (s).
    #[getter]
    fn run_time_s(&self) -> f64 {
        self.report.run_time_s
    }
    /// Expected samples per channel at the sampling interval given.
    #[getter]
    fn samples_per_channel(&self) -> u64 {
        self.report.samples_per_channel
    }
    /// The feeds of the test, in order (mm/min).
    #[getter]
    fn feeds_mm_min<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.feeds_mm_min)
    }
    /// The moves of the program (list of dicts).
    #[getter]
    fn moves<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.moves)
    }
    /// Notes about the program (list of str).
    #[getter]
    fn notes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.notes)
    }
    /// What to know before running the test: for a triangular wave, that the twin sampled at
    /// `sample_interval_ms` cannot identify it (and the rate from which it can).
    #[getter]
    fn warnings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.warnings)
    }
    /// The summary as the binary's `plan ... --format json` prints it, without `output`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }
    /// Write the program text to `path`.
    fn write(&self, path: std::path::PathBuf) -> PyResult<()> {
        std::fs::write(&path, &self.text).map_err(|e| {
            crate::errors::py_err(
                anyhow::Error::new(e).context(format!("writing {}", path.display())),
            )
        })
    }
    fn __str__(&self) -> String {
        self.text.clone()
    }
    fn __repr__(&self) -> String {
        let s = &self.report;
        format!(
            "Plan({} test, {}, {} moves over {} to {} mm, {} feed(s), run time {:.1} s, {} \
             samples per channel)",
            serde_name(&s.test),
            serde_name(&s.dialect),
            s.moves.len(),
            s.span_mm.0,
            s.span_mm.1,
            s.feeds_mm_min.len(),
            s.run_time_s,
            s.samples_per_channel
        )
    }
}

/// The options both tests share, as a request of the app with `test` still to set (the
/// enum keywords checked here with the messages Python users see).
#[allow(clippy::too_many_arguments)]
fn request(
    travel_min_mm: Option<f64>,
    travel_max_mm: Option<f64>,
    feed_limit_mm_min: Option<f64>,
    dialect: &str,
    fanuc_machine: &str,
    axis_letter: char,
    program_number: u32,
    approach_feed_mm_min: Option<f64>,
    accel_mm_s2: f64,
    sample_interval_ms: f64,
    sample_rate_hz: Option<f64>,
    ramp: &str,
    jerk_mm_s3: Option<f64>,
) -> PyResult<PlanRequest> {
    // The CLI's --ramp names, with Python's underscores accepted too.
    let ramp = match ramp {
        "trapezoid" => RampShape::Trapezoid,
        "jerk_limited" | "jerk-limited" => RampShape::JerkLimited,
        "bell" => RampShape::Bell,
        other => {
            return Err(PyValueError::new_err(format!(
                "ramp must be \"trapezoid\", \"jerk_limited\" or \"bell\", not {other:?}"
            )))
        }
    };
    let dialect = match dialect {
        "fanuc" => Dialect::Fanuc,
        "siemens" => Dialect::Siemens,
        other => {
            return Err(PyValueError::new_err(format!(
                "dialect must be \"fanuc\" or \"siemens\", not {other:?}"
            )))
        }
    };
    let fanuc_machine = match fanuc_machine {
        "lathe" => FanucMachine::Lathe,
        "mill" => FanucMachine::Mill,
        other => {
            return Err(PyValueError::new_err(format!(
                "fanuc_machine must be \"lathe\" or \"mill\", not {other:?}"
            )))
        }
    };
    Ok(PlanRequest {
        travel_min_mm,
        travel_max_mm,
        feed_limit_mm_min,
        dialect,
        fanuc_machine,
        axis_letter,
        program_number,
        approach_feed_mm_min,
        accel_mm_s2,
        ramp,
        jerk_mm_s3,
        sample_interval_ms: Some(sample_interval_ms),
        sample_rate_hz,
        ..PlanRequest::default()
    })
}

/// Plan `request` within the travel of `axis` (none written: `Plan.write` writes on demand).
fn finish(request: &PlanRequest, axis: Option<&Axis>) -> PyResult<Plan> {
    let planned = request
        .plan(axis.map(|a| &a.inner), &Keywords)
        .map_err(py_err)?;
    Ok(Plan {
        text: planned.gcode,
        report: planned.report,
    })
}

/// The NC program of a stroke test (paper 000), as `feedscope plan strokes`: idle strokes from
/// `from_mm` to `to_mm` and back at each feed of `feeds_mm_min` (mm/min), `repeats` pairs per
/// feed, `dwell_s` (s) after every stroke. Travel limits from `axis` (travel_min_mm,
/// travel_max_mm) or `travel_min_mm`/`travel_max_mm`; feeds checked against
/// `feed_limit_mm_min`. `dialect` "fanuc" or "siemens"; `fanuc_machine` "lathe" or "mill";
/// `accel_mm_s2` (mm/s²) and `sample_interval_ms` (ms) or `sample_rate_hz` (Hz) for the run
/// time and sample counts; `ramp` ("jerk_limited", the default, "trapezoid" or "bell") and
/// `jerk_mm_s3` (mm/s³, jerk-limited only; default 20,000) the control's ramps the run time
/// assumes, as the CLI's --ramp and --jerk-mm-s3.
#[pyfunction]
#[pyo3(signature = (from_mm, to_mm, feeds_mm_min, *, repeats=3, dwell_s=1.0, axis=None,
                    travel_min_mm=None, travel_max_mm=None, feed_limit_mm_min=None,
                    dialect="fanuc", fanuc_machine="lathe", axis_letter='Z',
                    program_number=1000, approach_feed_mm_min=None, accel_mm_s2=1000.0,
                    sample_interval_ms=72.0, sample_rate_hz=None, ramp="jerk_limited",
                    jerk_mm_s3=None))]
#[allow(clippy::too_many_arguments)]
pub fn plan_strokes(
    from_mm: f64,
    to_mm: f64,
    feeds_mm_min: Vec<f64>,
    repeats: u32,
    dwell_s: f64,
    axis: Option<&Axis>,
    travel_min_mm: Option<f64>,
    travel_max_mm: Option<f64>,
    feed_limit_mm_min: Option<f64>,
    dialect: &str,
    fanuc_machine: &str,
    axis_letter: char,
    program_number: u32,
    approach_feed_mm_min: Option<f64>,
    accel_mm_s2: f64,
    sample_interval_ms: f64,
    sample_rate_hz: Option<f64>,
    ramp: &str,
    jerk_mm_s3: Option<f64>,
) -> PyResult<Plan> {
    let mut r = request(
        travel_min_mm,
        travel_max_mm,
        feed_limit_mm_min,
        dialect,
        fanuc_machine,
        axis_letter,
        program_number,
        approach_feed_mm_min,
        accel_mm_s2,
        sample_interval_ms,
        sample_rate_hz,
        ramp,
        jerk_mm_s3,
    )?;
    r.test = PlanTest::Strokes(StrokesTest {
        from_mm,
        to_mm,
        feeds_mm_min,
        repeats,
        dwell_s,
    });
    finish(&r, axis)
}

/// The NC program of a triangle test (paper 002 Eq. 8), as `feedscope plan triangle`: a
/// variable-amplitude, variable-velocity triangular wave in the window `from_mm`..`to_mm`
/// (default: the travel limits), feeds geometric from `feed_min_mm_min` (default
/// vs_guess_mm_min/5) to `feed_max_mm_min` (default: feed_limit_mm_min) over `levels` levels,
/// `cycles` full cycles per level, each stroke cruising `cruise_s` (s) where the window
/// allows, `dwell_s` (s) after every stroke. Other keywords as `plan_strokes`.
#[pyfunction]
#[pyo3(signature = (*, from_mm=None, to_mm=None, feed_max_mm_min=None, feed_min_mm_min=None,
                    vs_guess_mm_min=60.0, levels=10, cycles=1, cruise_s=2.0, dwell_s=0.0,
                    axis=None, travel_min_mm=None, travel_max_mm=None, feed_limit_mm_min=None,
                    dialect="fanuc", fanuc_machine="lathe", axis_letter='Z',
                    program_number=1000, approach_feed_mm_min=None, accel_mm_s2=1000.0,
                    sample_interval_ms=72.0, sample_rate_hz=None, ramp="jerk_limited",
                    jerk_mm_s3=None))]
#[allow(clippy::too_many_arguments)]
pub fn plan_triangle(
    from_mm: Option<f64>,
    to_mm: Option<f64>,
    feed_max_mm_min: Option<f64>,
    feed_min_mm_min: Option<f64>,
    vs_guess_mm_min: f64,
    levels: usize,
    cycles: usize,
    cruise_s: f64,
    dwell_s: f64,
    axis: Option<&Axis>,
    travel_min_mm: Option<f64>,
    travel_max_mm: Option<f64>,
    feed_limit_mm_min: Option<f64>,
    dialect: &str,
    fanuc_machine: &str,
    axis_letter: char,
    program_number: u32,
    approach_feed_mm_min: Option<f64>,
    accel_mm_s2: f64,
    sample_interval_ms: f64,
    sample_rate_hz: Option<f64>,
    ramp: &str,
    jerk_mm_s3: Option<f64>,
) -> PyResult<Plan> {
    let mut r = request(
        travel_min_mm,
        travel_max_mm,
        feed_limit_mm_min,
        dialect,
        fanuc_machine,
        axis_letter,
        program_number,
        approach_feed_mm_min,
        accel_mm_s2,
        sample_interval_ms,
        sample_rate_hz,
        ramp,
        jerk_mm_s3,
    )?;
    r.test = PlanTest::Triangle(TriangleTest {
        from_mm,
        to_mm,
        feed_max_mm_min,
        feed_min_mm_min,
        vs_guess_mm_min,
        levels,
        cycles,
        cruise_s,
        dwell_s,
    });
    finish(&r, axis)
}
