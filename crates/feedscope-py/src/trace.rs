//! `feedscope.Trace` and `feedscope.read_trace`: a controller trace from a file or from numpy
//! arrays.
use std::path::PathBuf;

use feedscope::trace::{
    glitch::remove_samples, screen_position, Channel, EffortKind, GlitchParams, Trace as Inner,
    MIN_SAMPLES,
};
use feedscope::units::feed_m_s_to_mm_min;
use feedscope_app::estimate::DroppedPosition;
use feedscope_io::trace::{read_trace_file_with, ReadOptions, ReadReport, TraceError};
use numpy::PyArray1;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::axis::Axis;
use crate::convert::{f64_vec, readonly, to_py};
use crate::errors::{bad_input, py_err};
use feedscope_app::AppError;

/// A trace of one axis: position and effort (motor current or torque), each channel with its
/// own time stamps. Build it from 1-D float64 numpy arrays, or read it with `read_trace`.
///
/// `Trace(time_s=t, position_mm=z, current_a=i)` for synchronous channels; channels with their
/// own clocks take `position_time_s=` and `effort_time_s=` instead of (or overriding) `time_s`.
/// Exactly one of `current_a` (A) and `torque_nm` (N·m) is given. The arrays are copied once
/// into the library's trace (positions converted to metres); they are checked as a trace file
/// is: equal lengths per channel, at least 4 samples, finite values, strictly increasing times,
/// motion, and position glitches screened at 200 m/min (isolated samples dropped with a
/// warning in `warnings`, a jump that does not come back refused).
#[pyclass(module = "feedscope", frozen)]
pub struct Trace {
    /// The library's trace (SI units).
    pub inner: Inner,
    /// What the reader reported, for a trace read from a file.
    pub report: ReadReport,
    /// The file it was read from, or `arrays`.
    pub source: String,
}

/// `effort=` of `read_trace`: the CLI's `--effort` values, or the channel names.
fn effort_arg(effort: Option<&str>) -> PyResult<Option<EffortKind>> {
    match effort {
        None => Ok(None),
        Some("current" | "current_a") => Ok(Some(EffortKind::CurrentA)),
        Some("torque" | "torque_nm") => Ok(Some(EffortKind::TorqueNm)),
        Some(other) => Err(PyValueError::new_err(format!(
            "effort must be \"current\" or \"torque\", not {other:?}"
        ))),
    }
}

/// Read a trace file (CSV in the long or wide layout, or Parquet), as `feedscope estimate`
/// reads its TRACE argument: same checks, same messages (`BadInputError` naming the file and
/// line), position glitches screened at 200 m/min, or at 1.25 × the axis' `rapid_rate_mm_min`
/// and within its travel when `axis` is given (as every subcommand with `--axis` does).
/// `effort="current"` or `"torque"` chooses the channel of a file that holds both.
#[pyfunction]
#[pyo3(signature = (path, axis=None, effort=None))]
pub fn read_trace(
    py: Python<'_>,
    path: PathBuf,
    axis: Option<&Axis>,
    effort: Option<&str>,
) -> PyResult<Trace> {
    let effort = effort_arg(effort)?;
    let glitch = axis.map_or_else(GlitchParams::default, |a| GlitchParams::for_axis(&a.inner));
    let opts = ReadOptions { effort, threads: 0 };
    let read = py.detach(|| read_trace_file_with(&path, &opts, &glitch));
    let (inner, report) = read.map_err(|e| effort_error(e, effort))?;
    Ok(Trace {
        inner,
        report,
        source: path.display().to_string(),
    })
}

/// A reader's error restated for `effort=`, as the CLI restates it for `--effort`.
fn effort_error(e: TraceError, asked: Option<EffortKind>) -> PyErr {
    match (e, asked) {
        (TraceError::AmbiguousEffort { source_name }, _) => bad_input(format!(
            "{source_name}: both `current_a` and `torque_nm` are present; choose one with \
             effort=\"current\" or effort=\"torque\""
        )),
        (e @ TraceError::MissingChannel { .. }, Some(k)) => {
            let name = match k {
                EffortKind::CurrentA => "current",
                EffortKind::TorqueNm => "torque",
            };
            let is_effort =
                matches!(&e, TraceError::MissingChannel { channel, .. } if channel == k.column());
            if is_effort {
                py_err(anyhow::Error::new(e).context(format!("effort=\"{name}\"")))
            } else {
                py_err(e)
            }
        }
        (e, _) => py_err(e),
    }
}

