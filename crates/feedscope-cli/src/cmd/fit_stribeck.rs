//! `feedscope fit-stribeck`: Stribeck curves from a steady-speed torque or force table.
use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use feedscope::compensation::{DriveConversion, FrictionCurve};
use feedscope::estimate::Direction;
use feedscope::stribeck::{
    detect_nonconventional, DeltaMode, FitWarning, FrictionModel, NonConventional,
    NonConventionalParams, ParamEstimate, Reduction, StribeckFit, StribeckFitParams,
    StribeckFitter, StribeckParams, M_S_PER_MM_MIN,
};
use feedscope_io::stribeck_table::{self, EffortColumn, SpeedPoints, TableOptions};
use serde::Serialize;

use super::estimate::Format;
use super::export::{ExportArgs, ExportCurves};
use super::BadInput;
use crate::output::OutputSet;
use crate::plot;

/// Fit Stribeck curves to a steady-speed table (paper 000 Eq. 9, paper 001 Eq. 15).
///
/// TABLE is a CSV with a header naming `feed_mm_min` and one of `torque_nm` (motor torque at
/// steady speed, converted by Eq. 15: F = 2π·η·T/p) or `force_n` (friction force), and
/// optionally `direction` (`forward`/`backward`, or `+`/`-`). Without a direction column the
/// sign of the feed gives the direction; each direction present is fitted on its own with
/// F(v) = Fc + (Fs − Fc)·exp(−(|v|/vs)^δ) + σ·|v| on magnitudes, bounded Fc, Fs, σ ≥ 0,
/// vs > 0. Writes OUT/stribeck.json (per direction: parameters in user units, standard
/// errors, 95 % intervals, warnings, residual, non-conventional falls) and OUT/stribeck.svg
/// (points and fitted curves), and prints a table. Lines starting with `#` are comments.
///
/// A curve the table does not determine is not reported: with fewer distinct feeds than
/// parameters (4, or 5 with `--delta free`), a singular or ill-conditioned fit, or
/// non-physical values, the fit falls back to δ = 2 (after δ free), then to Coulomb + viscous
/// (F = Fc + σ·|v|, from 2 distinct feeds); the model and the reason are printed on stderr
/// and kept in the JSON. A direction with a single distinct feed is refused (exit 2).
///
/// With --export (and --axis for the motor's lead and torque constant) the fitted curves go
/// into the controllers' own files as well: a Beckhoff TF5200 frict_comp block, SINUMERIK
/// starting values, a generic velocity table (docs/friction-map.md says how to load them).
/// The output files are written together or not at all.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Steady-speed table (CSV with header).
    pub table: PathBuf,
    /// Screw lead p (mm), > 0; needed for a `torque_nm` table (or taken from --axis).
    #[arg(long)]
    pub lead_mm: Option<f64>,
    /// Axis parameters (TOML or JSON): the lead, and for --export the torque constant (and
    /// the masses for sinumerik).
    #[arg(long)]
    pub axis: Option<PathBuf>,
    /// Transmission efficiency η in (0, 1]; F = 2π·η·T/p (η < 1 attributes 1 − η of the torque
    /// to losses in the screw itself).
    #[arg(long, default_value_t = 1.0)]
    pub efficiency: f64,
    /// Stribeck shape exponent δ: a positive number, or `free` to fit it.
    #[arg(long, default_value = "2", value_parser = parse_delta)]
    pub delta: DeltaMode,
    /// Noise standard deviation of one friction value (N) for the non-conventional check
    /// [default: estimated from the fit residuals].
    #[arg(long)]
    pub noise_n: Option<f64>,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
    #[command(flatten)]
    pub export: ExportArgs,
}

fn parse_delta(s: &str) -> Result<DeltaMode, String> {
    if s.eq_ignore_ascii_case("free") {
        return Ok(DeltaMode::Free);
    }
    match s.parse::<f64>() {
        Ok(d) if d.is_finite() && d > 0.0 => Ok(DeltaMode::Fixed(d)),
        _ => Err(format!("expected a positive number or `free`, got `{s}`")),
    }
}

fn bad(msg: String) -> anyhow::Error {
    BadInput(msg).into()
}

/// A parameter in user units with its uncertainty.
#[derive(Debug, Serialize)]
pub struct Estimate {
    pub value: f64,
    pub std_error: f64,
    pub ci95: [f64; 2],
}

