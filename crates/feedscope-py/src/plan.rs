//! `feedscope.plan`: NC programs (G-code) for the friction tests, as `feedscope plan`.
use feedscope::plan::gcode::{write_gcode, Dialect, FanucMachine, GcodeOptions};
use feedscope::plan::{
    identifiability_warning, strokes_program, triangle_program, Limits, StrokeTestParams,
    TestProgram, TriangleParams,
};
use feedscope::sim::RampShape;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde_json::json;

use crate::axis::Axis;
use crate::convert::to_py;
use crate::errors::bad_input;
use feedscope_app::AppError;

/// An NC program of a friction test: `text` (the G-code, as `feedscope plan` writes it) and
/// its summary (`run_time_s` (s), `samples_per_channel`, `feeds_mm_min`, `span_mm`, `moves`,
/// `notes`, `ramp` and `jerk_mm_s3` the run time assumes, ...), as the binary's
/// `--format json` prints it.
#[pyclass(module = "feedscope", frozen)]
pub struct Plan {
    /// The program text.
    #[pyo3(get)]
    text: String,
    summary: serde_json::Value,
}

#[pymethods]
impl Plan {
    /// Expected run time (s).
    #[getter]
    fn run_time_s(&self) -> f64 {
        self.summary["run_time_s"].as_f64().unwrap_or(f64::NAN)
    }
    /// Expected samples per channel at the sampling interval given.
    #[getter]
    fn samples_per_channel(&self) -> u64 {
        self.summary["samples_per_channel"].as_u64().unwrap_or(0)
    }
    /// The feeds of the test, in order (mm/min).
    #[getter]
    fn feeds_mm_min<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary["feeds_mm_min"])
    }
    /// The moves of the program (list of dicts).
    #[getter]
    fn moves<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary["moves"])
    }
    /// Notes about the program (list of str).
    #[getter]
    fn notes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary["notes"])
    }
    /// What to know before running the test: for a triangular wave, that the twin sampled at
    /// `sample_interval_ms` cannot identify it (and the rate from which it can).
    #[getter]
    fn warnings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary["warnings"])
    }
    /// The summary as the binary's `plan ... --format json` prints it, without `output`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary)
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
        let s = &self.summary;
        format!(
            "Plan({} test, {}, {} moves over {} to {} mm, {} feed(s), run time {:.1} s, {} \
             samples per channel)",
            s["test"].as_str().unwrap_or("-"),
            s["dialect"].as_str().unwrap_or("-"),
            s["moves"].as_array().map_or(0, |m| m.len()),
            s["span_mm"][0],
            s["span_mm"][1],
            s["feeds_mm_min"].as_array().map_or(0, |m| m.len()),
            self.run_time_s(),
            self.samples_per_channel()
        )
    }
}

/// The options both tests share (the CLI's `Common`).
struct Common {
    limits: Limits,
    opts: GcodeOptions,
    accel_mm_s2: f64,
    ramp: RampShape,
    jerk_mm_s3: Option<f64>,
}

#[allow(clippy::too_many_arguments)]
fn common(
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
) -> PyResult<Common> {
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
    if jerk_mm_s3.is_some() && ramp != RampShape::JerkLimited {
        return Err(bad(
            "jerk_mm_s3 applies only to ramp=\"jerk_limited\" (trapezoid and bell ramps have no \
             jerk limit)",
        ));
    }
    let (lo, hi) = axis.map_or((None, None), |a| {
        (a.inner.travel_min_mm, a.inner.travel_max_mm)
    });
    let limits = Limits {
        travel_min_mm: travel_min_mm.or(lo),
        travel_max_mm: travel_max_mm.or(hi),
        feed_max_mm_min: feed_limit_mm_min,
    };
    let sample_interval_s = match sample_rate_hz {
        Some(r) if r.is_finite() && r > 0.0 => 1.0 / r,
        Some(r) => return Err(bad_input(format!("sample_rate_hz {r}: must be > 0"))),
        None => sample_interval_ms * 1e-3,
    };
    let opts = GcodeOptions {
        dialect: match dialect {
            "fanuc" => Dialect::Fanuc,
            "siemens" => Dialect::Siemens,
            other => {
                return Err(PyValueError::new_err(format!(
                    "dialect must be \"fanuc\" or \"siemens\", not {other:?}"
                )))
            }
        },
        fanuc_machine: match fanuc_machine {
            "lathe" => FanucMachine::Lathe,
            "mill" => FanucMachine::Mill,
            other => {
                return Err(PyValueError::new_err(format!(
                    "fanuc_machine must be \"lathe\" or \"mill\", not {other:?}"
                )))
            }
        },
        axis_letter,
        program_number,
        sample_interval_s,
        approach_feed_mm_min,
    };
    Ok(Common {
        limits,
        opts,
        accel_mm_s2,
        ramp,
        jerk_mm_s3,
    })
}

