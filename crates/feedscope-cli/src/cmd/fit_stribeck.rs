//! `feedscope fit-stribeck`: Stribeck curves from a steady-speed torque or force table.
use std::path::PathBuf;

use anyhow::{Context, Result};
use feedscope::stribeck::DeltaMode;
use feedscope_app::stribeck::{FitStribeckOptions, FitStribeckRequest};

use super::estimate::Format;
use super::export::ExportArgs;
use crate::front::Cli;
use crate::output::{out, outln, OutputSet};
use feedscope_app::plot;

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

pub fn run(args: Args) -> Result<()> {
    let request = FitStribeckRequest {
        table: args.table.clone(),
        axis: args.axis.clone(),
        options: FitStribeckOptions {
            lead_mm: args.lead_mm,
            efficiency: args.efficiency,
            delta: args.delta,
            noise_n: args.noise_n,
        },
        export: args.export.options(),
    };
    let front = Cli::default();
    let done = request.run(&front)?;
    let report = &done.report;
    let json = serde_json::to_string_pretty(report)?;
    let svg = plot::stribeck_svg(report)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let json_path = args.out.join("stribeck.json");
    let svg_path = args.out.join("stribeck.svg");
    // All or nothing: the files replace the previous run's together at the end.
    let mut outputs = OutputSet::new();
    outputs.write(&json_path, json.as_bytes())?;
    outputs.write(&svg_path, svg.as_bytes())?;
    for f in &done.exports {
        outputs.write(&args.out.join(f.name), &f.bytes)?;
    }
    outputs.commit()?;
    match args.format {
        Format::Json => outln!("{json}"),
        Format::Text => out!("{report}"),
    }
    for line in report.remarks(&front) {
        eprintln!("{line}");
    }
    if args.format == Format::Text {
        eprintln!("wrote {}, {}", json_path.display(), svg_path.display());
    }
    for f in &done.exports {
        eprintln!("wrote {}: {}", args.out.join(f.name).display(), f.summary);
    }
    Ok(())
}
