//! `feedscope.Axis`: the axis description, with the keys and checks of the axis file.
use std::path::PathBuf;

use feedscope::axis::{AxisParams, ConfigFormat};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{to_json, to_py};
use crate::errors::py_err;

/// The mechanical description of a feed axis: the keys of the axis file (TOML or JSON) as
/// keyword arguments, with their units in their names (`lead_mm`, `table_mass_kg`,
/// `inertia_kgm2`, `damping_nms_per_rad`, `torque_constant_nm_per_a`, ...). Unknown keys and
/// out-of-range values raise `BadInputError` naming the key, as for a file.
#[pyclass(module = "feedscope", frozen)]
#[derive(Clone)]
pub struct Axis {
    /// The library's axis.
    pub inner: AxisParams,
}

impl Axis {
    /// The axis as a dict with the file's keys.
    pub fn inner_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.inner)
    }
}

#[pymethods]
impl Axis {
    /// `Axis(lead_mm=10, table_mass_kg=425, ...)`: the keys of the axis file.
    #[new]
    #[pyo3(signature = (**keys))]
    fn new(keys: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let text = match keys {
            Some(k) => to_json(k.as_any())?,
            None => "{}".to_string(),
        };
        let inner = AxisParams::parse(&text, ConfigFormat::Json, "Axis(...)").map_err(py_err)?;
        Ok(Self { inner })
    }

    /// Read an axis file (TOML, or JSON with a `.json` extension), as `--axis FILE` does.
    /// With `for_identification=True`, `inertia_kgm2` and `damping_nms_per_rad` may be left
    /// out, as `feedscope identify` reads its axis (the test identifies them).
    #[staticmethod]
    #[pyo3(signature = (path, *, for_identification=false))]
    fn load(path: PathBuf, for_identification: bool) -> PyResult<Self> {
        let inner = if for_identification {
            feedscope_io::axis::load_for_identification(&path)
        } else {
            feedscope_io::axis::load(&path)
        }
        .map_err(py_err)?;
        Ok(Self { inner })
    }

    /// `Axis(**keys)` for `identify`: `inertia_kgm2` and `damping_nms_per_rad` may be left
    /// out.
    #[staticmethod]
    #[pyo3(signature = (**keys))]
    fn for_identification(keys: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let text = match keys {
            Some(k) => to_json(k.as_any())?,
            None => "{}".to_string(),
        };
        let inner = AxisParams::parse_for_identification(&text, ConfigFormat::Json, "Axis(...)")
            .map_err(py_err)?;
        Ok(Self { inner })
    }

    /// The axis as a dict with the file's keys (those set, and the defaults filled in).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.inner)
    }

    /// The axis as TOML text, as `feedscope simulate` writes `axis.toml`.
    fn to_toml(&self) -> PyResult<String> {
        toml::to_string_pretty(&self.inner).map_err(py_err)
    }

    /// Screw lead p (mm).
    #[getter]
    fn lead_mm(&self) -> f64 {
        self.inner.lead_mm
    }

    /// Name of the axis, when given.
    #[getter]
    fn name(&self) -> Option<String> {
        self.inner.name.clone()
    }

    /// Any key of the axis file, e.g. `axis.table_mass_kg` (None when an optional key is
    /// absent).
    fn __getattr__<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        let d = self.to_dict(py)?;
        let d = d.cast::<PyDict>()?;
        match d.get_item(key)? {
            Some(v) => Ok(v),
            None => Err(pyo3::exceptions::PyAttributeError::new_err(format!(
                "Axis has no key `{key}`"
            ))),
        }
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let d = self.to_dict(py)?;
        let d = d.cast::<PyDict>()?;
        let mut parts = Vec::new();
        for (k, v) in d.iter() {
            if v.is_none() {
                continue;
            }
            parts.push(format!("{}={}", k.str()?, v.repr()?));
        }
        Ok(format!("Axis({})", parts.join(", ")))
    }
}