/// A library error of planning as bad input, as the CLI's `bad`.
fn bad<E: std::fmt::Display>(e: E) -> PyErr {
    crate::errors::py_err(AppError::bad_input(e.to_string()))
}

/// The G-code and summary of a program, with the CLI's checks of the approach feed.
fn finish(prog: TestProgram, c: &Common) -> PyResult<Plan> {
    let prog = prog
        .with_ramp(c.ramp, c.jerk_mm_s3)
        .map_err(|e| bad(format!("jerk_mm_s3: {e}")))?;
    if let Some(f) = c.opts.approach_feed_mm_min {
        if !(f.is_finite() && f > 0.0) {
            return Err(bad(format!("approach_feed_mm_min {f}: must be > 0")));
        }
        c.limits.check_feed(f).map_err(bad)?;
    }
    let text = write_gcode(&prog, &c.opts).map_err(bad)?;
    let summary = json!({
        "test": prog.kind,
        "dialect": c.opts.dialect,
        "start_mm": prog.start_mm,
        "span_mm": prog.span_mm(),
        "feeds_mm_min": prog.feeds_mm_min(),
        "run_time_s": prog.run_time_s(),
        "sample_interval_s": c.opts.sample_interval_s,
        "samples_per_channel": prog.expected_samples(c.opts.sample_interval_s),
        "accel_mm_s2": prog.accel_mm_s2,
        "ramp": prog.ramp,
        "jerk_mm_s3": prog.jerk_mm_s3,
        "notes": prog.notes,
        "warnings": identifiability_warning(&prog, c.opts.sample_interval_s)
            .into_iter()
            .collect::<Vec<_>>(),
        "moves": prog.moves,
    });
    Ok(Plan { text, summary })
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
    let c = common(
        axis,
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
    let p = StrokeTestParams {
        from_mm,
        to_mm,
        feeds_mm_min,
        repeats,
        dwell_s,
        accel_mm_s2: c.accel_mm_s2,
    };
    finish(strokes_program(&p, &c.limits).map_err(bad)?, &c)
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
    let c = common(
        axis,
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
    let lim = &c.limits;
    let from = from_mm
        .or(lim.travel_min_mm)
        .ok_or_else(|| bad("from_mm is needed (or travel_min_mm in the axis / travel_min_mm=)"))?;
    let to = to_mm
        .or(lim.travel_max_mm)
        .ok_or_else(|| bad("to_mm is needed (or travel_max_mm in the axis / travel_max_mm=)"))?;
    let feed_max = feed_max_mm_min
        .or(lim.feed_max_mm_min)
        .ok_or_else(|| bad("feed_max_mm_min or feed_limit_mm_min is needed"))?;
    let p = TriangleParams {
        window_min_mm: from,
        window_max_mm: to,
        feed_max_mm_min: feed_max,
        feed_min_mm_min,
        vs_guess_mm_min,
        levels,
        cycles_per_level: cycles,
        min_cruise_s: cruise_s,
        dwell_s,
        accel_mm_s2: c.accel_mm_s2,
    };
    finish(triangle_program(&p, lim).map_err(bad)?, &c)
}
