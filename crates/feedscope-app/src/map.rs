//! The friction map F(z, v) of a test set (paper 000, Section 4.2): every run estimated, every
//! stroke fitted with common breakpoints, the repeats of a feed averaged (PPOCM, Eq. 6), each
//! mean coefficient made a polynomial of the feed (Eq. 8), and the Stribeck curve (Eq. 9) fitted
//! at chosen positions and along the grid, with the non-conventional spans.
//!
//! [`MapRequest`] names the index and axis files; [`map_set`] takes a parsed index and axis
//! (the Python module's path). Both give a [`Mapped`]: `map.json` ([`MapReport`]),
//! `stribeck.json` ([`MapStribeckReport`]), the CSV tables ([`Mapped::files`]) and the curves a
//! controller export tabulates ([`Mapped::export_at`]); the request also makes the controller
//! files it asks for ([`Mapped::exports`], [`crate::compensation`]). The pictures are
//! `crate::plot::map_svgs`; the plain-text view is the `Display` of [`Mapped`] and
//! [`Mapped::remarks`] (the child module `text`).
use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use feedscope::axis::AxisParams;
use feedscope::compensation::{DriveConversion, FrictionCurve};
use feedscope::estimate::{Direction, EstimateParams};
use feedscope::map::{
    stribeck_profile, FeedScale, FrictionMap, MapParams, NonConventionalSpan, SetEstimate,
    StribeckAtPosition, StribeckProfile, TestSet,
};
use feedscope::stribeck::{FrictionModel, ParamEstimate, M_S_PER_MM_MIN};
use feedscope::study::{map_study, MapStudy, MapStudyParams, StudyError};
use feedscope::ErrorKind;
use feedscope_io::compensation::CompensationTable;
use feedscope_io::controller_compensation::ExportSource;
use feedscope_io::test_set::{estimate_set, read_index};
use feedscope_io::trace::ReadOptions;
use serde::{Deserialize, Serialize};

use crate::compensation::{export_files, ExportCurves, ExportFile, ExportOptions, ExportPlan};
use crate::{AppError, FrontEnd};
use feedscope::diag::Diagnostic;

mod text;

/// Map a test set given as files.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapRequest {
    /// Index CSV of the runs (`file,feed_mm_min,repeat`, files relative to its folder).
    pub index: PathBuf,
    /// Axis parameters (TOML or JSON).
    pub axis: PathBuf,
    /// Settings of the map.
    #[serde(flatten)]
    pub options: MapOptions,
    /// Controller files to make from the friction at `export_position_mm`.
    #[serde(flatten)]
    pub export: ExportOptions,
    /// Position (mm) whose friction the exports tabulate; default: the middle of the span
    /// both directions share. Only with an export.
    pub export_position_mm: Option<f64>,
    /// Curve the exported tables follow at that position. Only with an export.
    pub export_curve: ExportCurve,
}

/// Settings of the map, as a user gives them; [`MapOptions::study_params`] turns them into
/// the study's [`MapStudyParams`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapOptions {
    /// Positions of the Stribeck fits (mm); default: 5 evenly spaced inside each direction's
    /// mapped span.
    pub positions_mm: Option<Vec<f64>>,
    /// Interior breakpoints common to every feed (mm); default: equal intervals. Needs
    /// `orders`.
    pub breaks_mm: Option<Vec<f64>>,
    /// Polynomial order of each interval, one more than breakpoints (default: 4 each).
    pub orders: Option<Vec<usize>>,
    /// Highest order of the feed polynomial (Eq. 8); lowered to feeds − 2 when fewer feeds.
    pub feed_order: usize,
    /// Scaled feed variable of the feed polynomial.
    pub feed_scale: FeedScale,
    /// Position step of the map grid, the compensation table and the Stribeck profile (mm).
    pub position_step_mm: f64,
    /// Feeds of the compensation table (mm/min); default: the measured feeds.
    pub table_feeds_mm_min: Option<Vec<f64>>,
    /// Allow table feeds outside the measured feeds (the feed polynomial extrapolates).
    pub extrapolate: bool,
    /// Trimmed from both ends of the strokes' common span (mm).
    pub margin_mm: f64,
    /// Resampling points per lead when estimating (16 to 1,000,000).
    pub samples_per_lead: u32,
}

impl Default for MapOptions {
    fn default() -> Self {
        let map = MapParams::default();
        let study = MapStudyParams::default();
        Self {
            positions_mm: None,
            breaks_mm: None,
            orders: None,
            feed_order: map.feed_order,
            feed_scale: map.feed_scale,
            position_step_mm: study.position_step_mm,
            table_feeds_mm_min: None,
            extrapolate: false,
            margin_mm: map.margin_mm,
            samples_per_lead: EstimateParams::default().samples_per_lead,
        }
    }
}