fn est(e: &ParamEstimate, scale: f64) -> Estimate {
    Estimate {
        value: e.value * scale,
        std_error: e.std_error * scale,
        ci95: [e.ci95_low * scale, e.ci95_high * scale],
    }
}

/// Parameters in user units; `null` when the reported model has no such parameter.
#[derive(Debug, Serialize)]
pub struct Params {
    pub fc_n: f64,
    pub fs_n: Option<f64>,
    pub vs_mm_min: Option<f64>,
    pub sigma_n_s_per_m: Option<f64>,
    pub delta: Option<f64>,
}

#[derive(Debug, Serialize)]
pub struct Uncertainty {
    pub fc_n: Estimate,
    pub fs_n: Option<Estimate>,
    pub static_excess_n: Option<Estimate>,
    pub vs_mm_min: Option<Estimate>,
    pub sigma_n_s_per_m: Option<Estimate>,
    pub delta: Option<Estimate>,
}

/// A warning or a refused model in the JSON: a stable code and the text printed on stderr.
#[derive(Debug, Serialize)]
pub struct Note {
    pub code: &'static str,
    pub message: String,
}

impl From<&FitWarning> for Note {
    fn from(w: &FitWarning) -> Self {
        Note {
            code: w.code(),
            message: w.to_string(),
        }
    }
}

impl From<&Reduction> for Note {
    fn from(r: &Reduction) -> Self {
        Note {
            code: r.code(),
            message: r.to_string(),
        }
    }
}

#[derive(Debug, Serialize)]
pub struct Range {
    pub from_mm_min: f64,
    pub to_mm_min: f64,
    pub points: usize,
    pub drop_n: f64,
    pub fit_change_n: f64,
    pub excess_drop_n: f64,
}

#[derive(Debug, Serialize)]
pub struct NonConv {
    pub noise_n: f64,
    pub threshold_n: f64,
    pub rising_above_mm_min: f64,
    pub ranges: Vec<Range>,
}

#[derive(Debug, Serialize)]
pub struct Point {
    pub feed_mm_min: f64,
    pub friction_n: f64,
    pub fitted_n: f64,
}

/// One direction in stribeck.json.
#[derive(Debug, Serialize)]
pub struct DirectionFit {
    pub direction: &'static str,
    /// `stribeck`, `coulomb-viscous` or `coulomb`.
    pub model: &'static str,
    /// Richer models refused, in the order tried, and why.
    pub reductions: Vec<Note>,
    pub points: usize,
    pub feed_min_mm_min: f64,
    pub feed_max_mm_min: f64,
    pub params: Params,
    pub uncertainty: Option<Uncertainty>,
    pub residual_rms_n: f64,
    pub dof: usize,
    pub iterations: usize,
    pub termination: feedscope::stribeck::Termination,
    pub condition_number: Option<f64>,
    pub warnings: Vec<Note>,
    pub nonconventional: NonConv,
    pub data: Vec<Point>,
    /// The reported curve (SI), for the plot.
    #[serde(skip)]
    pub curve: StribeckParams,
    #[serde(skip)]
    pub model_name: String,
}

/// stribeck.json.
#[derive(Debug, Serialize)]
pub struct Report {
    pub source: String,
    pub input: EffortColumn,
    pub lead_mm: Option<f64>,
    pub efficiency: f64,
    pub delta: String,
    pub directions: Vec<DirectionFit>,
}

fn direction_fit(
    direction: Direction,
    pts: &SpeedPoints,
    fit: &StribeckFit,
    nc: &NonConventional,
) -> DirectionFit {
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
    DirectionFit {
        direction: direction.as_str(),
        model: fit.model.code(),
        reductions: fit.reductions.iter().map(Note::from).collect(),
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
            fc_n: est(&u.fc_n, 1.0),
            fs_n: u.fs_n.as_ref().map(|e| est(e, 1.0)),
            static_excess_n: u.static_excess_n.as_ref().map(|e| est(e, 1.0)),
            vs_mm_min: u.vs_m_s.as_ref().map(|e| est(e, mm)),
            sigma_n_s_per_m: u.sigma_n_s_per_m.as_ref().map(|e| est(e, 1.0)),
            delta: u.delta.as_ref().map(|d| est(d, 1.0)),
        }),
        residual_rms_n: fit.residual_rms_n,
        dof: fit.dof,
        iterations: fit.iterations,
        termination: fit.termination,
        condition_number: fit.condition_number,
        warnings: fit.warnings.iter().map(Note::from).collect(),
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

