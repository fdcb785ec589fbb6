//! `feedscope.dynamics`: natural frequencies of the feed drive against feed and nut position,
//! and torque-ripple resonance risks, as `feedscope dynamics --config FILE`.
use std::path::PathBuf;

use feedscope::dynamics::{analyse, DynamicsReport};
use feedscope_app::dynamics::{drive_from_toml, read_drive};
use numpy::PyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{array, to_json, to_py};
use crate::errors::py_err;

/// The modal analysis of a drive: `to_dict()` is the binary's `dynamics.json`; the sweeps as
/// arrays: `feed_mm_min` (mm/min) with `frequency_vs_feed_hz` (Hz, one row per feed, one
/// column per mode), and the headline numbers as attributes.
#[pyclass(module = "feedscope", frozen)]
pub struct DynamicsResult {
    report: DynamicsReport,
}

#[pymethods]
impl DynamicsResult {
    /// First natural frequency at rest (Hz).
    #[getter]
    fn static_first_hz(&self) -> f64 {
        self.report.static_first_hz
    }
    /// First natural frequency just after breakaway, v = 0+ (Hz).
    #[getter]
    fn breakaway_first_hz(&self) -> f64 {
        self.report.breakaway_first_hz
    }
    /// Highest first natural frequency over the feed sweep (Hz).
    #[getter]
    fn peak_first_hz(&self) -> f64 {
        self.report.peak_first_hz
    }
    /// Feed of that peak (mm/min).
    #[getter]
    fn peak_feed_mm_min(&self) -> f64 {
        self.report.peak_feed_mm_min
    }
    /// Where a bearing unloads, if it does in the sweep (dict), else None.
    #[getter]
    fn bearing_unload<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.bearing_unload)
    }
    /// Torque-ripple resonance risks (list of dicts: harmonic, feed_mm_min, frequency_hz,
    /// mode, margin_hz, order, feed_low_mm_min, feed_high_mm_min).
    #[getter]
    fn resonances<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.resonances)
    }
    /// Feeds of the feed sweep (mm/min).
    #[getter]
    fn feed_mm_min<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v: Vec<f64> = self
            .report
            .feed_sweep
            .points
            .iter()
            .map(|p| p.feed_mm_min)
            .collect();
        Ok(array(py, v)?.into_any())
    }
    /// Natural frequencies over the feed sweep (Hz): one row per feed, one column per mode.
    #[getter]
    fn frequency_vs_feed_hz<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let rows: Vec<Vec<f64>> = self
            .report
            .feed_sweep
            .points
            .iter()
            .map(|p| p.frequencies_hz.clone())
            .collect();
        PyArray2::from_vec2(py, &rows)
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))
    }
    /// The binary's `dynamics.json` as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }
    fn __repr__(&self) -> String {
        let r = &self.report;
        format!(
            "DynamicsResult({}: first frequency {:.2} Hz static, {:.2} Hz after breakaway, \
             peak {:.2} Hz at {:.2} m/min; {} resonance risk(s){})",
            r.name.as_deref().unwrap_or("feed drive"),
            r.static_first_hz,
            r.breakaway_first_hz,
            r.peak_first_hz,
            r.peak_feed_mm_min / 1000.0,
            r.resonances.len(),
            r.bearing_unload.as_ref().map_or(String::new(), |u| format!(
                "; {} bearing unloads at {:.2} m/min",
                u.bearing,
                u.feed_mm_min / 1000.0
            ))
        )
    }
}

/// Natural frequencies of the ball-screw feed drive against feed rate and nut position, and
/// where the motor's torque ripple meets them, as `feedscope dynamics --config FILE`. `config`
/// is the drive file's path (TOML, units in the keys; see examples/drive.toml) or a dict with
/// its keys. The GIL is released during the modal analysis.
#[pyfunction]
pub fn dynamics(py: Python<'_>, config: &Bound<'_, PyAny>) -> PyResult<DynamicsResult> {
    // The app's reading of a drive, with the CLI's messages: the file named (and its size
    // bounded), or `drive config` for a dict.
    let model = if config.is_instance_of::<PyDict>() {
        let json = to_json(config)?;
        let value: toml::Value = serde_json::from_str(&json).map_err(py_err)?;
        let text = toml::to_string(&value).map_err(py_err)?;
        drive_from_toml(&text, "drive config", "drive config").map_err(py_err)?
    } else {
        let path: PathBuf = config.extract()?;
        read_drive(&path).map_err(py_err)?
    };
    let report = py
        .detach(|| analyse(&model))
        .map_err(|e| py_err(anyhow::Error::new(e).context("modal analysis failed")))?;
    Ok(DynamicsResult { report })
}
