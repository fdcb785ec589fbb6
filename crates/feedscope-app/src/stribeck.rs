//! Fit Stribeck curves to a steady-speed table, each direction on its own (paper 000 Eq. 9,
//! paper 001 Eq. 15), with the non-conventional check of paper 001.
//!
//! [`FitStribeckRequest`] names the files; [`fit_table`] takes a table already parsed (the
//! Python module's arrays). Both give a [`StribeckFits`]: the [`StribeckReport`], which is
//! `stribeck.json`, and the fits themselves; the request also makes the controller files it
//! asks for ([`crate::compensation`]). The report's plain-text view is its `Display` (the
//! table of parameters) and [`StribeckReport::remarks`] (models, refusals, warnings).
use std::fmt;
use std::path::PathBuf;

use feedscope::axis::AxisParams;
use feedscope::compensation::{DriveConversion, FrictionCurve};
use feedscope::diag::{Code, Diagnostic};
use feedscope::estimate::Direction;
use feedscope::stribeck::{
    detect_nonconventional, DeltaMode, NonConventional, NonConventionalParams, ParamEstimate,
    StribeckFit, StribeckFitParams, StribeckFitter, StribeckParams, Termination, M_S_PER_MM_MIN,
};
use feedscope::ErrorKind;
use feedscope_io::controller_compensation::ExportSource;
use feedscope_io::stribeck_table::{
    self, EffortColumn, SpeedPoints, SteadySpeedTable, TableOptions,
};
use serde::{Deserialize, Serialize};

use crate::compensation::{export_files, ExportCurves, ExportFile, ExportOptions};
use crate::{AppError, FrontEnd};

/// Fit a steady-speed table file.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FitStribeckRequest {
    /// The table (CSV: `feed_mm_min`, `torque_nm` or `force_n`, optionally `direction`).
    pub table: PathBuf,
    /// Axis parameters (TOML or JSON), for the lead.
    pub axis: Option<PathBuf>,
    /// Settings of the fit.
    #[serde(flatten)]
    pub options: FitStribeckOptions,
    /// Controller files to make from the fitted curves (they need `axis`: its lead and
    /// torque constant, and for sinumerik its masses).
    #[serde(flatten)]
    pub export: ExportOptions,
}

/// Settings of the fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FitStribeckOptions {
    /// Screw lead p (mm), for a `torque_nm` table (or the axis file's).
    pub lead_mm: Option<f64>,
    /// Transmission efficiency η in (0, 1]: F = 2π·η·T/p (paper 001 Eq. 15). Default 1.
    pub efficiency: f64,
    /// The shape exponent δ: fixed (default 2) or fitted.
    pub delta: DeltaMode,
    /// Noise standard deviation of one friction value (N) for the non-conventional check;
    /// `None` estimates it from the residuals.
    pub noise_n: Option<f64>,
}

impl Default for FitStribeckOptions {
    fn default() -> Self {
        Self {
            lead_mm: None,
            efficiency: 1.0,
            delta: DeltaMode::Fixed(2.0),
            noise_n: None,
        }
    }
}

impl FitStribeckOptions {
    /// Check the settings.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the setting as the front end spells it.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        if let Some(s) = self.noise_n {
            if !(s.is_finite() && s >= 0.0) {
                let name = front.name("noise_n");
                return Err(AppError::invalid(
                    "noise_n",
                    format!("{name} must be >= 0, got {s}"),
                ));
            }
        }
        if let DeltaMode::Fixed(d) = self.delta {
            if !(d.is_finite() && d > 0.0) {
                let name = front.name("delta");
                return Err(AppError::invalid(
                    "delta",
                    format!("{name}: expected a positive number or `free`, got `{d}`"),
                ));
            }
        }
        Ok(())
    }

    /// The lead to use: the axis's, or `lead_mm`; both must agree when both are given.
    /// `axis` is the axis with the name of where it came from.
    ///
    /// # Errors
    /// Bad input naming `lead_mm` when the two disagree.
    pub fn lead_mm(
        &self,
        axis: Option<(&AxisParams, &str)>,
        front: &dyn FrontEnd,
    ) -> Result<Option<f64>, AppError> {
        match (axis, self.lead_mm) {
            (Some((a, source)), Some(l)) if (a.lead_mm - l).abs() > 1e-9 * a.lead_mm.abs() => {
                Err(AppError::invalid(
                    "lead_mm",
                    format!(
                        "{} {l} disagrees with lead_mm = {} of {source}",
                        front.name("lead_mm"),
                        a.lead_mm
                    ),
                ))
            }
            (Some((a, _)), _) => Ok(Some(a.lead_mm)),
            (None, l) => Ok(l),
        }
    }

    /// How a table is read with these settings and `lead_mm`.
    pub fn table_options(&self, lead_mm: Option<f64>) -> TableOptions {
        TableOptions {
            lead_mm,
            efficiency: self.efficiency,
        }
    }
}

