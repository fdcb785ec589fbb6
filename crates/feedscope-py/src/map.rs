//! `feedscope.map`: the friction map F(z, v) of a test set and the Stribeck fits along the
//! travel (paper 000, Section 4.2), as `feedscope map INDEX --axis AXIS` (its `map.json` and
//! `stribeck.json`; the CSV tables, plots and `--export` files are not made here).
use std::path::PathBuf;

use feedscope::estimate::EstimateParams;
use feedscope::map::{
    FeedScale, FrictionMap, MapParams, NonConventionalSpan, SetEstimate, StribeckAtPosition,
    StribeckProfile,
};
use feedscope::stribeck::{FrictionModel, ParamEstimate, M_S_PER_MM_MIN};
use feedscope::study::{map_study, MapStudyParams, StudyError};
use feedscope_io::test_set::{estimate_set, read_index};
use feedscope_io::trace::ReadOptions;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde_json::{json, Value};

use crate::axis::Axis;
use crate::convert::to_py;
use crate::errors::{py_err, BadInput};

/// The friction map of a test set: `to_dict()` is the binary's `map.json` (`summary` and
/// `map`: per direction the common breakpoints, the mean curve (PPOCM) of every feed, its
/// repeatability, and the feed polynomial of every coefficient); `stribeck()` its
/// `stribeck.json` (the Stribeck fit of every direction at the chosen positions: `fc_n`,
/// `fs_n` (N), `vs_mm_min` (mm/min), `sigma_n_s_per_m` (N·s/m), with uncertainties);
/// `failed` the runs that could not be estimated.
#[pyclass(module = "feedscope", frozen)]
pub struct MapResult {
    map_json: Value,
    stribeck_json: Value,
}

#[pymethods]
impl MapResult {
    /// The summary of `map.json`: runs, failed runs, per direction its span (mm), breakpoints,
    /// orders, feeds (mm/min), repeats, feed-polynomial misfit (N) and worst repeatability (N).
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.map_json["summary"])
    }
    /// Runs that failed (list of dicts: file, error); the others were mapped.
    #[getter]
    fn failed<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.map_json["summary"]["failed"])
    }
    /// The binary's `stribeck.json` as a dict.
    fn stribeck<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.stribeck_json)
    }
    /// The binary's `map.json` as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.map_json)
    }
    fn __repr__(&self) -> String {
        let s = &self.map_json["summary"];
        let dirs: Vec<String> = s["directions"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|d| {
                format!(
                    "{} {:.1} to {:.1} mm at {} feed(s)",
                    d["direction"].as_str().unwrap_or("-"),
                    d["start_mm"].as_f64().unwrap_or(f64::NAN),
                    d["end_mm"].as_f64().unwrap_or(f64::NAN),
                    d["feeds_mm_min"].as_array().map_or(0, |f| f.len())
                )
            })
            .collect();
        format!(
            "MapResult({} of {} runs mapped; {})",
            s["runs_ok"],
            s["runs"],
            dirs.join("; ")
        )
    }
}

/// A parameter with its uncertainty, as the CLI's map `est`.
fn est(value: f64, u: Option<&ParamEstimate>, scale: f64) -> Value {
    json!({
        "value": value * scale,
        "std_error": u.map(|u| u.std_error * scale),
        "ci95_low": u.map(|u| u.ci95_low * scale),
        "ci95_high": u.map(|u| u.ci95_high * scale),
    })
}

