//! `feedscope.simulate`: the digital twin, as `feedscope simulate`.
use std::path::{Path, PathBuf};

use feedscope::sim::{simulate as run_sim, SimConfig, Truth};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::axis::Axis;
use crate::convert::{array, to_json, to_py};
use crate::errors::{bad_input, py_err};
use crate::trace::Trace;

/// The default simulator config as TOML text, every key with its unit (what
/// `feedscope simulate --print-default-config` prints).
#[pyfunction]
pub fn default_sim_config() -> PyResult<String> {
    SimConfig::default().to_toml_string().map_err(py_err)
}

/// The result of `simulate`: the controller's view (`trace`), the axis simulated (`axis`), and
/// the known truth.
///
/// Truth arrays (read-only), one sample every `truth.interval_ms` of the config:
/// `truth_time_s` (s), `truth_position_mm` (mm), `truth_velocity_mm_s` (mm/s),
/// `truth_accel_mm_s2` (mm/s²), `truth_friction_n` (N, signed as Eq. 5) — the columns of the
/// binary's `truth.csv`. `truth()` is the binary's `truth.json` as a dict.
#[pyclass(module = "feedscope", frozen)]
pub struct Simulation {
    /// What the controller would have recorded.
    #[pyo3(get)]
    trace: Py<Trace>,
    /// The axis simulated (the binary's `axis.toml`).
    #[pyo3(get)]
    axis: Py<Axis>,
    truth: Truth,
    /// Times of the true state (s).
    #[pyo3(get)]
    truth_time_s: Py<PyArray1<f64>>,
    /// True table position (mm).
    #[pyo3(get)]
    truth_position_mm: Py<PyArray1<f64>>,
    /// True table velocity (mm/s).
    #[pyo3(get)]
    truth_velocity_mm_s: Py<PyArray1<f64>>,
    /// True table acceleration (mm/s²).
    #[pyo3(get)]
    truth_accel_mm_s2: Py<PyArray1<f64>>,
    /// True friction force (N, signed as Eq. 5).
    #[pyo3(get)]
    truth_friction_n: Py<PyArray1<f64>>,
}

#[pymethods]
impl Simulation {
    /// The truth as the binary's `truth.json`: friction model, axis, commanded strokes,
    /// dynamics mode, seed, duration (s).
    fn truth<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.truth)
    }

    /// The twin's friction model evaluated at positions (mm) and velocities (mm/s), arrays of
    /// equal length or scalars: signed friction (N), as the demo compares its estimate with.
    fn true_friction_n<'py>(
        &self,
        py: Python<'py>,
        position_mm: &Bound<'py, PyAny>,
        velocity_mm_s: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let np = py.import("numpy")?;
        let as_f64 = |o: &Bound<'py, PyAny>| -> PyResult<Vec<f64>> {
            let kwargs = PyDict::new(py);
            kwargs.set_item("dtype", np.getattr("float64")?)?;
            let a = np.call_method("asarray", (o,), Some(&kwargs))?;
            let a = np.call_method1("ravel", (a,))?;
            a.call_method0("tolist")?.extract()
        };
        let z = as_f64(position_mm)?;
        let v = as_f64(velocity_mm_s)?;
        if z.len() != v.len() {
            return Err(bad_input(format!(
                "position_mm has {} values, velocity_mm_s {}: they must be of equal length",
                z.len(),
                v.len()
            )));
        }
        let model = &self.truth.friction;
        let out: Vec<f64> = z
            .iter()
            .zip(&v)
            .map(|(z, v)| model.friction_n(z * 1e-3, v * 1e-3))
            .collect();
        array(py, out)
    }

    /// `trace`, `axis` (dicts), `truth` (the `truth.json` dict) and the truth arrays.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("trace", self.trace.bind(py).call_method0("to_dict")?)?;
        d.set_item("axis", self.axis.get().inner_dict(py)?)?;
        d.set_item("truth", self.truth(py)?)?;
        d.set_item("truth_time_s", self.truth_time_s.bind(py))?;
        d.set_item("truth_position_mm", self.truth_position_mm.bind(py))?;
        d.set_item("truth_velocity_mm_s", self.truth_velocity_mm_s.bind(py))?;
        d.set_item("truth_accel_mm_s2", self.truth_accel_mm_s2.bind(py))?;
        d.set_item("truth_friction_n", self.truth_friction_n.bind(py))?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let t = &self.trace.get().inner;
        format!(
            "Simulation(axis={:?}, {:.1} s, {} position and {} {} samples, {} commanded \
             stroke(s), seed {})",
            self.axis.get().inner.name.as_deref().unwrap_or("axis"),
            self.truth.duration_s,
            t.position_m.len(),
            t.effort.len(),
            t.effort_kind.column(),
            self.truth.strokes.len(),
            self.truth.seed
        )
    }
}