fn svg(report: &Report) -> Result<String> {
    let mut series = Vec::new();
    for d in &report.directions {
        let pts: Vec<(f64, f64)> = d
            .data
            .iter()
            .map(|p| (p.feed_mm_min, p.friction_n))
            .collect();
        // the shared point style is a faint dot meant for dense samples; a dashed line
        // through the (feed-sorted) points keeps a few table rows visible
        series.push(plot::Series {
            name: format!("{} data", d.direction),
            points: pts,
            style: plot::Style::Dashed,
        });
        let p = d.curve;
        // linear and logarithmic spacing together: the hump sits at the low end
        let (lo, hi) = (d.feed_min_mm_min, d.feed_max_mm_min);
        let mut feeds: Vec<f64> = (0..=200)
            .flat_map(|k| {
                let s = k as f64 / 200.0;
                [lo + (hi - lo) * s, lo * (hi / lo).powf(s)]
            })
            .collect();
        feeds.sort_by(f64::total_cmp);
        let curve = feeds
            .into_iter()
            .map(|f| (f, p.magnitude_n(f * M_S_PER_MM_MIN)))
            .collect();
        let fitted = if d.model == FrictionModel::Stribeck.code() {
            "Stribeck fit"
        } else {
            "Coulomb + viscous fit"
        };
        series.push(plot::Series {
            name: format!("{} {fitted}", d.direction),
            points: curve,
            style: plot::Style::Line,
        });
    }
    plot::line_chart_svg(&plot::LineChart {
        title: "Friction against feed (steady speed) and Stribeck fit",
        x_label: "feed (mm/min)",
        y_label: "friction (N)",
        series,
    })
}

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

fn print_table(report: &Report) -> Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
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
    for d in &report.directions {
        let u = d.uncertainty.as_ref();
        writeln!(
            out,
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
    for d in &report.directions {
        for r in &d.nonconventional.ranges {
            writeln!(
                out,
                "{}: non-conventional: friction falls by {:.2} N from {:.1} to {:.1} mm/min \
                 (fit predicts {:+.2} N)",
                d.direction, r.drop_n, r.from_mm_min, r.to_mm_min, r.fit_change_n
            )?;
        }
    }
    print_models(report);
    Ok(())
}

/// On stderr: the model of each direction, the refused models with their reasons and what to
/// do, and every warning's text.
fn print_models(report: &Report) {
    for d in &report.directions {
        eprintln!("{}: model {}", d.direction, d.model_name);
        for r in &d.reductions {
            eprintln!("  {}", r.message);
        }
        if let Some(r) = d.reductions.last() {
            eprintln!("  {}", advice(r.code, report.delta == "free"));
        }
        for w in &d.warnings {
            eprintln!("warning: {}: {}", d.direction, w.message);
        }
    }
}

/// What to measure when a Stribeck curve was refused (shared by `map`, which has δ = 2).
pub(crate) fn advice(code: &str, delta_free: bool) -> &'static str {
    match (code, delta_free) {
        ("too-few-feeds", true) => {
            "for a Stribeck curve, measure at least 4 distinct feeds per direction (5 with \
             --delta free), several of them below the expected Stribeck velocity"
        }
        ("too-few-feeds", false) => {
            "for a Stribeck curve, measure at least 4 distinct feeds per direction, several of \
             them below the expected Stribeck velocity"
        }
        _ => {
            "for a Stribeck curve, add feeds below and around the expected Stribeck velocity \
             so that the hump is measured"
        }
    }
}