/// One channel from arrays: equal lengths, finite values, strictly increasing times.
fn channel(
    time_name: &str,
    time_s: Vec<f64>,
    value_name: &str,
    value: Vec<f64>,
    scale: Option<f64>,
) -> PyResult<Channel> {
    if time_s.len() != value.len() {
        return Err(bad_input(format!(
            "{value_name} has {} samples but its times {time_name} have {}; they must be of \
             equal length",
            value.len(),
            time_s.len()
        )));
    }
    for (name, v) in [(time_name, &time_s), (value_name, &value)] {
        if let Some(k) = v.iter().position(|x| !x.is_finite()) {
            return Err(bad_input(format!(
                "{name}[{k}] is {}: every sample must be finite (drop or fill the gap)",
                v[k]
            )));
        }
    }
    if let Some(k) = time_s.windows(2).position(|w| w[1] <= w[0]) {
        return Err(bad_input(format!(
            "{time_name}[{}] = {} s does not come after {time_name}[{k}] = {} s (time must \
             strictly increase within a channel)",
            k + 1,
            time_s[k + 1],
            time_s[k]
        )));
    }
    if time_s.len() < MIN_SAMPLES {
        return Err(bad_input(format!(
            "{value_name} has {} samples, at least {MIN_SAMPLES} are needed",
            time_s.len()
        )));
    }
    let value = match scale {
        None => value,
        Some(f) => value.into_iter().map(|x| x * f).collect(),
    };
    Ok(Channel { time_s, value })
}

