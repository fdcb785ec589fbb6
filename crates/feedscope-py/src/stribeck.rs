//! `feedscope.fit_stribeck`: Stribeck curves from a steady-speed table (paper 000 Eq. 9, paper
//! 001 Eq. 15), as `feedscope fit-stribeck` (its `stribeck.json`, without `--export`).
use std::path::PathBuf;

use feedscope::stribeck::DeltaMode;
use feedscope_app::stribeck::{fit_table, FitStribeckOptions};
use feedscope_io::stribeck_table;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyFloat, PyInt, PyString};
use serde_json::Value;

use crate::axis::Axis;
use crate::convert::{f64_vec, to_py};
use crate::errors::{bad_input, py_err};
use crate::front::Keywords;

/// The Stribeck fits of a table: `directions` (one dict per direction fitted: `model`,
/// `params` in user units — `fc_n` (N), `fs_n` (N), `vs_mm_min` (mm/min), `sigma_n_s_per_m`
/// (N·s/m), `delta` — `uncertainty` (standard errors and 95 % intervals), `residual_rms_n`,
/// `warnings`, `reductions`, `nonconventional`, `data`); `to_dict()` is the binary's
/// `stribeck.json`.
#[pyclass(module = "feedscope", frozen)]
pub struct StribeckResult {
    report: Value,
}

#[pymethods]
impl StribeckResult {
    /// One dict per direction fitted (forward first).
    #[getter]
    fn directions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["directions"])
    }
    /// The fit of one direction (`"forward"` or `"backward"`), or None when the table has no
    /// rows of it.
    fn direction<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let found = self.report["directions"]
            .as_array()
            .and_then(|ds| ds.iter().find(|d| d["direction"] == name))
            .cloned()
            .unwrap_or(Value::Null);
        to_py(py, &found)
    }
    /// The binary's `stribeck.json` as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }
    fn __repr__(&self) -> String {
        let mut parts = Vec::new();
        for d in self.report["directions"].as_array().into_iter().flatten() {
            let p = &d["params"];
            let f = |k: &str| p[k].as_f64().map_or("-".into(), |v| format!("{v:.2}"));
            parts.push(format!(
                "  {}: {} model, Fc {} N, Fs {} N, vs {} mm/min, sigma {} N·s/m, delta {}, rms \
                 {:.3} N over {} points",
                d["direction"].as_str().unwrap_or("-"),
                d["model"].as_str().unwrap_or("-"),
                f("fc_n"),
                f("fs_n"),
                f("vs_mm_min"),
                f("sigma_n_s_per_m"),
                f("delta"),
                d["residual_rms_n"].as_f64().unwrap_or(f64::NAN),
                d["points"]
            ));
        }
        format!("StribeckResult(\n{}\n)", parts.join("\n"))
    }
}

/// `delta=`: a positive number or `"free"`.
fn delta_arg(obj: &Bound<'_, PyAny>) -> PyResult<DeltaMode> {
    if let Ok(s) = obj.cast::<PyString>() {
        let s = s.to_cow()?;
        if s.eq_ignore_ascii_case("free") {
            return Ok(DeltaMode::Free);
        }
        return Err(bad_input(format!(
            "delta: expected a positive number or `free`, got `{s}`"
        )));
    }
    if obj.cast::<PyFloat>().is_ok() || obj.cast::<PyInt>().is_ok() {
        let d: f64 = obj.extract()?;
        if d.is_finite() && d > 0.0 {
            return Ok(DeltaMode::Fixed(d));
        }
        return Err(bad_input(format!(
            "delta: expected a positive number or `free`, got `{d}`"
        )));
    }
    Err(PyTypeError::new_err("delta must be a number or \"free\""))
}

/// A parameter estimate in user units, as the CLI's `est`.
/// Fit Stribeck curves F(v) = Fc + (Fs − Fc)·exp(−(|v|/vs)^δ) + σ·|v| to a steady-speed table,
/// each direction on its own, as `feedscope fit-stribeck TABLE`.
///
/// The table is a CSV file (`table`, with `feed_mm_min`, one of `torque_nm` or `force_n`, and
/// optionally `direction`), or arrays: `feed_mm_min` (mm/min, signed unless `direction` is
/// given), `force_n` (N) or `torque_nm` (N·m, converted by Eq. 15 with the lead and
/// `efficiency`), `direction` (a list of `"forward"`/`"backward"`). The arrays go through the
/// table's parser (written with round-trip precision), so they meet its checks; its messages
/// name `arrays` and a line, line k + 2 being element k. `lead_mm` (mm) or `axis` gives the
/// lead; `delta` is the shape exponent (a number, or `"free"` to fit it); `noise_n` (N) the
/// noise of one value for the non-conventional check (default: from the residuals).
#[pyfunction]
#[pyo3(signature = (table=None, *, feed_mm_min=None, force_n=None, torque_nm=None,
                    direction=None, lead_mm=None, axis=None, efficiency=1.0, delta=None,
                    noise_n=None))]
