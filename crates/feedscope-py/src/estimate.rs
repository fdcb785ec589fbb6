//! `feedscope.estimate`: friction along the travel (paper 000, Section 3, Eq. 5), as
//! `feedscope estimate`.
use std::path::PathBuf;

use feedscope::estimate::{
    EffortSign, PositionSmoothing, StrokeFriction, StrokeSummary, TimeOfPosition,
};
use feedscope::spline::EndCondition;
use feedscope::trace::EffortKind;
use feedscope_app::estimate::{estimate_recording, parse_cutoff, EstimateOptions, EstimateReport};
use feedscope_app::Recording;
use numpy::PyArray1;
use pyo3::exceptions::{PyImportError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyFloat, PyInt, PyString};

use crate::axis::Axis;
use crate::convert::{array, scaled, to_py};
use crate::errors::{bad_input, py_err};
use crate::front::Keywords;
use crate::trace::Trace;

/// `position_cutoff_hz=`: `"auto"`, `"off"` or a cut-off in Hz (None, the default, is
/// `"auto"`); a number is checked with the request ([`EstimateOptions::params`]).
fn cutoff(obj: Option<&Bound<'_, PyAny>>) -> PyResult<PositionSmoothing> {
    let Some(obj) = obj else {
        return Ok(PositionSmoothing::Auto);
    };
    if let Ok(s) = obj.cast::<PyString>() {
        return parse_cutoff(&s.to_cow()?)
            .map_err(|why| bad_input(format!("position_cutoff_hz: {why}")));
    }
    if obj.cast::<PyFloat>().is_ok() || obj.cast::<PyInt>().is_ok() {
        return Ok(PositionSmoothing::CutoffHz(obj.extract()?));
    }
    Err(PyTypeError::new_err(
        "position_cutoff_hz must be \"auto\", \"off\" or a number (Hz)",
    ))
}

/// One of the words of a CLI value enum.
fn word<T: Copy>(name: &str, value: &str, choices: &[(&str, T)]) -> PyResult<T> {
    choices
        .iter()
        .find(|(w, _)| *w == value)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            let names: Vec<String> = choices.iter().map(|(w, _)| format!("{w:?}")).collect();
            PyValueError::new_err(format!(
                "{name} must be one of {}, not {value:?}",
                names.join(", ")
            ))
        })
}

/// One stroke's friction along the travel: numpy arrays on the resampling grid (one point
/// every lead/samples_per_lead), in time order, and the stroke's summary.
///
/// Arrays (read-only, all of equal length): `position_mm` (mm), `time_s` (s),
/// `velocity_mm_s` (mm/s), `accel_mm_s2` (mm/s²), `current_a` (A) or `torque_nm` (N·m) as
/// `effort_kind` says (also as `effort`), `friction_n` (N, signed as Eq. 5: positive moving
/// forward, negative backward, or from the direction of motion when the effort is a magnitude).
#[pyclass(module = "feedscope", frozen)]
pub struct Stroke {
    /// The stroke's summary, as in the binary's JSON summary.
    summary: StrokeSummary,
    effort_kind: EffortKind,
    /// Resampled positions (mm).
    #[pyo3(get)]
    position_mm: Py<PyArray1<f64>>,
    /// Times at those positions (s).
    #[pyo3(get)]
    time_s: Py<PyArray1<f64>>,
    /// Table velocity (mm/s).
    #[pyo3(get)]
    velocity_mm_s: Py<PyArray1<f64>>,
    /// Table acceleration (mm/s²).
    #[pyo3(get)]
    accel_mm_s2: Py<PyArray1<f64>>,
    /// Motor current (A) or torque (N·m).
    #[pyo3(get)]
    effort: Py<PyArray1<f64>>,
    /// Friction force F_f (N), Eq. 5.
    #[pyo3(get)]
    friction_n: Py<PyArray1<f64>>,
}

impl Stroke {
    /// The stroke from the library's result, its vectors moved into numpy (positions,
    /// velocities and accelerations scaled from m to mm in place, as the binary's CSV does).
    pub fn from_friction(
        py: Python<'_>,
        s: StrokeFriction,
        effort_kind: EffortKind,
    ) -> PyResult<Self> {
        Ok(Self {
            summary: s.summary,
            effort_kind,
            position_mm: scaled(py, s.position_m, 1e3)?,
            time_s: array(py, s.time_s)?.unbind(),
            velocity_mm_s: scaled(py, s.velocity_m_s, 1e3)?,
            accel_mm_s2: scaled(py, s.accel_m_s2, 1e3)?,
            effort: array(py, s.effort)?.unbind(),
            friction_n: array(py, s.friction_n)?.unbind(),
        })
    }