/// One position's Stribeck fit as `stribeck.json` holds it (the CLI's `position_fit`).
fn position_fit(p: &StribeckAtPosition) -> Value {
    let f = p.fit.as_ref();
    let u = f.and_then(|f| f.uncertainty.as_ref());
    let mm = 1.0 / M_S_PER_MM_MIN;
    // Parameters the reported model does not have are null.
    let hump = f.filter(|f| f.model == FrictionModel::Stribeck);
    let viscous = f.filter(|f| f.model != FrictionModel::Coulomb);
    let note = |code: &str, message: String| json!({"code": code, "message": message});
    json!({
        "position_mm": p.position_mm,
        "model": f.map(|f| f.model.code()),
        "reductions": f
            .map(|f| f.reductions.iter().map(|r| note(r.code(), r.to_string())).collect::<Vec<_>>())
            .unwrap_or_default(),
        "fc_n": f.map(|f| est(f.params.fc_n, u.map(|u| &u.fc_n), 1.0)),
        "fs_n": hump.map(|f| est(f.params.fs_n, u.and_then(|u| u.fs_n.as_ref()), 1.0)),
        "static_excess_n": hump.map(|f| est(
            f.params.static_excess_n(),
            u.and_then(|u| u.static_excess_n.as_ref()),
            1.0,
        )),
        "vs_mm_min": hump.map(|f| est(f.params.vs_m_s, u.and_then(|u| u.vs_m_s.as_ref()), mm)),
        "sigma_n_s_per_m": viscous.map(|f| est(
            f.params.sigma_n_s_per_m,
            u.and_then(|u| u.sigma_n_s_per_m.as_ref()),
            1.0,
        )),
        "residual_rms_n": f.map(|f| f.residual_rms_n),
        "friction_n": p.friction_n,
        "warnings": f
            .map(|f| f.warnings.iter().map(|w| note(w.code(), w.to_string())).collect::<Vec<_>>())
            .unwrap_or_default(),
        "nonconventional": p
            .nonconventional
            .iter()
            .flat_map(|n| &n.ranges)
            .map(|r| json!({
                "from_mm_min": r.from_mm_min(),
                "to_mm_min": r.to_mm_min(),
                "drop_n": r.drop_n,
                "excess_drop_n": r.excess_drop_n,
            }))
            .collect::<Vec<_>>(),
        "error": p.error,
    })
}