impl MapOptions {
    /// Check the settings and give the study's parameters.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field in the front end's spelling: a position or
    /// breakpoint that is not finite, a step or table feed that is not positive, samples per
    /// lead out of range, breakpoints without orders or with the wrong number of orders; the
    /// map's own checks (margin, feed order).
    pub fn study_params(&self, front: &dyn FrontEnd) -> Result<MapStudyParams, AppError> {
        let name = |f: &str| front.name(f);
        for (field, xs) in [
            ("positions_mm", &self.positions_mm),
            ("breaks_mm", &self.breaks_mm),
        ] {
            if let Some(x) = xs.iter().flatten().find(|x| !x.is_finite()) {
                return Err(AppError::invalid(
                    field,
                    format!("{}: {x} is not a finite position", name(field)),
                ));
            }
        }
        if !(self.position_step_mm.is_finite() && self.position_step_mm > 0.0) {
            return Err(AppError::invalid(
                "position_step_mm",
                format!(
                    "{} {} must be positive",
                    name("position_step_mm"),
                    self.position_step_mm
                ),
            ));
        }
        if let Some(x) = self
            .table_feeds_mm_min
            .iter()
            .flatten()
            .find(|x| !(x.is_finite() && **x > 0.0))
        {
            return Err(AppError::invalid(
                "table_feeds_mm_min",
                format!("{}: {x} is not a positive feed", name("table_feeds_mm_min")),
            ));
        }
        if !(16..=1_000_000).contains(&self.samples_per_lead) {
            return Err(AppError::invalid(
                "samples_per_lead",
                format!(
                    "{} {} is not in 16..=1000000",
                    name("samples_per_lead"),
                    self.samples_per_lead
                ),
            ));
        }
        match (&self.breaks_mm, &self.orders) {
            (Some(_), None) => {
                return Err(AppError::invalid(
                    "breaks_mm",
                    format!(
                        "{} needs {} (one per interval)",
                        name("breaks_mm"),
                        name("orders")
                    ),
                ))
            }
            (b, Some(o)) => {
                let n = b.as_ref().map_or(0, Vec::len) + 1;
                if o.len() != n {
                    return Err(AppError::invalid(
                        "orders",
                        format!(
                            "{} has {} values; {n} intervals need {n}",
                            name("orders"),
                            o.len()
                        ),
                    ));
                }
            }
            (None, None) => {}
        }
        let map = MapParams {
            breaks_mm: self.breaks_mm.clone(),
            orders: self.orders.clone(),
            margin_mm: self.margin_mm,
            feed_order: self.feed_order,
            feed_scale: self.feed_scale,
            ..MapParams::default()
        };
        map.validate().map_err(AppError::from_error)?;
        Ok(MapStudyParams {
            map,
            positions_mm: self.positions_mm.clone(),
            position_step_mm: self.position_step_mm,
            table_feeds_mm_min: self.table_feeds_mm_min.clone(),
            extrapolate: self.extrapolate,
            ..MapStudyParams::default()
        })
    }

    fn estimate_params(&self) -> EstimateParams {
        EstimateParams {
            samples_per_lead: self.samples_per_lead,
            ..EstimateParams::default()
        }
    }
}

impl MapRequest {
    /// Check the request without reading anything.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field: the export's settings
    /// ([`ExportOptions::validate`]), an export position or curve without an export, an empty
    /// path, a setting out of range.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        self.checked(front).map(|_| ())
    }

    /// [`MapRequest::validate`], giving the export's plan.
    fn checked(&self, front: &dyn FrontEnd) -> Result<Option<ExportPlan>, AppError> {
        let plan = self.export.validate(front)?;
        if plan.is_none() {
            let only = |field: &'static str| {
                AppError::invalid(
                    field,
                    format!(
                        "{} is used only with {}",
                        front.name(field),
                        front.name("export")
                    ),
                )
            };
            if self.export_position_mm.is_some() {
                return Err(only("export_position_mm"));
            }
            if self.export_curve != ExportCurve::default() {
                return Err(only("export_curve"));
            }
        }
        for (field, p) in [("index", &self.index), ("axis", &self.axis)] {
            if p.as_os_str().is_empty() {
                return Err(AppError::invalid(
                    field,
                    format!("{} names no file", front.name(field)),
                ));
            }
        }
        self.options.study_params(front)?;
        Ok(plan)
    }

    /// Read the axis and the index, estimate every run, map, and make the controller files
    /// asked for.
    ///
    /// # Errors
    /// As [`MapRequest::validate`], [`map_set`], [`Mapped::export_at`] and [`export_files`];
    /// the readers' errors naming the file and line.
    pub fn run(&self, front: &dyn FrontEnd) -> Result<Mapped, AppError> {
        let plan = self.checked(front)?;
        let axis = feedscope_io::axis::load(&self.axis).map_err(AppError::from_error)?;
        // A position outside the declared travel is wrong whatever the data say: refused
        // before the index is read.
        in_travel(
            &axis,
            "positions_mm",
            self.options.positions_mm.as_deref(),
            front,
        )?;
        let set = read_index(&self.index).map_err(AppError::from_error)?;
        let mut mapped = map_set(&set, &axis, &self.options, front)?;
        if let Some(plan) = &plan {
            let at = mapped.export_at(self.export_position_mm, self.export_curve, front)?;
            mapped.exports = export_files(
                plan,
                &ExportCurves {
                    table: &at.table,
                    stribeck: &at.stribeck,
                },
                &mapped.axis,
                at.drive,
                &ExportSource {
                    source: &at.source,
                    axis_name: mapped.axis.name.as_deref(),
                },
                front,
            )?;
        }
        Ok(mapped)
    }
}