impl FitStribeckRequest {
    /// Read the axis (when given) and the table, fit, and make the controller files asked
    /// for.
    ///
    /// # Errors
    /// As [`ExportOptions::validate`] (first, before anything is read),
    /// [`FitStribeckOptions::validate`] and [`fit_table`]; an export without `axis`; the
    /// readers' errors naming the file and line; a lead that disagrees with the axis file's;
    /// a curve or an axis an export cannot use ([`export_files`]).
    pub fn run(&self, front: &dyn FrontEnd) -> Result<StribeckFits, AppError> {
        let export = self.export.validate(front)?;
        if export.is_some() && self.axis.is_none() {
            return Err(AppError::invalid(
                "axis",
                format!(
                    "{} needs {}: its lead_mm and torque_constant_nm_per_a turn friction into \
                     motor torque and current (and table_mass_kg, inertia_kgm2 set the \
                     SINUMERIK amplitude)",
                    front.name("export"),
                    front.spell("axis", "AXIS.toml")
                ),
            ));
        }
        if self.table.as_os_str().is_empty() {
            return Err(AppError::invalid("table", "`table` names no file"));
        }
        self.options.validate(front)?;
        let axis = match &self.axis {
            Some(p) => Some(feedscope_io::axis::load(p).map_err(AppError::from_error)?),
            None => None,
        };
        let axis_name = self.axis.as_ref().map(|p| p.display().to_string());
        let lead_mm = self
            .options
            .lead_mm(axis.as_ref().zip(axis_name.as_deref()), front)?;
        front.stage(&format!("reading {}", self.table.display()));
        let table = stribeck_table::read(&self.table, &self.options.table_options(lead_mm))
            .map_err(AppError::from_error)?;
        let mut fits = fit_table(
            &table,
            &self.table.display().to_string(),
            lead_mm,
            &self.options,
            front,
        )?;
        fits.axis = axis;
        if let (Some(plan), Some(axis)) = (&export, &fits.axis) {
            let name = &fits.report.source;
            let export = front.name("export");
            let curves = fits
                .fits
                .iter()
                .map(|(dir, fit)| FrictionCurve::from_stribeck(*dir, fit))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| AppError::within(format!("{name}: {export}"), e))?;
            let drive = DriveConversion::from_axis(axis, self.options.efficiency).map_err(|e| {
                AppError::within(
                    format!("{export}: the axis file and {}", front.name("efficiency")),
                    e,
                )
            })?;
            let source = format!("feedscope fit-stribeck {name}");
            fits.exports = export_files(
                plan,
                &ExportCurves {
                    table: &curves,
                    stribeck: &curves,
                },
                axis,
                drive,
                &ExportSource {
                    source: &source,
                    axis_name: axis.name.as_deref(),
                },
                front,
            )?;
        }
        Ok(fits)
    }
}

/// What a fit of a table gives.
#[derive(Debug, Clone)]
pub struct StribeckFits {
    /// `stribeck.json`.
    pub report: StribeckReport,
    /// The fit of each direction present, in the report's order (for exports).
    pub fits: Vec<(Direction, StribeckFit)>,
    /// The axis the request's file gave, if any.
    pub axis: Option<AxisParams>,
    /// The controller files the request asked for, not yet written (empty from
    /// [`fit_table`]).
    pub exports: Vec<ExportFile>,
}

