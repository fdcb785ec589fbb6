//! `feedscope.map`: the friction map F(z, v) of a test set and the Stribeck fits along the
//! travel (paper 000, Section 4.2), as `feedscope map INDEX --axis AXIS` (its `map.json` and
//! `stribeck.json`; the CSV tables, plots and `--export` files are not made here).
use std::path::PathBuf;

use feedscope::map::FeedScale;
use feedscope_app::map::{map_set, MapOptions, MapReport, MapStribeckReport};
use feedscope_app::AppError;
use feedscope_io::test_set::read_index;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::axis::Axis;
use crate::convert::to_py;
use crate::errors::py_err;
use crate::front::Keywords;

/// The friction map of a test set: `to_dict()` is the binary's `map.json` (`summary` and
/// `map`: per direction the common breakpoints, the mean curve (PPOCM) of every feed, its
/// repeatability, and the feed polynomial of every coefficient); `stribeck()` its
/// `stribeck.json` (the Stribeck fit of every direction at the chosen positions: `fc_n`,
/// `fs_n` (N), `vs_mm_min` (mm/min), `sigma_n_s_per_m` (N·s/m), with uncertainties);
/// `failed` the runs that could not be estimated.
#[pyclass(module = "feedscope", frozen)]
pub struct MapResult {
    report: MapReport,
    stribeck: MapStribeckReport,
}

#[pymethods]
impl MapResult {
    /// The summary of `map.json`: runs, failed runs, per direction its span (mm), breakpoints,
    /// orders, feeds (mm/min), repeats, feed-polynomial misfit (N) and worst repeatability (N).
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.summary)
    }
    /// Runs that failed (list of dicts: file, error); the others were mapped.
    #[getter]
    fn failed<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report.summary.failed)
    }
    /// The binary's `stribeck.json` as a dict.
    fn stribeck<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.stribeck)
    }
    /// The binary's `map.json` as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }
    fn __repr__(&self) -> String {
        let s = &self.report.summary;
        let dirs: Vec<String> = s
            .directions
            .iter()
            .map(|d| {
                format!(
                    "{} {:.1} to {:.1} mm at {} feed(s)",
                    d.direction.as_str(),
                    d.start_mm,
                    d.end_mm,
                    d.feeds_mm_min.len()
                )
            })
            .collect();
        format!(
            "MapResult({} of {} runs mapped; {})",
            s.runs_ok,
            s.runs,
            dirs.join("; ")
        )
    }
}

/// The friction map F(z, v) of a test set (paper 000, Section 4.2), as `feedscope map INDEX
/// --axis AXIS`: `index` is the CSV listing the runs (`file,feed_mm_min,repeat`, files
/// relative to it); each run is estimated (`samples_per_lead`), every stroke fitted with
/// common breakpoints (`breaks_mm` (mm) with `orders`, or equal intervals), the repeats of each
/// feed averaged (PPOCM), each coefficient made a polynomial of the feed (`feed_order`,
/// `feed_scale` `"log"` or `"linear"`), with `margin_mm` (mm) trimmed from the span; the
/// Stribeck curve is fitted at `positions_mm` (default: 5 per direction) and every
/// `position_step_mm` (mm). `table_feeds_mm_min` and `extrapolate` as for the compensation
/// table. Runs that fail are listed in `failed` and the others mapped; when every run fails,
/// `InternalError` (the binary's exit code 1). The GIL is released while estimating and
/// fitting.
#[pyfunction]
#[pyo3(signature = (index, axis, *, positions_mm=None, breaks_mm=None, orders=None,
                    feed_order=None, feed_scale="log", position_step_mm=None,
                    table_feeds_mm_min=None, extrapolate=false, margin_mm=None,
                    samples_per_lead=1024))]
#[allow(clippy::too_many_arguments)]
pub fn map(
    py: Python<'_>,
    index: PathBuf,
    axis: &Axis,
    positions_mm: Option<Vec<f64>>,
    breaks_mm: Option<Vec<f64>>,
    orders: Option<Vec<usize>>,
    feed_order: Option<usize>,
    feed_scale: &str,
    position_step_mm: Option<f64>,
    table_feeds_mm_min: Option<Vec<f64>>,
    extrapolate: bool,
    margin_mm: Option<f64>,
    samples_per_lead: u32,
) -> PyResult<MapResult> {
    let feed_scale = match feed_scale {
        "log" => FeedScale::Log,
        "linear" => FeedScale::Linear,
        other => {
            return Err(PyValueError::new_err(format!(
                "feed_scale must be \"log\" or \"linear\", not {other:?}"
            )))
        }
    };
    let defaults = MapOptions::default();
    let options = MapOptions {
        positions_mm,
        breaks_mm,
        orders,
        feed_order: feed_order.unwrap_or(defaults.feed_order),
        feed_scale,
        position_step_mm: position_step_mm.unwrap_or(defaults.position_step_mm),
        table_feeds_mm_min,
        extrapolate,
        margin_mm: margin_mm.unwrap_or(defaults.margin_mm),
        samples_per_lead,
    };
    // The settings are checked before the index is read, as on the command line.
    options.study_params(&Keywords).map_err(py_err)?;
    let set = read_index(&index)
        .map_err(AppError::from_error)
        .map_err(py_err)?;
    let a = &axis.inner;
    let mapped = py
        .detach(|| map_set(&set, a, &options, &Keywords))
        .map_err(py_err)?;
    Ok(MapResult {
        report: mapped.report,
        stribeck: mapped.stribeck,
    })
}