/// Refuse positions outside the axis file's travel, when it declares one.
fn in_travel(
    axis: &AxisParams,
    field: &'static str,
    positions_mm: Option<&[f64]>,
    front: &dyn FrontEnd,
) -> Result<(), AppError> {
    let (Some(lo), Some(hi)) = (axis.travel_min_mm, axis.travel_max_mm) else {
        return Ok(());
    };
    match positions_mm
        .unwrap_or(&[])
        .iter()
        .find(|&&x| x < lo || x > hi)
    {
        Some(x) => Err(AppError::invalid(
            field,
            format!(
                "{}: {x} mm is outside the axis travel [{lo}, {hi}] mm",
                front.name(field)
            ),
        )),
        None => Ok(()),
    }
}

/// Estimate every run of `set` in parallel and map those that worked.
///
/// Runs that fail are listed in the report's summary (and `runs.csv`) and the others mapped;
/// each failure and each reader's warning is also a [`FrontEnd::notice`] as soon as it is known.
///
/// # Errors
/// As [`MapOptions::study_params`]; a position outside the axis travel; every run failed
/// ([`ErrorKind::Internal`], the binary's exit code 1); the study's refusal (a position
/// outside the mapped travel names `positions_mm`, a table feed beyond the measured feeds
/// `table_feeds_mm_min`, anything else the index).
pub fn map_set(
    set: &TestSet,
    axis: &AxisParams,
    options: &MapOptions,
    front: &dyn FrontEnd,
) -> Result<Mapped, AppError> {
    let params = options.study_params(front)?;
    in_travel(axis, "positions_mm", options.positions_mm.as_deref(), front)?;
    let total = set.runs.len();
    let done = AtomicUsize::new(0);
    front.progress("estimate", 0, total);
    let estimate = estimate_set(
        set,
        axis,
        &options.estimate_params(),
        &ReadOptions::default(),
        params.map.stroke_feed_tolerance,
        &|_| front.progress("estimate", done.fetch_add(1, Ordering::Relaxed) + 1, total),
    );
    // Said as they are known: when every run failed, they are the only explanation.
    for w in &estimate.read_warnings {
        front.notice(&format!("run {}: {}", w.run, w.message));
    }
    for f in &estimate.failed {
        front.notice(&format!("run {} failed: {}", f.run.name, f.error));
    }
    if estimate.ok.is_empty() {
        return Err(AppError::failed(format!(
            "all {total} runs of {} failed; nothing to map",
            set.source_name
        )));
    }
    front.stage("mapping");
    let study = map_study(&estimate.ok, axis.lead_m(), &params).map_err(|e| match e {
        StudyError::Position(e) => {
            AppError::within(front.name("positions_mm"), e).for_field("positions_mm")
        }
        StudyError::TableFeed(e) => AppError::within(
            format!(
                "{}, without {}",
                front.name("table_feeds_mm_min"),
                front.name("extrapolate")
            ),
            e,
        )
        .for_field("table_feeds_mm_min"),
        e => AppError::within(set.source_name.clone(), e),
    })?;
    let report = MapReport {
        summary: MapSummary::new(set, &estimate, &study.map, &study.nonconventional),
        map: study.map.clone(),
    };
    let stribeck = MapStribeckReport::new(&study.at_positions, &study.nonconventional);
    Ok(Mapped {
        report,
        stribeck,
        study,
        estimate,
        params,
        axis: axis.clone(),
        exports: Vec::new(),
    })
}

/// What a map gives.
#[derive(Debug, Clone)]
pub struct Mapped {
    /// `map.json`.
    pub report: MapReport,
    /// `stribeck.json`.
    pub stribeck: MapStribeckReport,
    /// The study: the map, the Stribeck fits and the grids, for plots and tables.
    pub study: MapStudy,
    /// Every run's estimate or failure, and the readers' warnings.
    pub estimate: SetEstimate,
    /// The study's parameters.
    pub params: MapStudyParams,
    /// The axis mapped.
    pub axis: AxisParams,
    /// The controller files the request asked for, not yet written (empty from
    /// [`map_set`]).
    pub exports: Vec<ExportFile>,
}