pub fn run(args: Args) -> Result<()> {
    if let Some(s) = args.noise_n {
        if !(s.is_finite() && s >= 0.0) {
            return Err(bad(format!("--noise-n must be >= 0, got {s}")));
        }
    }
    let export = args.export.validate()?;
    if export.is_some() && args.axis.is_none() {
        return Err(bad(
            "--export needs --axis AXIS.toml: its lead_mm and torque_constant_nm_per_a turn \
             friction into motor torque and current (and table_mass_kg, inertia_kgm2 set the \
             SINUMERIK amplitude)"
                .into(),
        ));
    }
    let axis = args
        .axis
        .as_ref()
        .map(|p| feedscope_io::axis::load(p))
        .transpose()?;
    // One lead: the axis file's, or --lead-mm, and they must agree when both are given.
    let lead_mm = match (&axis, args.lead_mm) {
        (Some(a), Some(l)) if (a.lead_mm - l).abs() > 1e-9 * a.lead_mm.abs() => {
            return Err(bad(format!(
                "--lead-mm {l} disagrees with lead_mm = {} of {}",
                a.lead_mm,
                args.axis
                    .as_ref()
                    .map_or(String::new(), |p| p.display().to_string())
            )))
        }
        (Some(a), _) => Some(a.lead_mm),
        (None, l) => l,
    };
    let table = stribeck_table::read(
        &args.table,
        &TableOptions {
            lead_mm,
            efficiency: args.efficiency,
        },
    )?;
    let (input, fwd, bwd) = (table.effort, table.forward, table.backward);
    let fit_params = StribeckFitParams {
        delta: args.delta,
        ..StribeckFitParams::default()
    };
    let name = args.table.display().to_string();
    if fwd.speed_m_s.is_empty() && bwd.speed_m_s.is_empty() {
        return Err(bad(format!("{name}: no data rows")));
    }
    let nc_params = NonConventionalParams {
        noise_n: args.noise_n,
        ..NonConventionalParams::default()
    };
    let mut directions = Vec::new();
    let mut curves = Vec::new();
    for (dir, pts) in [(Direction::Forward, &fwd), (Direction::Backward, &bwd)] {
        if pts.speed_m_s.is_empty() {
            continue;
        }
        let fitter = StribeckFitter::new(&pts.speed_m_s, &fit_params)
            .map_err(|e| bad(format!("{name}: {} direction: {e}", dir.as_str())))?;
        // One feed gives a level that mixes Coulomb and viscous friction: not a friction
        // curve (the library would report it as a Coulomb level).
        if let [one] = fitter.distinct_speeds_m_s() {
            return Err(bad(format!(
                "{name}: the {} direction has 1 distinct feed ({} mm/min, {} rows); a \
                 friction curve needs at least 2 (Coulomb + viscous), a Stribeck curve at \
                 least 4 (5 with --delta free): measure at more feeds",
                dir.as_str(),
                one / M_S_PER_MM_MIN,
                pts.speed_m_s.len()
            )));
        }
        let fit = fitter
            .fit(&pts.friction_n)
            .map_err(|e| bad(format!("{name}: {} direction: {e}", dir.as_str())))?;
        let nc = detect_nonconventional(&pts.speed_m_s, &pts.friction_n, &fit, &nc_params)
            .map_err(|e| bad(format!("{name}: {} direction: {e}", dir.as_str())))?;
        directions.push(direction_fit(dir, pts, &fit, &nc));
        if export.is_some() {
            curves.push(
                FrictionCurve::from_stribeck(dir, &fit)
                    .with_context(|| format!("{name}: --export"))?,
            );
        }
    }
    let exports = match (&export, &axis) {
        (Some(cfg), Some(axis)) => {
            let drive = DriveConversion::from_axis(axis, args.efficiency)
                .context("--export: the axis file and --efficiency")?;
            let source = format!("feedscope fit-stribeck {name}");
            super::export::build(
                cfg,
                &ExportCurves {
                    table: &curves,
                    stribeck: &curves,
                },
                axis,
                drive,
                &feedscope_io::controller_compensation::ExportSource {
                    source: &source,
                    axis_name: axis.name.as_deref(),
                },
            )?
        }
        _ => Vec::new(),
    };
    let report = Report {
        source: name,
        input,
        lead_mm,
        efficiency: args.efficiency,
        delta: match args.delta {
            DeltaMode::Free => "free".to_string(),
            DeltaMode::Fixed(d) => format!("{d}"),
        },
        directions,
    };
    let json = serde_json::to_string_pretty(&report)?;
    let svg = svg(&report)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let json_path = args.out.join("stribeck.json");
    let svg_path = args.out.join("stribeck.svg");
    // All or nothing: the files replace the previous run's together at the end.
    let mut outputs = OutputSet::new();
    outputs.write(&json_path, json.as_bytes())?;
    outputs.write(&svg_path, svg.as_bytes())?;
    for f in &exports {
        outputs.write(&args.out.join(f.name), &f.bytes)?;
    }
    outputs.commit()?;
    match args.format {
        Format::Json => {
            writeln!(std::io::stdout().lock(), "{json}")?;
            print_models(&report);
        }
        Format::Text => {
            print_table(&report)?;
            eprintln!("wrote {}, {}", json_path.display(), svg_path.display());
        }
    }
    for f in &exports {
        eprintln!("wrote {}: {}", args.out.join(f.name).display(), f.summary);
    }
    Ok(())
}