    fn direction_str(&self) -> &'static str {
        self.summary.direction.as_str()
    }
}

#[pymethods]
impl Stroke {
    /// Stroke number (0-based, time order), as in the binary's table and CSV.
    #[getter]
    fn stroke(&self) -> usize {
        self.summary.stroke
    }
    /// `"measuring"`, `"rapid"`, `"positioning"` or `"jog"`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.summary.kind.as_str()
    }
    /// `"forward"` (increasing position) or `"backward"`.
    #[getter]
    fn direction(&self) -> &'static str {
        self.direction_str()
    }
    /// Measured plateau feed (mm/min).
    #[getter]
    fn feed_mm_min(&self) -> f64 {
        self.summary.feed_mm_min
    }
    /// Low end of the feed's range along the stroke: the 5th percentile of its chord speeds
    /// (mm/min), or None when not known.
    #[getter]
    fn feed_min_mm_min(&self) -> Option<f64> {
        self.summary.feed_min_mm_min
    }
    /// High end of the feed's range: the 95th percentile of its chord speeds (mm/min), or None.
    #[getter]
    fn feed_max_mm_min(&self) -> Option<f64> {
        self.summary.feed_max_mm_min
    }
    /// First resampled position (mm).
    #[getter]
    fn start_mm(&self) -> f64 {
        self.summary.start_mm
    }
    /// Last resampled position (mm).
    #[getter]
    fn end_mm(&self) -> f64 {
        self.summary.end_mm
    }
    /// Mean friction over the stroke (N, signed).
    #[getter]
    fn mean_friction_n(&self) -> f64 {
        self.summary.mean_friction_n
    }
    /// Standard error of the mean friction (N), when known.
    #[getter]
    fn mean_friction_se_n(&self) -> Option<f64> {
        self.summary.mean_friction_se_n
    }
    /// RMS of friction minus its mean (N).
    #[getter]
    fn friction_std_n(&self) -> f64 {
        self.summary.friction_std_n
    }
    /// Highest order (cycles per lead) that can be trusted.
    #[getter]
    fn max_order(&self) -> f64 {
        self.summary.max_order
    }
    /// Cut-off of the position smoothing (Hz), when applied.
    #[getter]
    fn position_cutoff_hz(&self) -> Option<f64> {
        self.summary.position_cutoff_hz
    }
    /// Raw samples per lead (the smaller of the two channels).
    #[getter]
    fn raw_samples_per_lead(&self) -> f64 {
        self.summary.raw_samples_per_lead
    }
    /// `"current_a"` or `"torque_nm"`: what `effort` holds.
    #[getter]
    fn effort_kind(&self) -> &'static str {
        self.effort_kind.column()
    }
    /// Motor current (A), or None for a torque trace.
    #[getter]
    fn current_a(&self, py: Python<'_>) -> Option<Py<PyArray1<f64>>> {
        (self.effort_kind == EffortKind::CurrentA).then(|| self.effort.clone_ref(py))
    }
    /// Motor torque (N·m), or None for a current trace.
    #[getter]
    fn torque_nm(&self, py: Python<'_>) -> Option<Py<PyArray1<f64>>> {
        (self.effort_kind == EffortKind::TorqueNm).then(|| self.effort.clone_ref(py))
    }
    /// What this stroke's data support (`support`, `reasons`), as a dict; None when not judged.
    #[getter]
    fn verdict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary.verdict)
    }
    /// Predicted noise floor of the friction (N RMS) and its parts, as a dict.
    #[getter]
    fn noise_floor<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary.noise_floor)
    }
    /// Warnings (diagnostics) about this stroke: dicts of `code` and `message`.
    #[getter]
    fn warnings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary.warnings)
    }
    /// The stroke's summary: every field of the binary's JSON summary entry, as a dict.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.summary)
    }
    /// Number of resampled points.
    fn __len__(&self) -> usize {
        self.summary.points
    }

    /// The summary's fields and the arrays (`position_mm`, `time_s`, `velocity_mm_s`,
    /// `accel_mm_s2`, `current_a`/`torque_nm`, `friction_n`) in one dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = self.summary(py)?.cast_into::<PyDict>()?;
        d.set_item("position_mm", self.position_mm.bind(py))?;
        d.set_item("time_s", self.time_s.bind(py))?;
        d.set_item("velocity_mm_s", self.velocity_mm_s.bind(py))?;
        d.set_item("accel_mm_s2", self.accel_mm_s2.bind(py))?;
        d.set_item(self.effort_kind.column(), self.effort.bind(py))?;
        d.set_item("friction_n", self.friction_n.bind(py))?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let s = &self.summary;
        format!(
            "Stroke({} {} {}, {:.1} mm/min, {:.2} → {:.2} mm, mean friction {:.2} N ± {}, \
             {} points, supports {}{})",
            s.stroke,
            s.kind.as_str(),
            s.direction.as_str(),
            s.feed_mm_min,
            s.start_mm,
            s.end_mm,
            s.mean_friction_n,
            s.mean_friction_se_n
                .map_or_else(|| "-".to_string(), |e| format!("{e:.2}")),
            s.points,
            s.verdict.as_ref().map_or("-", |v| v.support.as_str()),
            if s.warnings.is_empty() {
                String::new()
            } else {
                format!(", {} warning(s)", s.warnings.len())
            }
        )
    }
}