/// An optional array argument.
fn opt_vec(name: &str, obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<f64>>> {
    match obj {
        Some(o) if !o.is_none() => Ok(Some(f64_vec(name, o)?)),
        _ => Ok(None),
    }
}

#[pymethods]
impl Trace {
    #[new]
    #[pyo3(signature = (*, time_s=None, position_mm=None, current_a=None, torque_nm=None,
                        position_time_s=None, effort_time_s=None))]
    fn new(
        py: Python<'_>,
        time_s: Option<&Bound<'_, PyAny>>,
        position_mm: Option<&Bound<'_, PyAny>>,
        current_a: Option<&Bound<'_, PyAny>>,
        torque_nm: Option<&Bound<'_, PyAny>>,
        position_time_s: Option<&Bound<'_, PyAny>>,
        effort_time_s: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let time = opt_vec("time_s", time_s)?;
        let position = opt_vec("position_mm", position_mm)?
            .ok_or_else(|| PyTypeError::new_err("Trace needs position_mm= (mm)"))?;
        let (effort_name, effort_kind, effort) = match (
            opt_vec("current_a", current_a)?,
            opt_vec("torque_nm", torque_nm)?,
        ) {
            (Some(i), None) => ("current_a", EffortKind::CurrentA, i),
            (None, Some(t)) => ("torque_nm", EffortKind::TorqueNm, t),
            (Some(_), Some(_)) => {
                return Err(PyTypeError::new_err(
                    "give one effort channel: current_a= (A) or torque_nm= (N·m), not both",
                ))
            }
            (None, None) => {
                return Err(PyTypeError::new_err(
                    "Trace needs an effort channel: current_a= (A) or torque_nm= (N·m)",
                ))
            }
        };
        let pick = |own: Option<Vec<f64>>, own_name: &'static str| match (own, &time) {
            (Some(t), _) => Ok((own_name, t)),
            (None, Some(t)) => Ok(("time_s", t.clone())),
            (None, None) => Err(PyTypeError::new_err(format!(
                "Trace needs time stamps (s): time_s= for both channels, or {own_name}="
            ))),
        };
        let (pt_name, pt) = pick(
            opt_vec("position_time_s", position_time_s)?,
            "position_time_s",
        )?;
        let (et_name, et) = pick(opt_vec("effort_time_s", effort_time_s)?, "effort_time_s")?;
        drop(time);
        let position_m = channel(pt_name, pt, "position_mm", position, Some(1e-3))?;
        let effort = channel(et_name, et, effort_name, effort, None)?;
        let (inner, report) = py.detach(|| screen(position_m, effort, effort_kind))?;
        Ok(Self {
            inner,
            report,
            source: "arrays".into(),
        })
    }

    /// What the effort channel is: `"current_a"` (A) or `"torque_nm"` (N·m).
    #[getter]
    fn effort_kind(&self) -> &'static str {
        self.inner.effort_kind.column()
    }

    /// Position sample times (s), a copy.
    #[getter]
    fn position_time_s<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        ro(py, &self.inner.position_m.time_s, None)
    }

    /// Positions (mm), a copy.
    #[getter]
    fn position_mm<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        ro(py, &self.inner.position_m.value, Some(1e3))
    }

    /// Effort sample times (s), a copy.
    #[getter]
    fn effort_time_s<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        ro(py, &self.inner.effort.time_s, None)
    }

    /// Effort values: current (A) or torque (N·m) as `effort_kind` says, a copy.
    #[getter]
    fn effort<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        ro(py, &self.inner.effort.value, None)
    }

    /// Motor current (A), or None for a torque trace.
    #[getter]
    fn current_a<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<f64>>>> {
        (self.inner.effort_kind == EffortKind::CurrentA)
            .then(|| self.effort(py))
            .transpose()
    }

    /// Motor torque (N·m), or None for a current trace.
    #[getter]
    fn torque_nm<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<f64>>>> {
        (self.inner.effort_kind == EffortKind::TorqueNm)
            .then(|| self.effort(py))
            .transpose()
    }

    /// The file read, or `"arrays"`.
    #[getter]
    fn source(&self) -> &str {
        &self.source
    }

    /// What the reader warns about (glitches dropped, a cut last line): a list of dicts
    /// `{"code", "message"}` (codes in docs/diagnostics.md), the serde form of the reader's
    /// diagnostics, as a report's `warnings` hold them; empty for a clean trace.
    #[getter]
    fn warnings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.diagnostics())
    }

    /// Position samples dropped as logger glitches: dicts of `time_s`, `position_mm` and the
    /// file's `line` (CSV) or `row` (Parquet).
    #[getter]
    fn dropped_position<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let dropped: Vec<DroppedPosition> = self
            .report
            .dropped_position
            .iter()
            .map(Into::into)
            .collect();
        to_py(py, &dropped)
    }

    /// What the recording's source declared (`# fact` lines): effort_quantum, effort_signed,
    /// process_load, recordings.
    #[getter]
    fn facts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.inner.facts)
    }

    /// Write the trace to a file as `feedscope simulate` writes its trace: CSV (6 decimals:
    /// 1 µs, 1 nm, 1 µA or 1 µN·m), or Parquet at full precision when the name ends in
    /// `.parquet`; `layout` `"long"` (`time_s,channel,value`) or `"wide"` (one row per time;
    /// both channels on the same time stamps only).
    #[pyo3(signature = (path, layout="long"))]
    fn write(&self, py: Python<'_>, path: PathBuf, layout: &str) -> PyResult<()> {
        use feedscope_io::trace::{write_csv, write_parquet, Layout};
        let layout = match layout {
            "long" => Layout::Long,
            "wide" => Layout::Wide,
            other => {
                return Err(PyValueError::new_err(format!(
                    "layout must be \"long\" or \"wide\", not {other:?}"
                )))
            }
        };
        if layout == Layout::Wide && self.inner.position_m.time_s != self.inner.effort.time_s {
            return Err(bad_input(
                "layout=\"wide\" needs both channels on the same time stamps; use \"long\"",
            ));
        }
        let parquet = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("parquet"));
        let result = py.detach(|| -> anyhow::Result<()> {
            let file = std::fs::File::create(&path).map_err(|e| {
                anyhow::Error::new(e).context(format!("creating {}", path.display()))
            })?;
            if parquet {
                write_parquet(&self.inner, file, layout)?;
            } else {
                write_csv(&self.inner, file, layout)?;
            }
            Ok(())
        });
        result.map_err(|e| crate::errors::to_py(e.context(format!("writing {}", path.display()))))
    }

    /// The trace as a dict of arrays (SI time, mm, A or N·m) and its facts.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("source", &self.source)?;
        d.set_item("effort_kind", self.effort_kind())?;
        d.set_item("position_time_s", self.position_time_s(py)?)?;
        d.set_item("position_mm", self.position_mm(py)?)?;
        d.set_item("effort_time_s", self.effort_time_s(py)?)?;
        d.set_item(self.effort_kind(), self.effort(py)?)?;
        d.set_item("facts", self.facts(py)?)?;
        d.set_item("warnings", self.warnings(py)?)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let p = &self.inner.position_m;
        let e = &self.inner.effort;
        let (lo, hi) = p
            .value
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        format!(
            "Trace(source={:?}, position: {} samples, {:.3} to {:.3} s, {:.3} to {:.3} mm; \
             {}: {} samples, {:.3} to {:.3} s)",
            self.source,
            p.len(),
            p.time_s.first().copied().unwrap_or(f64::NAN),
            p.time_s.last().copied().unwrap_or(f64::NAN),
            lo * 1e3,
            hi * 1e3,
            self.inner.effort_kind.column(),
            e.len(),
            e.time_s.first().copied().unwrap_or(f64::NAN),
            e.time_s.last().copied().unwrap_or(f64::NAN),
        )
    }
}