#[allow(clippy::too_many_arguments)]
pub fn fit_stribeck(
    py: Python<'_>,
    table: Option<PathBuf>,
    feed_mm_min: Option<&Bound<'_, PyAny>>,
    force_n: Option<&Bound<'_, PyAny>>,
    torque_nm: Option<&Bound<'_, PyAny>>,
    direction: Option<Vec<String>>,
    lead_mm: Option<f64>,
    axis: Option<&Axis>,
    efficiency: f64,
    delta: Option<&Bound<'_, PyAny>>,
    noise_n: Option<f64>,
) -> PyResult<StribeckResult> {
    let delta = match delta {
        Some(d) if !d.is_none() => delta_arg(d)?,
        _ => DeltaMode::Fixed(2.0),
    };
    let options = FitStribeckOptions {
        lead_mm,
        efficiency,
        delta,
        noise_n,
    };
    options.validate(&Keywords).map_err(py_err)?;
    // One lead: the axis's, or lead_mm, and they must agree when both are given (as the CLI).
    let lead_mm = options
        .lead_mm(axis.map(|a| (&a.inner, "the axis")), &Keywords)
        .map_err(py_err)?;
    let opts = options.table_options(lead_mm);
    let (tab, name) = match (table, feed_mm_min) {
        (Some(path), None) => {
            let name = path.display().to_string();
            (stribeck_table::read(&path, &opts).map_err(py_err)?, name)
        }
        (None, Some(feed)) => {
            let text = table_text(feed, force_n, torque_nm, direction.as_deref())?;
            (
                stribeck_table::parse(&text, "arrays", &opts).map_err(py_err)?,
                "arrays".to_string(),
            )
        }
        (Some(_), Some(_)) => {
            return Err(PyTypeError::new_err(
                "give a table file or feed_mm_min= arrays, not both",
            ))
        }
        (None, None) => {
            return Err(PyTypeError::new_err(
                "fit_stribeck needs a table file or feed_mm_min= with force_n= or torque_nm=",
            ))
        }
    };
    let done = py
        .detach(|| fit_table(&tab, &name, lead_mm, &options, &Keywords))
        .map_err(py_err)?;
    let report = serde_json::to_value(&done.report).map_err(py_err)?;
    Ok(StribeckResult { report })
}

/// The arrays as the text of a steady-speed table, every number in Rust's shortest
/// round-trip form so that the parser reads back the same values.
fn table_text(
    feed: &Bound<'_, PyAny>,
    force_n: Option<&Bound<'_, PyAny>>,
    torque_nm: Option<&Bound<'_, PyAny>>,
    direction: Option<&[String]>,
) -> PyResult<String> {
    let feed = f64_vec("feed_mm_min", feed)?;
    let (col, effort) = match (force_n, torque_nm) {
        (Some(f), None) => ("force_n", f64_vec("force_n", f)?),
        (None, Some(t)) => ("torque_nm", f64_vec("torque_nm", t)?),
        _ => {
            return Err(PyTypeError::new_err(
                "give one effort: force_n= (N) or torque_nm= (N·m)",
            ))
        }
    };
    if effort.len() != feed.len() {
        return Err(bad_input(format!(
            "{col} has {} values but feed_mm_min has {}; they must be of equal length",
            effort.len(),
            feed.len()
        )));
    }
    if let Some(d) = direction {
        if d.len() != feed.len() {
            return Err(bad_input(format!(
                "direction has {} values but feed_mm_min has {}; they must be of equal length",
                d.len(),
                feed.len()
            )));
        }
        if let Some(k) = d.iter().position(|s| s.contains([',', '\n', '\r'])) {
            return Err(bad_input(format!(
                "direction[{k}] = {:?} is not a direction",
                d[k]
            )));
        }
    }
    let mut text = format!(
        "feed_mm_min,{col}{}\n",
        if direction.is_some() {
            ",direction"
        } else {
            ""
        }
    );
    for k in 0..feed.len() {
        text.push_str(&format!("{},{}", feed[k], effort[k]));
        if let Some(d) = direction {
            text.push(',');
            text.push_str(&d[k]);
        }
        text.push('\n');
    }
    Ok(text)
}
