//! `feedscope.fit_stribeck`: Stribeck curves from a steady-speed table (paper 000 Eq. 9, paper
//! 001 Eq. 15), as `feedscope fit-stribeck` (its `stribeck.json`, without `--export`).
use std::path::PathBuf;

use feedscope::estimate::Direction;
use feedscope::stribeck::{
    detect_nonconventional, DeltaMode, NonConventionalParams, ParamEstimate, StribeckFitParams,
    StribeckFitter, M_S_PER_MM_MIN,
};
use feedscope_io::stribeck_table::{self, SpeedPoints, TableOptions};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyFloat, PyInt, PyString};
use serde_json::{json, Value};

use crate::axis::Axis;
use crate::convert::{f64_vec, to_py};
use crate::errors::{bad_input, py_err};

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
fn est(e: &ParamEstimate, scale: f64) -> Value {
    json!({
        "value": e.value * scale,
        "std_error": e.std_error * scale,
        "ci95": [e.ci95_low * scale, e.ci95_high * scale],
    })
}

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
    if let Some(s) = noise_n {
        if !(s.is_finite() && s >= 0.0) {
            return Err(bad_input(format!("noise_n must be >= 0, got {s}")));
        }
    }
    // One lead: the axis's, or lead_mm, and they must agree when both are given (as the CLI).
    let lead_mm = match (axis, lead_mm) {
        (Some(a), Some(l)) if (a.inner.lead_mm - l).abs() > 1e-9 * a.inner.lead_mm.abs() => {
            return Err(bad_input(format!(
                "lead_mm {l} disagrees with lead_mm = {} of the axis",
                a.inner.lead_mm
            )))
        }
        (Some(a), _) => Some(a.inner.lead_mm),
        (None, l) => l,
    };
    let opts = TableOptions {
        lead_mm,
        efficiency,
    };
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
    let fit_params = StribeckFitParams {
        delta,
        ..StribeckFitParams::default()
    };
    if tab.forward.speed_m_s.is_empty() && tab.backward.speed_m_s.is_empty() {
        return Err(bad_input(format!("{name}: no data rows")));
    }
    let nc_params = NonConventionalParams {
        noise_n,
        ..NonConventionalParams::default()
    };
    let directions = py.detach(|| -> Result<Vec<Value>, String> {
        let mut out = Vec::new();
        for (dir, pts) in [
            (Direction::Forward, &tab.forward),
            (Direction::Backward, &tab.backward),
        ] {
            if pts.speed_m_s.is_empty() {
                continue;
            }
            out.push(fit_direction(dir, pts, &fit_params, &nc_params, &name)?);
        }
        Ok(out)
    });
    let directions = directions.map_err(bad_input)?;
    let report = json!({
        "source": name,
        "input": tab.effort,
        "lead_mm": lead_mm,
        "efficiency": efficiency,
        "delta": match delta {
            DeltaMode::Free => "free".to_string(),
            DeltaMode::Fixed(d) => format!("{d}"),
        },
        "directions": directions,
    });
    Ok(StribeckResult { report })
}

/// The fit of one direction as the CLI's `direction_fit` reports it; errors in its words.
fn fit_direction(
    dir: Direction,
    pts: &SpeedPoints,
    fit_params: &StribeckFitParams,
    nc_params: &NonConventionalParams,
    name: &str,
) -> Result<Value, String> {
    let fitter = StribeckFitter::new(&pts.speed_m_s, fit_params)
        .map_err(|e| format!("{name}: {} direction: {e}", dir.as_str()))?;
    if let [one] = fitter.distinct_speeds_m_s() {
        return Err(format!(
            "{name}: the {} direction has 1 distinct feed ({} mm/min, {} rows); a friction \
             curve needs at least 2 (Coulomb + viscous), a Stribeck curve at least 4 (5 with \
             --delta free): measure at more feeds",
            dir.as_str(),
            one / M_S_PER_MM_MIN,
            pts.speed_m_s.len()
        ));
    }
    let fit = fitter
        .fit(&pts.friction_n)
        .map_err(|e| format!("{name}: {} direction: {e}", dir.as_str()))?;
    let nc = detect_nonconventional(&pts.speed_m_s, &pts.friction_n, &fit, nc_params)
        .map_err(|e| format!("{name}: {} direction: {e}", dir.as_str()))?;
    let mm = 1.0 / M_S_PER_MM_MIN;
    let p = &fit.params;
    let mut data: Vec<(f64, f64, f64)> = pts
        .speed_m_s
        .iter()
        .zip(&pts.friction_n)
        .map(|(&v, &f)| (v * mm, f, p.magnitude_n(v)))
        .collect();
    data.sort_by(|a, b| a.0.total_cmp(&b.0));
    let note = |code: &str, message: String| json!({"code": code, "message": message});
    Ok(json!({
        "direction": dir.as_str(),
        "model": fit.model.code(),
        "reductions": fit.reductions.iter().map(|r| note(r.code(), r.to_string())).collect::<Vec<_>>(),
        "points": fit.points,
        "feed_min_mm_min": fit.min_speed_m_s * mm,
        "feed_max_mm_min": fit.max_speed_m_s * mm,
        "params": {
            "fc_n": p.fc_n,
            "fs_n": fit.fs_n(),
            "vs_mm_min": fit.vs_m_s().map(|v| v * mm),
            "sigma_n_s_per_m": fit.sigma_n_s_per_m(),
            "delta": fit.delta(),
        },
        "uncertainty": fit.uncertainty.as_ref().map(|u| json!({
            "fc_n": est(&u.fc_n, 1.0),
            "fs_n": u.fs_n.as_ref().map(|e| est(e, 1.0)),
            "static_excess_n": u.static_excess_n.as_ref().map(|e| est(e, 1.0)),
            "vs_mm_min": u.vs_m_s.as_ref().map(|e| est(e, mm)),
            "sigma_n_s_per_m": u.sigma_n_s_per_m.as_ref().map(|e| est(e, 1.0)),
            "delta": u.delta.as_ref().map(|d| est(d, 1.0)),
        })),
        "residual_rms_n": fit.residual_rms_n,
        "dof": fit.dof,
        "iterations": fit.iterations,
        "termination": fit.termination,
        "condition_number": fit.condition_number,
        "warnings": fit.warnings.iter().map(|w| note(w.code(), w.to_string())).collect::<Vec<_>>(),
        "nonconventional": {
            "noise_n": nc.noise_n,
            "threshold_n": nc.threshold_n,
            "rising_above_mm_min": nc.rising_above_m_s * mm,
            "ranges": nc.ranges.iter().map(|r| json!({
                "from_mm_min": r.from_mm_min(),
                "to_mm_min": r.to_mm_min(),
                "points": r.points,
                "drop_n": r.drop_n,
                "fit_change_n": r.fit_change_n,
                "excess_drop_n": r.excess_drop_n,
            })).collect::<Vec<_>>(),
        },
        "data": data.iter().map(|(f, fr, fit)| json!({
            "feed_mm_min": f, "friction_n": fr, "fitted_n": fit,
        })).collect::<Vec<_>>(),
    }))
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
