//! `feedscope.identify`: Fs, Fc, σ, vs and the inertia J from one triangular-wave test (paper
//! 002), as `feedscope identify` (its `ident.json`).
use feedscope::estimate::EstimateParams;
use feedscope::ident::{fit_groups, identify as run_identify, ForceSide, IdentParams, TorqueFit};
use numpy::PyArray1;
use pyo3::prelude::*;
use serde_json::{json, Value};

use crate::axis::Axis;
use crate::convert::{array, readonly_bool, to_py};
use crate::errors::{py_err, BadInput};
use crate::trace::Trace;

/// The parameter set of a fit as `ident.json` holds it (the CLI's `ParamSet`).
fn param_set(f: &TorqueFit, lead_m: f64) -> serde_json::Map<String, Value> {
    let v = json!({
        "motor": {
            "j_total_kgm2": f.j_total_kgm2,
            "tc_nm": f.tc_nm,
            "ts_nm": f.ts_nm,
            "vs_mm_min": f.vs_mm_min,
            "sigma_nm_s_per_m": f.sigma_nm_s_per_m,
            "offset_nm": f.offset_nm,
            "delta": f.delta,
        },
        "std_error": f.std_error,
        "force": ForceSide::from_fit(f, lead_m),
        "diagnostics": {
            "residual_rms_nm": f.residual_rms_nm,
            "condition_number": f.condition_number,
            "iterations": f.iterations,
            "samples_used": f.samples_used,
            "vs_at_bound": f.vs_at_bound,
        },
    });
    match v {
        Value::Object(m) => m,
        _ => serde_json::Map::new(),
    }
}

fn pct(a: f64, b: f64) -> f64 {
    100.0 * (a - b) / b
}

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
    /// Warnings (list of str).
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
    let a = &axis.inner;
    if compare.is_some() && !a.has_dynamics() {
        let key = if a.inertia_kgm2.is_finite() {
            "damping_nms_per_rad"
        } else {
            "inertia_kgm2"
        };
        return Err(py_err(BadInput(format!(
            "compare estimates the friction of the constant-speed strokes (paper 000 Eq. 5), \
             which needs key `{key}` in the axis"
        ))));
    }
    let params = IdentParams {
        kernel_half_width_s: kernel_s,
        min_speed_mm_min,
        reversal_guard_s: guard_s,
        delta,
        vs_min_mm_min,
        vs_max_mm_min,
        fit_offset,
        ..IdentParams::default()
    };
    let t = trace.get();
    let id = py
        .detach(|| run_identify(&t.inner, a, &params))
        .map_err(|e| {
            py_err(
                anyhow::Error::new(BadInput(e.to_string()))
                    .context(format!("identifying from {}", t.source)),
            )
        })?;
    let lead_m = a.lead_m();
    let mut warnings: Vec<String> = t
        .report
        .warning()
        .map(|w| format!("{}: {w}", t.source))
        .into_iter()
        .collect();
    warnings.extend(id.warnings.iter().cloned());
    let compare_json = match compare {
        Some(c) => {
            let c = c.get();
            warnings.extend(c.report.warning().map(|w| format!("{}: {w}", c.source)));
            let g = py
                .detach(|| fit_groups(&c.inner, a, &params, &EstimateParams::default()))
                .map_err(|e| {
                    py_err(
                        anyhow::Error::new(BadInput(e.to_string()))
                            .context(format!("fitting the constant-speed groups of {}", c.source)),
                    )
                })?;
            if g.fit.vs_at_bound {
                warnings.push(
                    "groups: the Stribeck velocity ended at a search bound (not resolved by \
                     the feeds of the groups)"
                        .to_string(),
                );
            }
            let f = &id.fit;
            let mut m = param_set(&g.fit, lead_m);
            m.insert("source".into(), json!(c.source));
            m.insert("groups".into(), json!(g.groups));
            m.insert(
                "difference_percent".into(),
                json!({
                    "tc": pct(f.tc_nm, g.fit.tc_nm),
                    "ts": pct(f.ts_nm, g.fit.ts_nm),
                    "vs": pct(f.vs_mm_min, g.fit.vs_mm_min),
                    "sigma": pct(f.sigma_nm_s_per_m, g.fit.sigma_nm_s_per_m),
                }),
            );
            Value::Object(m)
        }
        None => Value::Null,
    };
    let mut m = param_set(&id.fit, lead_m);
    m.insert("source".into(), json!(t.source));
    m.insert("effort".into(), json!(t.inner.effort_kind));
    m.insert("lead_mm".into(), json!(a.lead_mm));
    m.insert("samples_total".into(), json!(id.samples_total));
    m.insert("kernel_half_width_s".into(), json!(id.kernel_half_width_s));
    m.insert("reversal_guard_s".into(), json!(id.reversal_guard_s));
    m.insert("sample_interval_s".into(), json!(id.sample_interval_s));
    m.insert("axis_j_total_kgm2".into(), json!(id.axis_j_total_kgm2));
    m.insert("params".into(), json!(params));
    m.insert("warnings".into(), json!(warnings));
    m.insert("compare".into(), compare_json);
    Ok(IdentifyResult {
        report: Value::Object(m),
        time_s: array(py, id.time_s)?.unbind(),
        measured_torque_nm: array(py, id.regressors.torque_nm)?.unbind(),
        computed_torque_nm: array(py, id.computed_torque_nm)?.unbind(),
        used: readonly_bool(py, id.used)?.unbind(),
    })
}