/// The result of `estimate`: the strokes (`strokes`, a list of `Stroke`) and what the binary's
/// JSON summary holds besides them.
#[pyclass(module = "feedscope", frozen)]
pub struct EstimateResult {
    /// The strokes in time order.
    #[pyo3(get)]
    strokes: Vec<Py<Stroke>>,
    /// The summary (`feedscope estimate`'s JSON summary), with the strokes' summaries.
    report: EstimateReport,
    effort_kind: EffortKind,
}

#[pymethods]
impl EstimateResult {
    /// `"current_a"` or `"torque_nm"`.
    #[getter]
    fn effort_kind(&self) -> &'static str {
        self.effort_kind.column()
    }
    /// What the recording supports over all its strokes (dict: `support`, `friction_sign`,
    /// `reasons`, ...).
    #[getter]
    fn verdict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.verdict)
    }
    /// Every move of the axis with its kind (list of dicts).
    #[getter]
    fn moves<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.moves)
    }
    /// Dwell and reversal zones between the strokes (list of dicts).
    #[getter]
    fn zones<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.zones)
    }
    /// Notes of the move classification: a list of dicts `{"code", "message"}`.
    #[getter]
    fn notes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.notes)
    }
    /// Strokes found but not estimated, with the reason (list of str).
    #[getter]
    fn skipped<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.skipped)
    }

    /// The binary's JSON summary (`OUT.json` of `feedscope estimate`) as a dict: the same keys
    /// and numbers; `source` is the trace's file (or `"arrays"`).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }

    /// The friction CSV's rows as a pandas DataFrame (columns `stroke`, `direction`,
    /// `position_mm`, `time_s`, `velocity_mm_s`, `accel_mm_s2`, `current_a`|`torque_nm`,
    /// `friction_n`). Needs pandas, which feedscope does not otherwise require.
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let pd = py
            .import("pandas")
            .map_err(|_| PyImportError::new_err("to_pandas() needs pandas: pip install pandas"))?;
        let np = py.import("numpy")?;
        let cols = PyDict::new(py);
        let n = |s: &Stroke| s.summary.points;
        let stroke_col: Vec<usize> = self
            .strokes
            .iter()
            .flat_map(|s| std::iter::repeat_n(s.get().summary.stroke, n(s.get())))
            .collect();
        let dir_col: Vec<&str> = self
            .strokes
            .iter()
            .flat_map(|s| std::iter::repeat_n(s.get().direction_str(), n(s.get())))
            .collect();
        cols.set_item("stroke", stroke_col)?;
        cols.set_item("direction", dir_col)?;
        let concat = |f: &dyn Fn(&Stroke) -> &Py<PyArray1<f64>>| -> PyResult<Bound<'py, PyAny>> {
            let parts: Vec<Bound<'py, PyAny>> = self
                .strokes
                .iter()
                .map(|s| f(s.get()).bind(py).clone().into_any())
                .collect();
            if parts.is_empty() {
                np.call_method1("zeros", (0,))
            } else {
                np.call_method1("concatenate", (parts,))
            }
        };
        cols.set_item("position_mm", concat(&|s| &s.position_mm)?)?;
        cols.set_item("time_s", concat(&|s| &s.time_s)?)?;
        cols.set_item("velocity_mm_s", concat(&|s| &s.velocity_mm_s)?)?;
        cols.set_item("accel_mm_s2", concat(&|s| &s.accel_mm_s2)?)?;
        cols.set_item(self.effort_kind.column(), concat(&|s| &s.effort)?)?;
        cols.set_item("friction_n", concat(&|s| &s.friction_n)?)?;
        pd.call_method1("DataFrame", (cols,))
    }

    fn __len__(&self) -> usize {
        self.strokes.len()
    }

    fn __repr__(&self) -> String {
        let head = self.report.verdict.support.as_str();
        let lines: Vec<String> = self
            .strokes
            .iter()
            .take(8)
            .map(|s| format!("  {}", s.get().__repr__()))
            .collect();
        let more = if self.strokes.len() > 8 {
            format!("\n  ... {} more", self.strokes.len() - 8)
        } else {
            String::new()
        };
        format!(
            "EstimateResult({} strokes, {}, data support: {head}\n{}{more})",
            self.strokes.len(),
            self.effort_kind.column(),
            lines.join("\n")
        )
    }
}