/// Fit each direction of a parsed table; `source` names it in messages and the report.
///
/// # Errors
/// Bad input naming the table and the direction: no data rows, one distinct feed (a level
/// mixes Coulomb and viscous friction: not a curve), a fit the library refuses.
pub fn fit_table(
    table: &SteadySpeedTable,
    source: &str,
    lead_mm: Option<f64>,
    options: &FitStribeckOptions,
    front: &dyn FrontEnd,
) -> Result<StribeckFits, AppError> {
    options.validate(front)?;
    if table.forward.speed_m_s.is_empty() && table.backward.speed_m_s.is_empty() {
        return Err(AppError::bad_input(format!("{source}: no data rows")));
    }
    front.stage("fitting");
    let fit_params = StribeckFitParams {
        delta: options.delta,
        ..StribeckFitParams::default()
    };
    let nc_params = NonConventionalParams {
        noise_n: options.noise_n,
        ..NonConventionalParams::default()
    };
    let mut directions = Vec::new();
    let mut fits = Vec::new();
    for (dir, pts) in [
        (Direction::Forward, &table.forward),
        (Direction::Backward, &table.backward),
    ] {
        if pts.speed_m_s.is_empty() {
            continue;
        }
        let failed = |e: feedscope::stribeck::StribeckError| {
            AppError::caused(
                ErrorKind::BadInput,
                format!("{source}: {} direction: {e}", dir.as_str()),
                e,
            )
        };
        let fitter = StribeckFitter::new(&pts.speed_m_s, &fit_params).map_err(failed)?;
        // One feed gives a level that mixes Coulomb and viscous friction: not a friction
        // curve (the library would report it as a Coulomb level).
        if let [one] = fitter.distinct_speeds_m_s() {
            return Err(AppError::bad_input(format!(
                "{source}: the {} direction has 1 distinct feed ({} mm/min, {} rows); a \
                 friction curve needs at least 2 (Coulomb + viscous), a Stribeck curve at \
                 least 4 (5 with --delta free): measure at more feeds",
                dir.as_str(),
                one / M_S_PER_MM_MIN,
                pts.speed_m_s.len()
            )));
        }
        let fit = fitter.fit(&pts.friction_n).map_err(failed)?;
        let nc = detect_nonconventional(&pts.speed_m_s, &pts.friction_n, &fit, &nc_params)
            .map_err(failed)?;
        directions.push(DirectionFit::new(dir, pts, &fit, &nc));
        fits.push((dir, fit));
    }
    let report = StribeckReport {
        source: source.to_string(),
        input: table.effort,
        lead_mm,
        efficiency: options.efficiency,
        delta: match options.delta {
            DeltaMode::Free => "free".to_string(),
            DeltaMode::Fixed(d) => format!("{d}"),
        },
        directions,
    };
    Ok(StribeckFits {
        report,
        fits,
        axis: None,
        exports: Vec::new(),
    })
}

/// `stribeck.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StribeckReport {
    /// The table's source.
    pub source: String,
    /// Which column carried the effort.
    pub input: EffortColumn,
    /// The lead used for a torque table (mm).
    pub lead_mm: Option<f64>,
    /// The transmission efficiency η used.
    pub efficiency: f64,
    /// δ: a number, or `free`.
    pub delta: String,
    /// The fit of each direction present.
    pub directions: Vec<DirectionFit>,
}

/// A parameter in user units with its uncertainty.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimate {
    /// The value.
    pub value: f64,
    /// Its standard error.
    pub std_error: f64,
    /// Its 95 % interval.
    pub ci95: [f64; 2],
}

impl Estimate {
    fn new(e: &ParamEstimate, scale: f64) -> Self {
        Self {
            value: e.value * scale,
            std_error: e.std_error * scale,
            ci95: [e.ci95_low * scale, e.ci95_high * scale],
        }
    }
}

/// Parameters in user units; `None` when the reported model has no such parameter.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Params {
    /// Coulomb level F_c (N).
    pub fc_n: f64,
    /// Static level F_s (N).
    pub fs_n: Option<f64>,
    /// Stribeck velocity v_s (mm/min).
    pub vs_mm_min: Option<f64>,
    /// Viscous coefficient σ (N·s/m).
    pub sigma_n_s_per_m: Option<f64>,
    /// Shape exponent δ.
    pub delta: Option<f64>,
}

/// The parameters' uncertainties, same units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Uncertainty {
    /// Of F_c (N).
    pub fc_n: Estimate,
    /// Of F_s (N).
    pub fs_n: Option<Estimate>,
    /// Of F_s − F_c (N).
    pub static_excess_n: Option<Estimate>,
    /// Of v_s (mm/min).
    pub vs_mm_min: Option<Estimate>,
    /// Of σ (N·s/m).
    pub sigma_n_s_per_m: Option<Estimate>,
    /// Of δ.
    pub delta: Option<Estimate>,
}

/// A feed range where the friction falls faster than the model (paper 001).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Range {
    /// Start (mm/min).
    pub from_mm_min: f64,
    /// End (mm/min).
    pub to_mm_min: f64,
    /// Points in it.
    pub points: usize,
    /// Fall of the measured friction (N).
    pub drop_n: f64,
    /// Change of the fitted curve over it (N).
    pub fit_change_n: f64,
    /// The fall beyond the curve's (N).
    pub excess_drop_n: f64,
}

