//! `feedscope fit-stribeck`: Stribeck curves from a steady-speed torque or force table.
use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use feedscope::compensation::{DriveConversion, FrictionCurve};
use feedscope::diag::Code;
use feedscope::stribeck::{DeltaMode, FrictionModel, M_S_PER_MM_MIN};
use feedscope_app::stribeck::{
    Estimate, FitStribeckOptions, FitStribeckRequest, StribeckReport as Report,
};

use super::estimate::Format;
use super::export::{ExportArgs, ExportCurves};
use crate::front::Cli;
use crate::output::OutputSet;
use feedscope_app::plot;
use feedscope_app::AppError;

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
    AppError::bad_input(msg).into()
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
    Ok(plot::line_chart_svg(&plot::LineChart {
        title: "Friction against feed (steady speed) and Stribeck fit",
        x_label: "feed (mm/min)",
        y_label: "friction (N)",
        series,
    })?)
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
pub(crate) fn advice(code: Code, delta_free: bool) -> &'static str {
    match (code, delta_free) {
        (Code::TooFewFeeds, true) => {
            "for a Stribeck curve, measure at least 4 distinct feeds per direction (5 with \
             --delta free), several of them below the expected Stribeck velocity"
        }
        (Code::TooFewFeeds, false) => {
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
    let export = args.export.validate()?;
    if export.is_some() && args.axis.is_none() {
        return Err(bad(
            "--export needs --axis AXIS.toml: its lead_mm and torque_constant_nm_per_a turn \
             friction into motor torque and current (and table_mass_kg, inertia_kgm2 set the \
             SINUMERIK amplitude)"
                .into(),
        ));
    }
    let request = FitStribeckRequest {
        table: args.table.clone(),
        axis: args.axis.clone(),
        options: FitStribeckOptions {
            lead_mm: args.lead_mm,
            efficiency: args.efficiency,
            delta: args.delta,
            noise_n: args.noise_n,
        },
    };
    let done = request.run(&Cli::default())?;
    let name = &done.report.source;
    let exports = match (&export, &done.axis) {
        (Some(cfg), Some(axis)) => {
            let curves = done
                .fits
                .iter()
                .map(|(dir, fit)| FrictionCurve::from_stribeck(*dir, fit))
                .collect::<Result<Vec<_>, _>>()
                .with_context(|| format!("{name}: --export"))?;
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
    let report = &done.report;
    let json = serde_json::to_string_pretty(report)?;
    let svg = svg(report)?;
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
            print_models(report);
        }
        Format::Text => {
            print_table(report)?;
            eprintln!("wrote {}, {}", json_path.display(), svg_path.display());
        }
    }
    for f in &exports {
        eprintln!("wrote {}: {}", args.out.join(f.name).display(), f.summary);
    }
    Ok(())
}