/// A read-only copy of `v`, scaled by `factor` when given.
fn ro<'py>(py: Python<'py>, v: &[f64], factor: Option<f64>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let a = match factor {
        None => PyArray1::from_slice(py, v),
        Some(f) => PyArray1::from_iter(py, v.iter().map(|x| x * f)),
    };
    readonly(&a)?;
    Ok(a)
}

/// The checks the file readers end with, for arrays: motion, and the position glitch screen
/// at the default limit (isolated glitches dropped and reported, a lasting jump refused).
fn screen(
    mut position_m: Channel,
    effort: Channel,
    effort_kind: EffortKind,
) -> PyResult<(Inner, ReadReport)> {
    let motion = |p: &Channel| -> Result<(), AppError> {
        let (lo, hi) = p
            .value
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        // Below a nanometre nothing measurable moved (as the file readers).
        if hi - lo <= 1e-9 {
            return Err(AppError::bad_input(format!(
                "the position never moves (it spans only {} mm); friction needs motion",
                (hi - lo) * 1e3
            )));
        }
        Ok(())
    };
    motion(&position_m).map_err(py_err)?;
    let glitch = GlitchParams::default();
    let mut report = ReadReport {
        max_axis_speed_m_s: Some(glitch.max_axis_speed_m_s),
        ..ReadReport::default()
    };
    match screen_position(&position_m, &glitch) {
        Ok(s) => {
            report.dropped_position = s
                .glitches
                .iter()
                .map(|&k| feedscope_io::trace::DroppedSample {
                    time_s: position_m.time_s[k],
                    position_m: position_m.value[k],
                    // Arrays have no lines or rows; the time names the sample.
                    line: None,
                    row: None,
                })
                .collect();
            remove_samples(&mut position_m, &s.glitches);
            if position_m.len() < MIN_SAMPLES {
                return Err(bad_input(format!(
                    "position_mm has {} samples once glitches are dropped, at least \
                     {MIN_SAMPLES} are needed",
                    position_m.len()
                )));
            }
            motion(&position_m).map_err(py_err)?;
        }
        Err(j) => {
            return Err(bad_input(format!(
                "position_mm[{}]: the position jumps by {} mm between t = {} s and t = {} s, \
                 implying {:.0} mm/min, above the limit of {:.0} mm/min, and does not come \
                 back (re-homed, or two recordings joined?); split the trace at the jump",
                j.index,
                j.jump_m * 1e3,
                position_m.time_s[j.from_index],
                position_m.time_s[j.index],
                feed_m_s_to_mm_min(j.speed_m_s),
                glitch.max_axis_speed_mm_min()
            )))
        }
    }
    Ok((
        Inner {
            position_m,
            effort,
            effort_kind,
            facts: Default::default(),
        },
        report,
    ))
}