/// The non-conventional check of one direction.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NonConv {
    /// Noise of one friction value used (N).
    pub noise_n: f64,
    /// Fall that counts (N).
    pub threshold_n: f64,
    /// Feed above which the curve rises (mm/min).
    pub rising_above_mm_min: f64,
    /// The ranges found.
    pub ranges: Vec<Range>,
}

/// One table point with the fitted value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Point {
    /// Feed (mm/min).
    pub feed_mm_min: f64,
    /// Friction (N).
    pub friction_n: f64,
    /// The reported curve there (N).
    pub fitted_n: f64,
}

/// One direction in `stribeck.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DirectionFit {
    /// `forward` or `backward`.
    pub direction: &'static str,
    /// `stribeck`, `coulomb-viscous` or `coulomb`.
    pub model: &'static str,
    /// Richer models refused, in the order tried, and why.
    pub reductions: Vec<Diagnostic>,
    /// Points fitted.
    pub points: usize,
    /// Lowest feed (mm/min).
    pub feed_min_mm_min: f64,
    /// Highest feed (mm/min).
    pub feed_max_mm_min: f64,
    /// The parameters.
    pub params: Params,
    /// Their uncertainties, when the model determines them.
    pub uncertainty: Option<Uncertainty>,
    /// RMS of the residual (N).
    pub residual_rms_n: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// Iterations of the fit.
    pub iterations: usize,
    /// Why the fit stopped.
    pub termination: Termination,
    /// Condition number of the fit's Jacobian.
    pub condition_number: Option<f64>,
    /// What the result does not support.
    pub warnings: Vec<Diagnostic>,
    /// The non-conventional check.
    pub nonconventional: NonConv,
    /// The points, by feed.
    pub data: Vec<Point>,
    /// The reported curve (SI), for a plot.
    #[serde(skip)]
    pub curve: StribeckParams,
    /// The model's name for people.
    #[serde(skip)]
    pub model_name: String,
}

impl DirectionFit {
    fn new(
        direction: Direction,
        pts: &SpeedPoints,
        fit: &StribeckFit,
        nc: &NonConventional,
    ) -> Self {
        let mm = 1.0 / M_S_PER_MM_MIN;
        let p = &fit.params;
        let mut data: Vec<Point> = pts
            .speed_m_s
            .iter()
            .zip(&pts.friction_n)
            .map(|(&v, &f)| Point {
                feed_mm_min: v * mm,
                friction_n: f,
                fitted_n: p.magnitude_n(v),
            })
            .collect();
        data.sort_by(|a, b| a.feed_mm_min.total_cmp(&b.feed_mm_min));
        Self {
            direction: direction.as_str(),
            model: fit.model.code(),
            reductions: fit.reductions.iter().map(Diagnostic::from).collect(),
            points: fit.points,
            feed_min_mm_min: fit.min_speed_m_s * mm,
            feed_max_mm_min: fit.max_speed_m_s * mm,
            params: Params {
                fc_n: p.fc_n,
                fs_n: fit.fs_n(),
                vs_mm_min: fit.vs_m_s().map(|v| v * mm),
                sigma_n_s_per_m: fit.sigma_n_s_per_m(),
                delta: fit.delta(),
            },
            uncertainty: fit.uncertainty.as_ref().map(|u| Uncertainty {
                fc_n: Estimate::new(&u.fc_n, 1.0),
                fs_n: u.fs_n.as_ref().map(|e| Estimate::new(e, 1.0)),
                static_excess_n: u.static_excess_n.as_ref().map(|e| Estimate::new(e, 1.0)),
                vs_mm_min: u.vs_m_s.as_ref().map(|e| Estimate::new(e, mm)),
                sigma_n_s_per_m: u.sigma_n_s_per_m.as_ref().map(|e| Estimate::new(e, 1.0)),
                delta: u.delta.as_ref().map(|d| Estimate::new(d, 1.0)),
            }),
            residual_rms_n: fit.residual_rms_n,
            dof: fit.dof,
            iterations: fit.iterations,
            termination: fit.termination,
            condition_number: fit.condition_number,
            warnings: fit.warnings.iter().map(Diagnostic::from).collect(),
            nonconventional: NonConv {
                noise_n: nc.noise_n,
                threshold_n: nc.threshold_n,
                rising_above_mm_min: nc.rising_above_m_s * mm,
                ranges: nc
                    .ranges
                    .iter()
                    .map(|r| Range {
                        from_mm_min: r.from_mm_min(),
                        to_mm_min: r.to_mm_min(),
                        points: r.points,
                        drop_n: r.drop_n,
                        fit_change_n: r.fit_change_n,
                        excess_drop_n: r.excess_drop_n,
                    })
                    .collect(),
            },
            data,
            curve: *p,
            model_name: fit.model.to_string(),
        }
    }
}