/// The curve a controller export tabulates at its position.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExportCurve {
    /// The Stribeck fit at the position (Eq. 9; the reduced model where the feeds do not
    /// determine one).
    #[default]
    Stribeck,
    /// The map's section at the position (Eq. 6 with the feed polynomial of Eq. 8).
    Map,
}

/// The friction curves of one position, ready for a controller's file.
#[derive(Debug, Clone)]
pub struct ExportAt {
    /// The position (mm).
    pub position_mm: f64,
    /// Curves of the tables, forward first: the Stribeck fits or the map's sections.
    pub table: Vec<FrictionCurve>,
    /// Stribeck curves, forward first (what SINUMERIK starting values need).
    pub stribeck: Vec<FrictionCurve>,
    /// Force to motor torque and current, from the axis.
    pub drive: DriveConversion,
    /// Where the curves come from, for the files' headers.
    pub source: String,
}

impl Mapped {
    /// The curves an export tabulates at `position_mm` (default: the middle of the span both
    /// directions share): per direction the Stribeck fit there and, with [`ExportCurve::Map`],
    /// the map's section for the tables.
    ///
    /// # Errors
    /// Bad input naming `export_position_mm`: outside the axis travel or the mapped span, no
    /// shared span to default to, a failed Stribeck fit there; the axis lacking what the
    /// torque and current conversion needs.
    pub fn export_at(
        &self,
        position_mm: Option<f64>,
        curve: ExportCurve,
        front: &dyn FrontEnd,
    ) -> Result<ExportAt, AppError> {
        const FIELD: &str = "export_position_mm";
        if let Some(z) = position_mm.filter(|z| !z.is_finite()) {
            return Err(AppError::invalid(
                FIELD,
                format!("{}: {z} is not a finite position", front.name(FIELD)),
            ));
        }
        in_travel(&self.axis, FIELD, position_mm.as_slice().into(), front)?;
        let export = front.name("export");
        let dirs = &self.study.map.directions;
        let lo = dirs
            .iter()
            .map(|d| d.start_mm)
            .fold(f64::NEG_INFINITY, f64::max);
        let hi = dirs.iter().map(|d| d.end_mm).fold(f64::INFINITY, f64::min);
        let z = match position_mm {
            Some(z) => z,
            None if hi >= lo => 0.5 * (lo + hi),
            None => {
                return Err(AppError::invalid(
                    FIELD,
                    format!(
                        "{export}: the directions' mapped spans do not overlap ({}); give {}",
                        dirs.iter()
                            .map(|d| format!(
                                "{} {:.3}-{:.3} mm",
                                d.direction.as_str(),
                                d.start_mm,
                                d.end_mm
                            ))
                            .collect::<Vec<_>>()
                            .join(", "),
                        front.name(FIELD)
                    ),
                ))
            }
        };
        let mut table = Vec::new();
        let mut stribeck = Vec::new();
        for d in dirs {
            let profile = stribeck_profile(d, &[z], &self.params.map)
                .map_err(|e| AppError::within(front.name(FIELD), e).for_field(FIELD))?;
            let at = &profile.positions[0];
            let fit = at.fit.as_ref().ok_or_else(|| {
                AppError::invalid(
                    FIELD,
                    format!(
                        "{export}: the {} Stribeck fit at {z:.3} mm failed: {}",
                        d.direction.as_str(),
                        at.error.clone().unwrap_or_default()
                    ),
                )
            })?;
            let s = FrictionCurve::from_stribeck(d.direction, fit).map_err(|e| {
                AppError::within(
                    format!("{export}: the {} fit at {z:.3} mm", d.direction.as_str()),
                    e,
                )
            })?;
            table.push(match curve {
                ExportCurve::Stribeck => s.clone(),
                ExportCurve::Map => FrictionCurve::from_map_section(d, z)
                    .map_err(|e| AppError::within(front.name(FIELD), e).for_field(FIELD))?,
            });
            stribeck.push(s);
        }
        let drive = DriveConversion::from_axis(&self.axis, 1.0)
            .map_err(|e| AppError::within(format!("{export}: the axis file"), e))?;
        let source = format!(
            "feedscope map {} at {z:.3} mm, {}",
            self.report.summary.index,
            match curve {
                ExportCurve::Stribeck => "Stribeck fit at the position",
                ExportCurve::Map => "map section at the position",
            }
        );
        Ok(ExportAt {
            position_mm: z,
            table,
            stribeck,
            drive,
            source,
        })
    }
}

