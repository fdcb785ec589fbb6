//! Values between Rust and Python: serde values through JSON, arrays through numpy.
use numpy::{PyArray1, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;

use crate::errors::py_err;

/// A serde value as plain Python objects (dict, list, float, int, str, bool, None), through
/// JSON: the same keys and numbers as the JSON files the binary writes (serde_json writes the
/// shortest text that reads back to the same `f64`, so nothing is rounded).
pub fn to_py<'py, T: Serialize + ?Sized>(
    py: Python<'py>,
    value: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(py_err)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// A Python object of plain values as JSON text (`json.dumps`), for the library's parsers.
pub fn to_json(obj: &Bound<'_, PyAny>) -> PyResult<String> {
    let json = obj.py().import("json")?;
    let kwargs = PyDict::new(obj.py());
    // NaN and infinities are not JSON; the library's parsers would not read them either.
    kwargs.set_item("allow_nan", false)?;
    json.call_method("dumps", (obj,), Some(&kwargs))
        .map_err(|e| {
            PyTypeError::new_err(format!(
                "not representable as JSON (plain numbers, strings, lists and dicts only): {e}"
            ))
        })?
        .extract()
}

/// A vector moved into a numpy array without a copy, made read-only so that the object it
/// belongs to stays what the library computed.
pub fn array<'py>(py: Python<'py>, v: Vec<f64>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let a = PyArray1::from_vec(py, v);
    readonly(&a)?;
    Ok(a)
}

/// A bool vector moved into a read-only numpy array.
pub fn readonly_bool(py: Python<'_>, v: Vec<bool>) -> PyResult<Bound<'_, PyArray1<bool>>> {
    let a = PyArray1::from_vec(py, v);
    let kwargs = PyDict::new(py);
    kwargs.set_item("write", false)?;
    a.call_method("setflags", (), Some(&kwargs))?;
    Ok(a)
}

/// `a.setflags(write=False)`.
pub fn readonly(a: &Bound<'_, PyArray1<f64>>) -> PyResult<()> {
    let kwargs = PyDict::new(a.py());
    kwargs.set_item("write", false)?;
    a.call_method("setflags", (), Some(&kwargs))?;
    Ok(())
}

/// `v` scaled by `factor` in place (SI to the user unit, e.g. m to mm), then moved into numpy.
pub fn scaled(py: Python<'_>, mut v: Vec<f64>, factor: f64) -> PyResult<Py<PyArray1<f64>>> {
    for x in &mut v {
        *x *= factor;
    }
    Ok(array(py, v)?.unbind())
}

/// A 1-D float64 numpy array argument as a slice copied into a vector, with errors that say
/// what was expected: a `TypeError` naming the argument for anything that is not a 1-D float64
/// numpy array (with the conversion to use).
pub fn f64_vec(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let hint = format!("convert with numpy.asarray({name}, dtype=numpy.float64)");
    let Ok(untyped) = obj.cast::<PyUntypedArray>() else {
        return Err(PyTypeError::new_err(format!(
            "{name} must be a 1-D numpy array of float64, got {} ({hint})",
            obj.get_type().name()?
        )));
    };
    if untyped.ndim() != 1 {
        return Err(PyTypeError::new_err(format!(
            "{name} must be a 1-D numpy array of float64, got {} dimensions with shape {:?} \
             ({hint}, and .ravel() if it is a column)",
            untyped.ndim(),
            untyped.shape()
        )));
    }
    let Ok(arr) = obj.cast::<PyArray1<f64>>() else {
        return Err(PyTypeError::new_err(format!(
            "{name} must be a 1-D numpy array of float64, got dtype {} ({hint})",
            untyped.dtype()
        )));
    };
    let ro = arr.readonly();
    // A strided view (e.g. a column of a 2-D array) has no slice; it is copied element-wise.
    Ok(match ro.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => ro.as_array().iter().copied().collect(),
    })
}
