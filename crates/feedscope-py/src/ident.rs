//! `feedscope.identify`: Fs, Fc, σ, vs and the inertia J from one triangular-wave test (paper
//! 002), as `feedscope identify` (its `ident.json`).
use feedscope::ident::IdentParams;
use feedscope_app::identify::{identify_recordings, IdentifyOptions};
use feedscope_app::Recording;
use numpy::PyArray1;
use pyo3::prelude::*;
use serde_json::Value;

use crate::axis::Axis;
use crate::convert::{array, readonly_bool, to_py};
use crate::errors::py_err;
use crate::front::Keywords;
use crate::trace::Trace;

/// The result of `identify`: the parameters on the motor side (`motor`: `j_total_kgm2`
/// (kg·m²), `tc_nm`, `ts_nm` (N·m), `vs_mm_min` (mm/min), `sigma_nm_s_per_m` (N·m·s/m),
/// `offset_nm` (N·m), `delta`), their standard errors (`std_error`), the force side
/// (`force`: `fc_n`, `fs_n` (N), `sigma_n_s_per_m` (N·s/m), `equivalent_mass_kg`), the
/// diagnostics, and the kernel-averaged series of the fit as arrays: `time_s` (s),
/// `measured_torque_nm` and `computed_torque_nm` (N·m), `used` (bool). `to_dict()` is the
/// binary's `ident.json`.
#[pyclass(module = "feedscope", frozen)]
pub struct IdentifyResult {
    report: Value,
    /// Times of the kernel averages (s).
    #[pyo3(get)]
    time_s: Py<PyArray1<f64>>,
    /// Kernel-averaged measured motor torque (N·m).
    #[pyo3(get)]
    measured_torque_nm: Py<PyArray1<f64>>,
    /// Torque computed from the fitted model, J·θ'' + T_f(v) (N·m).
    #[pyo3(get)]
    computed_torque_nm: Py<PyArray1<f64>>,
    /// Whether each row was used in the fit.
    #[pyo3(get)]
    used: Py<PyArray1<bool>>,
}

#[pymethods]
impl IdentifyResult {
    /// Motor-side parameters (dict).
    #[getter]
    fn motor<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["motor"])
    }
    /// Their standard errors (dict, same keys).
    #[getter]
    fn std_error<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["std_error"])
    }
    /// Force-side parameters, F = 2π·T/p (dict).
    #[getter]
    fn force<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["force"])
    }
    /// Residual RMS (N·m), condition number, iterations, samples used, vs at a bound.
    #[getter]
    fn diagnostics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["diagnostics"])
    }
    /// Warnings: a list of dicts `{"code", "message"}` (codes in docs/diagnostics.md).
    #[getter]
    fn warnings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["warnings"])
    }
    /// The comparison with the constant-speed groups, when `compare` was given (dict).
    #[getter]
    fn compare<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["compare"])
    }
    /// The binary's `ident.json` as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }
    fn __repr__(&self) -> String {
        let m = &self.report["motor"];
        let f = &self.report["force"];
        let g = |v: &Value, k: &str| v[k].as_f64().unwrap_or(f64::NAN);
        format!(
            "IdentifyResult(J {:.6} kg·m², Tc {:.4} N·m, Ts {:.4} N·m, vs {:.2} mm/min, sigma \
             {:.3} N·m·s/m; force side Fc {:.2} N, Fs {:.2} N; residual {:.4} N·m RMS)",
            g(m, "j_total_kgm2"),
            g(m, "tc_nm"),
            g(m, "ts_nm"),
            g(m, "vs_mm_min"),
            g(m, "sigma_nm_s_per_m"),
            g(f, "fc_n"),
            g(f, "fs_n"),
            g(&self.report["diagnostics"], "residual_rms_nm")
        )
    }
}

/// Identify friction and inertia from one triangular-wave test (paper 002), as `feedscope
/// identify TRACE --axis AXIS`: T = J·θ'' + sgn(v)·[Tc + (Ts − Tc)·exp(−(|v|/vs)^δ)] + σ·v + T0
/// fitted on hat-kernel averages. Keywords as the CLI's options: `kernel_s` (s),
/// `min_speed_mm_min` (mm/min), `guard_s` (s), `delta`, `vs_min_mm_min`, `vs_max_mm_min`
/// (mm/min), `fit_offset`; `compare` (a trace of constant-feed strokes, fitted for
/// comparison). The axis may leave out inertia and damping (`Axis.load(path,
/// for_identification=True)`). The GIL is released while fitting.
#[pyfunction]
#[pyo3(signature = (trace, axis, *, kernel_s=None, min_speed_mm_min=1.0, guard_s=None,
                    delta=2.0, vs_min_mm_min=0.5, vs_max_mm_min=5000.0, fit_offset=true,
                    compare=None))]
#[allow(clippy::too_many_arguments)]
pub fn identify(
    py: Python<'_>,
    trace: &Bound<'_, Trace>,
    axis: &Axis,
    kernel_s: Option<f64>,
    min_speed_mm_min: f64,
    guard_s: Option<f64>,
    delta: f64,
    vs_min_mm_min: f64,
    vs_max_mm_min: f64,
    fit_offset: bool,
    compare: Option<&Bound<'_, Trace>>,
) -> PyResult<IdentifyResult> {
    let options = IdentifyOptions {
        params: IdentParams {
            kernel_half_width_s: kernel_s,
            min_speed_mm_min,
            reversal_guard_s: guard_s,
            delta,
            vs_min_mm_min,
            vs_max_mm_min,
            fit_offset,
            ..IdentParams::default()
        },
    };
    let t = trace.get();
    let test = Recording::borrowed(&t.inner, t.source.clone(), t.report.clone());
    let c = compare.map(|c| c.get());
    let groups = c.map(|c| Recording::borrowed(&c.inner, c.source.clone(), c.report.clone()));
    let done = py
        .detach(|| identify_recordings(&test, groups.as_ref(), &axis.inner, &options, &Keywords))
        .map_err(py_err)?;
    let report = serde_json::to_value(&done.report).map_err(py_err)?;
    let id = done.fit;
    Ok(IdentifyResult {
        report,
        time_s: array(py, id.time_s)?.unbind(),
        measured_torque_nm: array(py, id.regressors.torque_nm)?.unbind(),
        computed_torque_nm: array(py, id.computed_torque_nm)?.unbind(),
        used: readonly_bool(py, id.used)?.unbind(),
    })
}