// ---------- map.json ----------

/// `map.json`: the summary and the map itself.
#[derive(Debug, Clone, Serialize)]
pub struct MapReport {
    /// Runs, failures and per direction the map's shape.
    pub summary: MapSummary,
    /// The friction map F(z, v): per direction the breakpoints, every feed's PPOCM and
    /// repeatability, the feed polynomial of every coefficient.
    pub map: FrictionMap,
}

/// What was mapped, and what failed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MapSummary {
    /// The index file.
    pub index: String,
    /// Runs in the index.
    pub runs: usize,
    /// Runs estimated.
    pub runs_ok: usize,
    /// Runs that failed, with why.
    pub failed: Vec<FailedRun>,
    /// Per direction mapped.
    pub directions: Vec<DirectionSummary>,
    /// Number of non-conventional spans.
    pub nonconventional_spans: usize,
}

/// A run that could not be estimated.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FailedRun {
    /// Its name in the index.
    pub file: String,
    /// Why.
    pub error: String,
}

/// One direction of the map in brief.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DirectionSummary {
    /// The direction.
    pub direction: Direction,
    /// Start of the mapped span (mm).
    pub start_mm: f64,
    /// End of the mapped span (mm).
    pub end_mm: f64,
    /// Interval bounds, ends included (mm).
    pub breaks_mm: Vec<f64>,
    /// Polynomial order per interval.
    pub orders: Vec<usize>,
    /// Measured feeds (mm/min), ascending.
    pub feeds_mm_min: Vec<f64>,
    /// Repeats per feed.
    pub repeats: Vec<usize>,
    /// Order of the feed polynomial used.
    pub feed_order: usize,
    /// Its scaled feed variable.
    pub feed_scale: FeedScale,
    /// RMS misfit of the feed polynomial to the PPOCM (N).
    pub feed_misfit_rms_n: f64,
    /// Largest misfit (N).
    pub feed_misfit_max_n: f64,
    /// Worst repeatability (RMS of the pointwise std of the repeats, N); `None` with one
    /// repeat per feed.
    pub worst_repeatability_std_n: Option<f64>,
}

impl MapSummary {
    fn new(
        set: &TestSet,
        est: &SetEstimate,
        map: &FrictionMap,
        spans: &[NonConventionalSpan],
    ) -> Self {
        Self {
            index: set.source_name.clone(),
            runs: set.runs.len(),
            runs_ok: est.ok.len(),
            failed: est
                .failed
                .iter()
                .map(|f| FailedRun {
                    file: f.run.name.clone(),
                    error: f.error.clone(),
                })
                .collect(),
            directions: map
                .directions
                .iter()
                .map(|d| DirectionSummary {
                    direction: d.direction,
                    start_mm: d.start_mm,
                    end_mm: d.end_mm,
                    breaks_mm: d.breaks_mm.clone(),
                    orders: d.orders.clone(),
                    feeds_mm_min: d.feeds_mm_min(),
                    repeats: d.feeds.iter().map(|g| g.repeats.len()).collect(),
                    feed_order: d.feed_model.order,
                    feed_scale: d.feed_model.scale,
                    feed_misfit_rms_n: d.feed_model.rms_misfit_n,
                    feed_misfit_max_n: d.feed_model.max_misfit_n,
                    worst_repeatability_std_n: d
                        .feeds
                        .iter()
                        .flat_map(|g| g.repeatability.iter().filter_map(|r| r.std_n))
                        .reduce(f64::max),
                })
                .collect(),
            nonconventional_spans: spans.len(),
        }
    }
}

// ---------- stribeck.json ----------

/// `stribeck.json` of a map: the Stribeck fit (Eq. 9) of every direction at the chosen
/// positions, with uncertainties, and the non-conventional spans.
#[derive(Debug, Clone, Serialize)]
pub struct MapStribeckReport {
    /// The model, in words.
    pub model: &'static str,
    /// Units and what is null.
    pub conventions: &'static str,
    /// Per direction.
    pub directions: Vec<DirectionStribeck>,
    /// Position spans where friction falls with feed although the Stribeck curve rises.
    pub nonconventional_spans: Vec<NonConventionalSpan>,
}

/// The Stribeck fits of one direction.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DirectionStribeck {
    /// The direction.
    pub direction: Direction,
    /// The measured feeds, the fits' data points (mm/min).
    pub feeds_mm_min: Vec<f64>,
    /// The fit at each position.
    pub positions: Vec<PositionFit>,
}

/// A parameter with its uncertainty (`None` where the fit has no residual degrees of freedom).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PositionEstimate {
    /// The value.
    pub value: f64,
    /// Its standard error.
    pub std_error: Option<f64>,
    /// Lower end of its 95 % interval.
    pub ci95_low: Option<f64>,
    /// Upper end of its 95 % interval.
    pub ci95_high: Option<f64>,
}