/// Simulate a feed drive with known friction (the digital twin), as `feedscope simulate`.
///
/// `config` is a simulator config: a dict with the keys of the TOML file (see
/// `default_sim_config()`), or the path of a TOML file (a relative `motion.program_file` is
/// read relative to it); None simulates the default lathe Z axis, 0 → 410 → 0 mm at
/// 100 mm/min. `seed` overrides the config's `seed`. The GIL is released while simulating.
#[pyfunction]
#[pyo3(signature = (config=None, *, seed=None))]
pub fn simulate(
    py: Python<'_>,
    config: Option<&Bound<'_, PyAny>>,
    seed: Option<u64>,
) -> PyResult<Simulation> {
    let mut cfg = match config {
        None => SimConfig::default(),
        Some(c) if c.is_instance_of::<PyDict>() => {
            // The dict goes through TOML text so that its keys meet the file's parser and
            // checks (unknown keys and values out of range are refused, naming the key).
            let json = to_json(c)?;
            let value: toml::Value = serde_json::from_str(&json).map_err(py_err)?;
            let text = toml::to_string(&value).map_err(py_err)?;
            feedscope_io::sim::config_from_toml_str_in_dir(&text, Path::new("."))
                .map_err(|e| py_err(anyhow::Error::new(e).context("config")))?
        }
        Some(c) => {
            let path: PathBuf = c.extract()?;
            let text = std::fs::read_to_string(&path).map_err(|e| {
                py_err(anyhow::Error::new(e).context(format!("reading config {}", path.display())))
            })?;
            let dir = path.parent().unwrap_or(Path::new("."));
            feedscope_io::sim::config_from_toml_str_in_dir(&text, dir).map_err(|e| {
                py_err(anyhow::Error::new(e).context(format!("config {}", path.display())))
            })?
        }
    };
    if let Some(s) = seed {
        cfg.seed = s;
    }
    cfg.validate()
        .map_err(|e| py_err(anyhow::Error::new(e).context("config")))?;
    let out = py
        .detach(|| run_sim(&cfg, &mut |_| {}))
        .map_err(|e| py_err(anyhow::Error::new(e).context("simulation failed")))?;
    let mut truth = out.truth;
    let states = std::mem::take(&mut truth.states);
    let col = |f: &dyn Fn(&feedscope::sim::StateSample) -> f64| -> Vec<f64> {
        states.iter().map(f).collect()
    };
    let axis = Py::new(
        py,
        Axis {
            inner: truth.axis.clone(),
        },
    )?;
    let trace = Py::new(
        py,
        Trace {
            inner: out.trace,
            report: Default::default(),
            source: "simulate()".into(),
        },
    )?;
    Ok(Simulation {
        trace,
        axis,
        truth_time_s: array(py, col(&|s| s.time_s))?.unbind(),
        truth_position_mm: array(py, col(&|s| s.position_m * 1e3))?.unbind(),
        truth_velocity_mm_s: array(py, col(&|s| s.velocity_m_s * 1e3))?.unbind(),
        truth_accel_mm_s2: array(py, col(&|s| s.accel_m_s2 * 1e3))?.unbind(),
        truth_friction_n: array(py, col(&|s| s.friction_n))?.unbind(),
        truth,
    })
}