/// Estimate friction along the travel for every measuring stroke of a trace (paper 000,
/// Section 3, Eq. 5), as `feedscope estimate TRACE --axis AXIS` with the same keywords as its
/// options: `samples_per_lead` (points per lead, default 1024), `end_condition`
/// (`"not-a-knot"` or `"natural"`), `time_of_position` (`"invert"` or `"knot-spline"`),
/// `position_cutoff_hz` (`"auto"`, `"off"` or Hz), `include_rapids`, `effort_sign` (`"auto"`,
/// `"signed"`, `"magnitude"`, `"negated"`), `program` (the NC program file that made the trace) and
/// `program_axis` (its axis letter). Each `Stroke` of the result holds numpy arrays on the
/// resampling grid: `position_mm` (mm), `time_s` (s), `velocity_mm_s` (mm/s), `accel_mm_s2`
/// (mm/s²), `current_a` (A) or `torque_nm` (N·m), `friction_n` (N, signed as Eq. 5). The GIL
/// is released while estimating.
#[pyfunction]
#[pyo3(signature = (trace, axis, *, samples_per_lead=1024, end_condition="not-a-knot",
                    time_of_position="invert", position_cutoff_hz=None, include_rapids=false,
                    effort_sign="auto", program=None, program_axis='Z'))]
#[allow(clippy::too_many_arguments)]
pub fn estimate(
    py: Python<'_>,
    trace: &Bound<'_, Trace>,
    axis: &Axis,
    samples_per_lead: u32,
    end_condition: &str,
    time_of_position: &str,
    position_cutoff_hz: Option<&Bound<'_, PyAny>>,
    include_rapids: bool,
    effort_sign: &str,
    program: Option<PathBuf>,
    program_axis: char,
) -> PyResult<EstimateResult> {
    let options = EstimateOptions {
        samples_per_lead,
        end_condition: word(
            "end_condition",
            end_condition,
            &[
                ("not-a-knot", EndCondition::NotAKnot),
                ("natural", EndCondition::Natural),
            ],
        )?,
        time_of_position: word(
            "time_of_position",
            time_of_position,
            &[
                ("invert", TimeOfPosition::Invert),
                ("knot-spline", TimeOfPosition::KnotSpline),
            ],
        )?,
        position_cutoff_hz: cutoff(position_cutoff_hz)?,
        include_rapids,
        effort_sign: word(
            "effort_sign",
            effort_sign,
            &[
                ("auto", EffortSign::Auto),
                ("signed", EffortSign::Signed),
                ("magnitude", EffortSign::Magnitude),
                ("negated", EffortSign::Negated),
            ],
        )?,
        program,
        program_axis,
        ..EstimateOptions::default()
    };
    let t = trace.get();
    let recording = Recording::borrowed(&t.inner, t.source.clone(), t.report.clone());
    let a = &axis.inner;
    let est = py
        .detach(|| estimate_recording(&recording, a, &options, &Keywords))
        .map_err(py_err)?;
    let kind = est.report.effort;
    let strokes = est
        .strokes
        .into_iter()
        .map(|s| Py::new(py, Stroke::from_friction(py, s, kind)?))
        .collect::<PyResult<Vec<_>>>()?;
    Ok(EstimateResult {
        strokes,
        report: est.report,
        effort_kind: kind,
    })
}