impl PositionEstimate {
    fn new(value: f64, u: Option<&ParamEstimate>, scale: f64) -> Self {
        Self {
            value: value * scale,
            std_error: u.map(|u| u.std_error * scale),
            ci95_low: u.map(|u| u.ci95_low * scale),
            ci95_high: u.map(|u| u.ci95_high * scale),
        }
    }
}

/// A feed range where the friction falls although the Stribeck curve rises.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Fall {
    /// Start (mm/min).
    pub from_mm_min: f64,
    /// End (mm/min).
    pub to_mm_min: f64,
    /// Fall of the PPOCM values (N).
    pub drop_n: f64,
    /// The fall beyond the curve's (N).
    pub excess_drop_n: f64,
}

/// The Stribeck fit at one position; parameters the reported model does not have are `None`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PositionFit {
    /// The position (mm).
    pub position_mm: f64,
    /// `stribeck`, `coulomb-viscous` or `coulomb`; `None` when the fit failed.
    pub model: Option<&'static str>,
    /// Richer models refused, in the order tried, and why.
    pub reductions: Vec<Diagnostic>,
    /// F_c (N).
    pub fc_n: Option<PositionEstimate>,
    /// F_s (N).
    pub fs_n: Option<PositionEstimate>,
    /// F_s − F_c (N).
    pub static_excess_n: Option<PositionEstimate>,
    /// v_s (mm/min).
    pub vs_mm_min: Option<PositionEstimate>,
    /// σ (N·s/m).
    pub sigma_n_s_per_m: Option<PositionEstimate>,
    /// RMS residual of the fit (N).
    pub residual_rms_n: Option<f64>,
    /// |PPOCM| of every measured feed at the position (N).
    pub friction_n: Vec<f64>,
    /// The fit's warnings.
    pub warnings: Vec<Diagnostic>,
    /// Falls of friction with feed where the curve rises.
    pub nonconventional: Vec<Fall>,
    /// Why the fit failed.
    pub error: Option<String>,
}

impl PositionFit {
    fn new(p: &StribeckAtPosition) -> Self {
        let f = p.fit.as_ref();
        let u = f.and_then(|f| f.uncertainty.as_ref());
        let mm = 1.0 / M_S_PER_MM_MIN;
        let hump = f.filter(|f| f.model == FrictionModel::Stribeck);
        let viscous = f.filter(|f| f.model != FrictionModel::Coulomb);
        let est = PositionEstimate::new;
        Self {
            position_mm: p.position_mm,
            model: f.map(|f| f.model.code()),
            reductions: f
                .map(|f| f.reductions.iter().map(Diagnostic::from).collect())
                .unwrap_or_default(),
            fc_n: f.map(|f| est(f.params.fc_n, u.map(|u| &u.fc_n), 1.0)),
            fs_n: hump.map(|f| est(f.params.fs_n, u.and_then(|u| u.fs_n.as_ref()), 1.0)),
            static_excess_n: hump.map(|f| {
                est(
                    f.params.static_excess_n(),
                    u.and_then(|u| u.static_excess_n.as_ref()),
                    1.0,
                )
            }),
            vs_mm_min: hump.map(|f| est(f.params.vs_m_s, u.and_then(|u| u.vs_m_s.as_ref()), mm)),
            sigma_n_s_per_m: viscous.map(|f| {
                est(
                    f.params.sigma_n_s_per_m,
                    u.and_then(|u| u.sigma_n_s_per_m.as_ref()),
                    1.0,
                )
            }),
            residual_rms_n: f.map(|f| f.residual_rms_n),
            friction_n: p.friction_n.clone(),
            warnings: f
                .map(|f| f.warnings.iter().map(Diagnostic::from).collect())
                .unwrap_or_default(),
            nonconventional: p
                .nonconventional
                .iter()
                .flat_map(|n| &n.ranges)
                .map(|r| Fall {
                    from_mm_min: r.from_mm_min(),
                    to_mm_min: r.to_mm_min(),
                    drop_n: r.drop_n,
                    excess_drop_n: r.excess_drop_n,
                })
                .collect(),
            error: p.error.clone(),
        }
    }
}