// ---------- the plain-text view ----------

/// `value ± SE`; a standard error of 1e6 or more in scientific notation so that the table
/// keeps its shape; `-` for a parameter the reported model does not have.
fn pm(e: Option<&Estimate>, value: Option<f64>, prec: usize) -> String {
    let Some(value) = value else {
        return "-".to_string();
    };
    match e {
        Some(e) if e.std_error.abs() >= 1e6 => format!("{value:.prec$} ± {:.1e}", e.std_error),
        Some(e) => format!("{value:.prec$} ± {:.prec$}", e.std_error),
        None => format!("{value:.prec$}"),
    }
}

impl fmt::Display for StribeckReport {
    /// The report's plain-text view shared by the front ends: per direction the points and
    /// the parameters with their standard errors (Fc, Fs in N, vs in mm/min, σ in N·s/m, δ,
    /// the residual RMS in N), then every non-conventional fall.
    fn fmt(&self, o: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            o,
            "{:<9} {:>6}  {:>18}  {:>18}  {:>18}  {:>22}  {:>13}  {:>8}",
            "direction",
            "points",
            "Fc (N)",
            "Fs (N)",
            "vs (mm/min)",
            "sigma (N·s/m)",
            "delta",
            "rms (N)"
        )?;
        for d in &self.directions {
            let u = d.uncertainty.as_ref();
            writeln!(
                o,
                "{:<9} {:>6}  {:>18}  {:>18}  {:>18}  {:>22}  {:>13}  {:>8.3}",
                d.direction,
                d.points,
                pm(u.map(|u| &u.fc_n), Some(d.params.fc_n), 2),
                pm(u.and_then(|u| u.fs_n.as_ref()), d.params.fs_n, 2),
                pm(u.and_then(|u| u.vs_mm_min.as_ref()), d.params.vs_mm_min, 2),
                pm(
                    u.and_then(|u| u.sigma_n_s_per_m.as_ref()),
                    d.params.sigma_n_s_per_m,
                    1
                ),
                pm(u.and_then(|u| u.delta.as_ref()), d.params.delta, 3),
                d.residual_rms_n
            )?;
        }
        for d in &self.directions {
            for r in &d.nonconventional.ranges {
                writeln!(
                    o,
                    "{}: non-conventional: friction falls by {:.2} N from {:.1} to {:.1} mm/min \
                     (fit predicts {:+.2} N)",
                    d.direction, r.drop_n, r.from_mm_min, r.to_mm_min, r.fit_change_n
                )?;
            }
        }
        Ok(())
    }
}

impl StribeckReport {
    /// The remarks beside the text view (the CLI's stderr), one line each: per direction its
    /// model, the richer models refused with their reasons and what to measure
    /// ([`advice`]), and every warning (`warning: forward: ...`).
    pub fn remarks(&self, front: &dyn FrontEnd) -> Vec<String> {
        let free = (self.delta == "free").then(|| front.spell("delta", "free"));
        let mut lines = Vec::new();
        for d in &self.directions {
            lines.push(format!("{}: model {}", d.direction, d.model_name));
            for r in &d.reductions {
                lines.push(format!("  {}", r.message));
            }
            if let Some(r) = d.reductions.last() {
                lines.push(format!("  {}", advice(r.code, free.as_deref())));
            }
            for w in &d.warnings {
                lines.push(format!("warning: {}: {}", d.direction, w.message));
            }
        }
        lines
    }
}

/// What to measure when a Stribeck curve was refused for `code` (the last reduction's);
/// `delta_free` is how the user asked for a free δ (`--delta free`), when they did: that
/// needs one distinct feed more.
pub fn advice(code: Code, delta_free: Option<&str>) -> String {
    match (code, delta_free) {
        (Code::TooFewFeeds, Some(free)) => format!(
            "for a Stribeck curve, measure at least 4 distinct feeds per direction (5 with \
             {free}), several of them below the expected Stribeck velocity"
        ),
        (Code::TooFewFeeds, None) => "for a Stribeck curve, measure at least 4 distinct feeds \
                                      per direction, several of them below the expected \
                                      Stribeck velocity"
            .to_string(),
        _ => "for a Stribeck curve, add feeds below and around the expected Stribeck velocity so \
              that the hump is measured"
            .to_string(),
    }
}