/// `stribeck.json` (the CLI's `stribeck_report`).
fn stribeck_report(at: &[StribeckProfile], spans: &[NonConventionalSpan]) -> Value {
    json!({
        "model": "F(v) = Fc + (Fs - Fc)*exp(-(v/vs)^2) + sigma*v on friction magnitudes (paper \
                  000 Eq. 9); where the feeds do not determine it, the Coulomb + viscous line \
                  F = Fc + sigma*v (positions[].model, the reasons in positions[].reductions)",
        "conventions": "data points: |PPOCM(z)| of every measured feed at the position; forces \
                        in N, feeds and vs in mm/min, sigma in N*s/m; std_error and 95 % \
                        intervals null when the fit has no residual degrees of freedom; \
                        parameters the reported model does not have are null",
        "directions": at.iter().map(|p| json!({
            "direction": p.direction,
            "feeds_mm_min": p.feeds_mm_min,
            "positions": p.positions.iter().map(position_fit).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "nonconventional_spans": spans,
    })
}

/// `map.json` (the CLI's `map_summary` and the map).
fn map_json(
    index: &str,
    runs: usize,
    est: &SetEstimate,
    map: &FrictionMap,
    spans: &[NonConventionalSpan],
) -> Value {
    json!({
        "summary": {
            "index": index,
            "runs": runs,
            "runs_ok": est.ok.len(),
            "failed": est.failed.iter().map(|f| json!({
                "file": f.run.name,
                "error": f.error,
            })).collect::<Vec<_>>(),
            "directions": map.directions.iter().map(|d| json!({
                "direction": d.direction,
                "start_mm": d.start_mm,
                "end_mm": d.end_mm,
                "breaks_mm": d.breaks_mm,
                "orders": d.orders,
                "feeds_mm_min": d.feeds_mm_min(),
                "repeats": d.feeds.iter().map(|g| g.repeats.len()).collect::<Vec<_>>(),
                "feed_order": d.feed_model.order,
                "feed_scale": d.feed_model.scale,
                "feed_misfit_rms_n": d.feed_model.rms_misfit_n,
                "feed_misfit_max_n": d.feed_model.max_misfit_n,
                "worst_repeatability_std_n": d
                    .feeds
                    .iter()
                    .flat_map(|g| g.repeatability.iter().filter_map(|r| r.std_n))
                    .reduce(f64::max),
            })).collect::<Vec<_>>(),
            "nonconventional_spans": spans.len(),
        },
        "map": map,
    })
}

fn bad(m: String) -> PyErr {
    py_err(BadInput(m))
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
    // The CLI's `validate`, in the keywords' words.
    let defaults = MapParams::default();
    let study_defaults = MapStudyParams::default();
    let position_step_mm = position_step_mm.unwrap_or(study_defaults.position_step_mm);
    if let Some(x) = positions_mm.iter().flatten().find(|x| !x.is_finite()) {
        return Err(bad(format!("positions_mm: {x} is not a finite position")));
    }
    if !(position_step_mm.is_finite() && position_step_mm > 0.0) {
        return Err(bad(format!(
            "position_step_mm {position_step_mm} must be positive"
        )));
    }
    if let Some(x) = table_feeds_mm_min
        .iter()
        .flatten()
        .find(|x| !(x.is_finite() && **x > 0.0))
    {
        return Err(bad(format!(
            "table_feeds_mm_min: {x} is not a positive feed"
        )));
    }
    if samples_per_lead < 16 {
        return Err(bad("samples_per_lead must be at least 16".into()));
    }
    if breaks_mm.is_some() && orders.is_none() {
        return Err(bad("breaks_mm needs orders (one per interval)".into()));
    }
    let feed_scale = match feed_scale {
        "log" => FeedScale::Log,
        "linear" => FeedScale::Linear,
        other => {
            return Err(PyValueError::new_err(format!(
                "feed_scale must be \"log\" or \"linear\", not {other:?}"
            )))
        }
    };
    let params = MapParams {
        breaks_mm: breaks_mm.clone(),
        orders: orders.clone(),
        margin_mm: margin_mm.unwrap_or(defaults.margin_mm),
        feed_order: feed_order.unwrap_or(defaults.feed_order),
        feed_scale,
        ..MapParams::default()
    };
    if let Some(o) = &orders {
        let n = breaks_mm.as_ref().map_or(0, Vec::len) + 1;
        if o.len() != n {
            return Err(bad(format!(
                "orders has {} values; {n} intervals need {n}",
                o.len()
            )));
        }
    }
    params.validate().map_err(|e| bad(e.to_string()))?;
    let study_params = MapStudyParams {
        map: params,
        positions_mm: positions_mm.clone(),
        position_step_mm,
        table_feeds_mm_min,
        extrapolate,
        ..MapStudyParams::default()
    };
    let a = &axis.inner;
    // A position outside the declared travel is wrong whatever the data say.
    if let (Some(lo), Some(hi)) = (a.travel_min_mm, a.travel_max_mm) {
        if let Some(x) = positions_mm.iter().flatten().find(|&&x| x < lo || x > hi) {
            return Err(bad(format!(
                "positions_mm: {x} mm is outside the axis travel [{lo}, {hi}] mm"
            )));
        }
    }
    let set = read_index(&index).map_err(|e| bad(e.to_string()))?;
    let est_params = EstimateParams {
        samples_per_lead,
        ..EstimateParams::default()
    };
    let result = py.detach(|| -> anyhow::Result<(SetEstimate, _)> {
        let est = estimate_set(
            &set,
            a,
            &est_params,
            &ReadOptions::default(),
            study_params.map.stroke_feed_tolerance,
            &|_| {},
        );
        if est.ok.is_empty() {
            return Err(anyhow::anyhow!(
                "all {} runs of {} failed; nothing to map",
                set.runs.len(),
                set.source_name
            ));
        }
        let study = map_study(&est.ok, a.lead_m(), &study_params).map_err(|e| match e {
            StudyError::Position(e) => anyhow::Error::new(e).context("positions_mm"),
            StudyError::TableFeed(e) => {
                anyhow::Error::new(e).context("table_feeds_mm_min, without extrapolate")
            }
            e => anyhow::Error::new(e).context(set.source_name.clone()),
        })?;
        Ok((est, study))
    });
    let (est, study) = result.map_err(crate::errors::to_py)?;
    Ok(MapResult {
        map_json: map_json(
            &set.source_name,
            set.runs.len(),
            &est,
            &study.map,
            &study.nonconventional,
        ),
        stribeck_json: stribeck_report(&study.at_positions, &study.nonconventional),
    })
}