impl MapStribeckReport {
    fn new(at: &[StribeckProfile], spans: &[NonConventionalSpan]) -> Self {
        Self {
            model: "F(v) = Fc + (Fs - Fc)*exp(-(v/vs)^2) + sigma*v on friction magnitudes \
                    (paper 000 Eq. 9); where the feeds do not determine it, the Coulomb + \
                    viscous line F = Fc + sigma*v (positions[].model, the reasons in \
                    positions[].reductions)",
            conventions: "data points: |PPOCM(z)| of every measured feed at the position; \
                          forces in N, feeds and vs in mm/min, sigma in N*s/m; std_error and \
                          95 % intervals null when the fit has no residual degrees of freedom; \
                          parameters the reported model does not have are null",
            directions: at
                .iter()
                .map(|p| DirectionStribeck {
                    direction: p.direction,
                    feeds_mm_min: p.feeds_mm_min.clone(),
                    positions: p.positions.iter().map(PositionFit::new).collect(),
                })
                .collect(),
            nonconventional_spans: spans.to_vec(),
        }
    }
}

// ---------- the files ----------

impl Mapped {
    /// Every file of the map but the plots and exports, as (name, content): `stribeck.json`,
    /// `stribeck_profile.csv`, `compensation.csv` and `compensation_<direction>.csv`,
    /// `ppocm.csv`, `repeatability.csv`, `runs.csv` and `map.json`.
    ///
    /// # Errors
    /// The compensation table refusing a feed (only for a study built with other
    /// parameters than its own).
    pub fn files(&self) -> Result<Vec<(String, String)>, AppError> {
        let mut files = vec![
            ("stribeck.json".to_string(), pretty(&self.stribeck)?),
            (
                "stribeck_profile.csv".to_string(),
                self.stribeck_profile_csv(),
            ),
        ];
        files.extend(self.compensation_csvs()?);
        files.push(("ppocm.csv".to_string(), self.ppocm_csv()));
        files.push(("repeatability.csv".to_string(), self.repeatability_csv()));
        files.push(("runs.csv".to_string(), self.runs_csv()));
        files.push(("map.json".to_string(), pretty(&self.report)?));
        Ok(files)
    }

    /// `stribeck_profile.csv`: the Stribeck fit at every map grid position.
    pub fn stribeck_profile_csv(&self) -> String {
        let mut w = String::new();
        w.push_str("# Stribeck fit (paper 000 Eq. 9, delta = 2) at every map grid position; forces in N, vs in mm/min, sigma in N*s/m; *_se = standard error\n");
        w.push_str("# model: stribeck, or coulomb-viscous (F = Fc + sigma*v; fs, vs empty) where the feeds do not determine a Stribeck curve (reasons in stribeck.json)\n");
        w.push_str("direction,position_mm,model,fc_n,fc_se_n,fs_n,fs_se_n,static_excess_n,static_excess_se_n,vs_mm_min,vs_ci95_low_mm_min,vs_ci95_high_mm_min,sigma_n_s_per_m,sigma_se_n_s_per_m,residual_rms_n,nonconventional,warnings\n");
        let mm = 1.0 / M_S_PER_MM_MIN;
        for p in &self.study.profiles {
            for q in &p.positions {
                let Some(fit) = &q.fit else {
                    let _ = writeln!(
                        w,
                        "{},{:.6},,,,,,,,,,,,,,,fit failed: {}",
                        p.direction.as_str(),
                        q.position_mm,
                        q.error.clone().unwrap_or_default().replace(',', ";")
                    );
                    continue;
                };
                let u = fit.uncertainty.as_ref();
                let nc = q.nonconventional.as_ref().map_or(0, |n| n.ranges.len());
                let warn: Vec<String> = fit
                    .warnings
                    .iter()
                    .map(|w| w.to_string().replace(',', ";"))
                    .collect();
                let hump = fit.model == FrictionModel::Stribeck;
                let _ = writeln!(
                    w,
                    "{},{:.6},{},{:.6},{},{},{},{},{},{},{},{},{},{},{:.6},{},{}",
                    p.direction.as_str(),
                    q.position_mm,
                    fit.model.code(),
                    fit.params.fc_n,
                    opt(u.map(|u| u.fc_n.std_error)),
                    opt(fit.fs_n()),
                    opt(u.and_then(|u| u.fs_n).map(|e| e.std_error)),
                    opt(hump.then(|| fit.params.static_excess_n())),
                    opt(u.and_then(|u| u.static_excess_n).map(|e| e.std_error)),
                    opt(fit.vs_m_s().map(|v| v * mm)),
                    opt(u.and_then(|u| u.vs_m_s).map(|e| e.ci95_low * mm)),
                    opt(u.and_then(|u| u.vs_m_s).map(|e| e.ci95_high * mm)),
                    opt(fit.sigma_n_s_per_m()),
                    opt(u.and_then(|u| u.sigma_n_s_per_m).map(|e| e.std_error)),
                    fit.residual_rms_n,
                    nc,
                    warn.join(" | ")
                );
            }
        }
        w
    }

