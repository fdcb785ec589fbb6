//! `feedscope.analyze`: the mean friction profile (IAFV) and the fluctuation spectra in screw
//! orders (paper 000, Section 4.1), as `feedscope analyze TRACE`.
use feedscope_app::analyze::{analyze_recording, AnalyzeOptions};
use feedscope_app::Recording;
use numpy::PyArray1;
use pyo3::prelude::*;

use crate::axis::Axis;
use crate::convert::{array, to_py};
use crate::errors::py_err;
use crate::estimate::Stroke;
use crate::front::Keywords;
use crate::trace::Trace;

/// One analysed stroke: its friction (`stroke`, a `Stroke`), the IAFV and the FFS on the same
/// grid, and the analysis as `feedscope analyze` writes it in `analysis.json`.
///
/// Arrays (read-only, aligned with `stroke.position_mm`): `iafv_n` (N), the instantaneous
/// average friction value, and `ffs_n` (N), the friction fluctuating signal (friction − IAFV).
#[pyclass(module = "feedscope", frozen)]
pub struct StrokeProfile {
    /// The stroke's friction along the travel.
    #[pyo3(get)]
    stroke: Py<Stroke>,
    /// Instantaneous average friction value (N).
    #[pyo3(get)]
    iafv_n: Py<PyArray1<f64>>,
    /// Friction fluctuating signal, friction − IAFV (N).
    #[pyo3(get)]
    ffs_n: Py<PyArray1<f64>>,
    /// This stroke's entry of `analysis.json`.
    report: serde_json::Value,
}

#[pymethods]
impl StrokeProfile {
    /// Significant fluctuation components: dicts of `segment`, `order` (cycles per lead),
    /// `amplitude_n`, `floor_n`, `cause`, `trusted`, ...
    #[getter]
    fn components<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["fluctuation"]["components"])
    }
    /// The IAFV fit: breakpoints (mm), orders, coefficients, residual (dict).
    #[getter]
    fn iafv<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["iafv"])
    }
    /// The spectra of the whole stroke and of its segments, and the components (dict).
    #[getter]
    fn fluctuation<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["fluctuation"])
    }
    /// The order scan of single polynomials (dict).
    #[getter]
    fn order_scan<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["order_scan"])
    }
    /// This stroke's entry of `analysis.json` (without the arrays).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }
    fn __repr__(&self) -> String {
        let r = &self.report;
        let n = r["fluctuation"]["components"]
            .as_array()
            .map_or(0, |c| c.len());
        format!(
            "StrokeProfile(stroke {} {}, {:.1} mm/min, {:.2} → {:.2} mm, IAFV orders {}, {} \
             component(s))",
            r["stroke"],
            r["direction"].as_str().unwrap_or("-"),
            r["feed_mm_min"].as_f64().unwrap_or(f64::NAN),
            r["start_mm"].as_f64().unwrap_or(f64::NAN),
            r["end_mm"].as_f64().unwrap_or(f64::NAN),
            r["iafv"]["orders"],
            n
        )
    }
}

/// The result of `analyze`: `strokes` (a list of `StrokeProfile`), `order_scan_table` (the
/// paper's Table 2), `withheld` strokes, `verdict`; `to_dict()` is `analysis.json`.
#[pyclass(module = "feedscope", frozen)]
pub struct AnalyzeResult {
    /// The analysed strokes.
    #[pyo3(get)]
    strokes: Vec<Py<StrokeProfile>>,
    report: serde_json::Value,
}

#[pymethods]
impl AnalyzeResult {
    /// Table 2: mean residual standard deviation of single polynomials per order and direction
    /// (dict with `rows` of `order`, `forward_std_n`, `backward_std_n`).
    #[getter]
    fn order_scan_table<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["order_scan_table"])
    }
    /// Strokes left out because their data support no profile (list of dicts).
    #[getter]
    fn withheld<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["withheld"])
    }
    /// The recording's data verdict (dict).
    #[getter]
    fn verdict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report["verdict"])
    }
    /// The binary's `analysis.json` as a dict (`source` is the trace's file or `"arrays"`).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }
    fn __len__(&self) -> usize {
        self.strokes.len()
    }
    fn __repr__(&self) -> String {
        let lines: Vec<String> = self
            .strokes
            .iter()
            .map(|s| format!("  {}", s.get().__repr__()))
            .collect();
        format!(
            "AnalyzeResult({} strokes, {} withheld\n{})",
            self.strokes.len(),
            self.report["withheld"].as_array().map_or(0, |w| w.len()),
            lines.join("\n")
        )
    }
}

/// Analyse friction along the travel (paper 000, Section 4.1), as `feedscope analyze TRACE
/// --axis AXIS`: estimate every stroke, fit the IAFV as piecewise polynomials (breakpoints and
/// orders by BIC unless `breaks_mm` and `orders` are given), separate the FFS, compute its
/// amplitude spectra in screw orders (cycles per lead) over the stroke and its segments
/// (`segments` equal segments, or `segment_length_mm` each, else about 5 leads each), and name
/// the significant components' likely causes from the axis geometry. `samples_per_lead` as for
/// `estimate`. The GIL is released while analysing.
#[pyfunction]
#[pyo3(signature = (trace, axis, *, samples_per_lead=1024, breaks_mm=None, orders=None,
                    segments=None, segment_length_mm=None))]
#[allow(clippy::too_many_arguments)]
pub fn analyze(
    py: Python<'_>,
    trace: &Bound<'_, Trace>,
    axis: &Axis,
    samples_per_lead: u32,
    breaks_mm: Option<Vec<f64>>,
    orders: Option<Vec<usize>>,
    segments: Option<usize>,
    segment_length_mm: Option<f64>,
) -> PyResult<AnalyzeResult> {
    let options = AnalyzeOptions {
        samples_per_lead,
        breaks_mm,
        orders,
        segments,
        segment_length_mm,
    };
    let t = trace.get();
    let recording = Recording::borrowed(&t.inner, t.source.clone(), t.report.clone());
    let done = py
        .detach(|| analyze_recording(&recording, &axis.inner, &options, &Keywords))
        .map_err(py_err)?;
    let report = serde_json::to_value(&done.report).map_err(py_err)?;
    let study = done.study;
    let kind = t.inner.effort_kind;
    let mut strokes = Vec::new();
    for ((s, an), r) in study
        .strokes
        .into_iter()
        .zip(study.analyses)
        .zip(stroke_reports_of(&report))
    {
        strokes.push(Py::new(
            py,
            StrokeProfile {
                stroke: Py::new(py, Stroke::from_friction(py, s, kind)?)?,
                iafv_n: array(py, an.iafv_n)?.unbind(),
                ffs_n: array(py, an.ffs_n)?.unbind(),
                report: r,
            },
        )?);
    }
    Ok(AnalyzeResult { strokes, report })
}

/// The per-stroke entries of the report.
fn stroke_reports_of(report: &serde_json::Value) -> Vec<serde_json::Value> {
    report["strokes"].as_array().cloned().unwrap_or_default()
}
