//! `feedscope.analyze`: the mean friction profile (IAFV) and the fluctuation spectra in screw
//! orders (paper 000, Section 4.1), as `feedscope analyze TRACE`.
use feedscope::order::SegmentSpec;
use feedscope::study::{analyze_trace, AnalyzeStudyParams, StudyError};
use feedscope::verdict::FrictionSign;
use numpy::PyArray1;
use pyo3::prelude::*;
use serde_json::json;

use crate::axis::Axis;
use crate::convert::{array, to_py};
use crate::errors::{bad_input, py_err};
use crate::estimate::Stroke;
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
    // The CLI's checks of its options, in its words (keywords instead of flags).
    let mut params = AnalyzeStudyParams::default();
    if !(1..=1_000_000).contains(&samples_per_lead) {
        return Err(bad_input(format!(
            "samples_per_lead = {samples_per_lead} is not in 1..=1000000"
        )));
    }
    params.estimate.samples_per_lead = samples_per_lead;
    let p = &mut params.analysis;
    match (&breaks_mm, &orders) {
        (Some(b), Some(o)) => {
            if o.len() != b.len() + 1 {
                return Err(bad_input(format!(
                    "orders needs one order per interval: {} breakpoints make {} intervals, {} \
                     orders given",
                    b.len(),
                    b.len() + 1,
                    o.len()
                )));
            }
            p.profile.breaks_mm = Some(b.clone());
            p.profile.orders = Some(o.clone());
        }
        (None, Some(o)) => {
            if o.len() != 1 {
                return Err(bad_input("orders without breaks_mm takes one order"));
            }
            p.profile.breaks_mm = Some(Vec::new());
            p.profile.orders = Some(o.clone());
        }
        (Some(_), None) => return Err(bad_input("breaks_mm needs orders (one per interval)")),
        (None, None) => {}
    }
    if segments.is_some() && segment_length_mm.is_some() {
        return Err(bad_input("give segments or segment_length_mm, not both"));
    }
    if let Some(n) = segments {
        if n == 0 {
            return Err(bad_input("segments must be at least 1"));
        }
        p.spectrum.segments = SegmentSpec::Count { count: n };
    }
    if let Some(l) = segment_length_mm {
        if !(l.is_finite() && l > 0.0) {
            return Err(bad_input("segment_length_mm must be a positive length"));
        }
        p.spectrum.segments = SegmentSpec::LengthMm { length_mm: l };
    }
    let t = trace.get();
    let a = &axis.inner;
    let study = py
        .detach(|| analyze_trace(&t.inner, a, &params, &|_, _| {}))
        .map_err(|e| {
            // The context `feedscope analyze` gives each failing step (cmd/analyze.rs).
            py_err(match e {
                StudyError::Stroke {
                    stroke,
                    direction,
                    start_mm,
                    end_mm,
                    source,
                } => anyhow::Error::new(source).context(format!(
                    "stroke {stroke} ({direction}, {start_mm:.1} to {end_mm:.1} mm)"
                )),
                StudyError::SinglePolynomial { source, .. } => {
                    anyhow::Error::new(source).context("single-polynomial fit")
                }
                StudyError::OrderScanTable(e) => anyhow::Error::new(e),
                StudyError::Estimate(e) => anyhow::Error::new(e),
                e => anyhow::Error::new(e),
            })
        })?;
    let verdict = study.verdict.as_ref();
    let mut stroke_reports = Vec::new();
    for ((s, an), single) in study
        .strokes
        .iter()
        .zip(&study.analyses)
        .zip(&study.single_polynomials)
    {
        stroke_reports.push(json!({
            "stroke": s.summary.stroke,
            "direction": s.summary.direction,
            "feed_mm_min": s.summary.feed_mm_min,
            "start_mm": s.summary.start_mm,
            "end_mm": s.summary.end_mm,
            "max_trusted_order": s.summary.max_order,
            "order_scan": an.order_scan,
            "iafv": an.iafv,
            "single_polynomial_order": an.order_scan.best_order,
            "single_polynomial_std_n": single.residual_std_n,
            "fluctuation": an.fluctuation,
        }));
    }
    let mut report = json!({
        "source": t.source,
        "axis": a,
        "params": params.analysis,
        "order_scan_table": study.order_scan_table,
        "strokes": stroke_reports,
        "withheld": study.withheld,
        "conventions": {
            "order": "cycles per screw revolution = cycles per lead of table travel",
            "friction_sign": match verdict.map(|v| v.friction_sign) {
                Some(FrictionSign::FromDirection) => {
                    "from the direction of motion (the effort is a magnitude): positive \
                     moving forward, negative backward"
                }
                _ => "as paper 000 Eq. 5: positive moving forward, negative backward",
            },
            "amplitude": "single-sided amplitude spectrum in newtons; the window's coherent \
                          gain is corrected (factor amplitude_correction = 2/sum(w)), so a \
                          sinusoid of amplitude A reads A on its bin",
        },
    });
    if let Some(v) = verdict {
        report["verdict"] = json!(v);
    }
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