    /// The compensation table: `compensation.csv` (long) and `compensation_<direction>.csv`
    /// (matrix: rows positions, columns feeds), as (name, content).
    ///
    /// # Errors
    /// The table refusing a feed outside the measured ones without extrapolation.
    pub fn compensation_csvs(&self) -> Result<Vec<(String, String)>, AppError> {
        let map = &self.study.map;
        let table = CompensationTable::new(map, self.params.extrapolate, |d| {
            self.study
                .table_axes(d.direction)
                .map(|(grid, feeds)| (feeds.to_vec(), grid.to_vec()))
                .unwrap_or_default()
        })
        .map_err(|e| AppError::within("the compensation table", e))?;
        let text = |write: &dyn Fn(&mut Vec<u8>) -> std::io::Result<()>| {
            let mut bytes = Vec::new();
            // Writing into memory cannot fail, and the writers write UTF-8.
            write(&mut bytes).map_err(|e| AppError::caused(ErrorKind::Internal, "writing", e))?;
            String::from_utf8(bytes).map_err(|e| AppError::caused(ErrorKind::Internal, "UTF-8", e))
        };
        let mut files = vec![(
            "compensation.csv".to_string(),
            text(&|b| table.write_long(b))?,
        )];
        for d in &map.directions {
            files.push((
                format!("compensation_{}.csv", d.direction.as_str()),
                text(&|b| table.write_matrix(b, d.direction))?,
            ));
        }
        Ok(files)
    }

    /// `ppocm.csv`: the mean Legendre coefficients of every feed.
    pub fn ppocm_csv(&self) -> String {
        let mut w = String::new();
        w.push_str("# PPOCM: mean Legendre coefficients (N) of the repeats' IAFV per feed; in interval [start_mm, end_mm], F = sum_k coefficient_n * P_k(t), t = 2*(z - start_mm)/(end_mm - start_mm) - 1\n");
        w.push_str("direction,feed_mm_min,repeats,interval,start_mm,end_mm,k,coefficient_n\n");
        for d in &self.study.map.directions {
            for g in &d.feeds {
                for (j, c) in g.ppocm.coeffs_n.iter().enumerate() {
                    for (k, v) in c.iter().enumerate() {
                        let _ = writeln!(
                            w,
                            "{},{:.6},{},{},{:.6},{:.6},{},{:.9}",
                            d.direction.as_str(),
                            g.feed_mm_min,
                            g.repeats.len(),
                            j + 1,
                            d.breaks_mm[j],
                            d.breaks_mm[j + 1],
                            k,
                            v
                        );
                    }
                }
            }
        }
        w
    }

    /// `repeatability.csv`: per feed and interval, how far the repeats' IAFV spread.
    pub fn repeatability_csv(&self) -> String {
        let mut w = String::new();
        w.push_str("# repeatability per interval: std_n = RMS over the interval of the pointwise sample std of the repeats' IAFV (N); max_spread_n = largest pointwise max - min (N); mean_n = mean of the PPOCM (N, signed)\n");
        w.push_str(
            "direction,feed_mm_min,repeats,interval,start_mm,end_mm,mean_n,std_n,max_spread_n\n",
        );
        for d in &self.study.map.directions {
            for g in &d.feeds {
                for (j, r) in g.repeatability.iter().enumerate() {
                    let _ = writeln!(
                        w,
                        "{},{:.6},{},{},{:.6},{:.6},{:.6},{},{:.6}",
                        d.direction.as_str(),
                        g.feed_mm_min,
                        g.repeats.len(),
                        j + 1,
                        r.start_mm,
                        r.end_mm,
                        r.mean_n,
                        opt(r.std_n),
                        r.max_spread_n
                    );
                }
            }
        }
        w
    }

    /// `runs.csv`: every run of the index, estimated or failed, with its messages.
    pub fn runs_csv(&self) -> String {
        let mut w = String::from("file,feed_mm_min,repeat,status,strokes,message\n");
        let clean = |s: &str| s.replace([',', '\n'], ";");
        for r in &self.estimate.ok {
            let _ = writeln!(
                w,
                "{},{},{},ok,{},{}",
                r.run.name,
                r.run.feed_mm_min,
                r.run.repeat,
                r.strokes.len(),
                clean(
                    &r.warnings
                        .iter()
                        .map(|w| w.message.as_str())
                        .collect::<Vec<_>>()
                        .join(" | ")
                )
            );
        }
        for r in &self.estimate.failed {
            let _ = writeln!(
                w,
                "{},{},{},failed,0,{}",
                r.run.name,
                r.run.feed_mm_min,
                r.run.repeat,
                clean(&r.error)
            );
        }
        w
    }
}

fn pretty(value: &impl Serialize) -> Result<String, AppError> {
    serde_json::to_string_pretty(value)
        .map_err(|e| AppError::caused(ErrorKind::Internal, "writing JSON", e))
}

fn opt(x: Option<f64>) -> String {
    x.map_or_else(String::new, |v| format!("{v:.6}"))
}
