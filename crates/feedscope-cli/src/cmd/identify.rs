//! `feedscope identify`: J, T_c, T_s, v_s and σ from one triangular-wave trace (paper 002).
use std::path::PathBuf;

use anyhow::Result;
use feedscope::ident::IdentParams;
use feedscope_app::identify::{IdentifyOptions, IdentifyRequest};

use super::estimate::{EffortArg, Format};
use crate::front::Cli;
use crate::output::{out, outln};
use feedscope_app::plot;

/// Identify friction and inertia from one test (paper 002): J, Tc, Ts, vs, σ.
///
/// Reads one trace of the variable-amplitude, variable-velocity triangular wave planned by
/// `feedscope plan triangle` (position and motor torque or current; each acceleration phase
/// must span a few samples: 83 Hz or more for 0.1 s ramps, 70 ms polling for 0.5 s) and fits T = J·θ'' + sgn(v)·[Tc + (Ts − Tc)·exp(−(|v|/vs)^δ)] + σ·v + T0 jointly
/// by separable least squares on hat-kernel averages: the position's second divided
/// difference is exactly the kernel average of the acceleration, and the torque and the
/// friction terms are averaged with the same kernel, so every sample of the acceleration
/// phases identifies J, whatever the ramp shape (trapezoid, jerk-limited, bell). Rows near a
/// standstill or a reversal (within --guard-s), or across a step of the acceleration (the
/// corner of a trapezoidal ramp), are excluded. Writes the parameters (motor side, force side via
/// F = 2π·T/p, standard errors, residual RMS) as JSON and a plot of measured and computed
/// torque over time. The axis file needs the lead and the torque constant; `inertia_kgm2`
/// and `damping_nms_per_rad` may be left out (the test identifies them; --compare needs
/// them). With --compare, the same model is also fitted to the mean friction of
/// the constant-speed strokes of a second trace (the traditional test) and the two parameter
/// sets are reported side by side.
///
/// Exit codes: 0 success; 2 bad input, including a trace that cannot identify the model
/// (no reversal, one speed only, no acceleration).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Trace file of the triangular-wave test (CSV or Parquet, as for `estimate`).
    pub trace: PathBuf,
    /// Axis parameters (TOML, or JSON with the same keys): lead, torque constant; inertia and
    /// damping optional.
    #[arg(long)]
    pub axis: PathBuf,
    /// Parameters JSON to write.
    #[arg(short = 'o', long = "output", default_value = "ident.json")]
    pub output: PathBuf,
    /// SVG of measured and computed torque over time [default: OUTPUT with extension .svg].
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Do not write the plot.
    #[arg(long)]
    pub no_plot: bool,
    /// Trace of constant-feed idle strokes at several feeds, fitted for comparison.
    #[arg(long, value_name = "GROUPS_TRACE")]
    pub compare: Option<PathBuf>,
    /// Half-width of the averaging kernel (s), rounded to whole sampling intervals
    /// [default: 0.01, at least one interval].
    #[arg(long)]
    pub kernel_s: Option<f64>,
    /// Exclude samples slower than this (mm/min): standstill and pre-sliding.
    #[arg(long, default_value_t = 1.0)]
    pub min_speed_mm_min: f64,
    /// Also exclude rows within this time of a slow sample or a reversal (s) [default: three
    /// kernel half-widths].
    #[arg(long)]
    pub guard_s: Option<f64>,
    /// Stribeck shape exponent δ (held fixed).
    #[arg(long, default_value_t = 2.0)]
    pub delta: f64,
    /// Lower bound of the Stribeck velocity search (mm/min).
    #[arg(long, default_value_t = 0.5)]
    pub vs_min_mm_min: f64,
    /// Upper bound of the Stribeck velocity search (mm/min).
    #[arg(long, default_value_t = 5000.0)]
    pub vs_max_mm_min: f64,
    /// Do not fit a constant torque T0 (gravity, asymmetric Coulomb level).
    #[arg(long)]
    pub no_offset: bool,
    /// Which effort channel to use when the file has both current and torque.
    #[arg(long, value_enum)]
    pub effort: Option<EffortArg>,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

fn params_from(a: &Args) -> IdentParams {
    IdentParams {
        kernel_half_width_s: a.kernel_s,
        min_speed_mm_min: a.min_speed_mm_min,
        reversal_guard_s: a.guard_s,
        delta: a.delta,
        vs_min_mm_min: a.vs_min_mm_min,
        vs_max_mm_min: a.vs_max_mm_min,
        fit_offset: !a.no_offset,
        ..IdentParams::default()
    }
}

pub fn run(args: Args) -> Result<()> {
    let request = IdentifyRequest {
        trace: args.trace.clone(),
        axis: args.axis.clone(),
        compare: args.compare.clone(),
        effort: args.effort.map(Into::into),
        options: IdentifyOptions {
            params: params_from(&args),
        },
    };
    let plot_path = (!args.no_plot).then(|| {
        args.plot
            .clone()
            .unwrap_or_else(|| args.output.with_extension("svg"))
    });
    let done = request.run(&Cli::default())?;
    let report = &done.report;
    let json = serde_json::to_string_pretty(report)?;
    // Render everything before writing anything.
    let svg = match &plot_path {
        Some(_) => Some(plot::identification_svg(
            &done.fit,
            done.axis.name.as_deref(),
        )?),
        None => None,
    };
    crate::output::write_atomic(&args.output, json.as_bytes())?;
    if let (Some(p), Some(svg)) = (&plot_path, svg) {
        crate::output::write_atomic(p, svg.as_bytes())?;
    }
    match args.format {
        Format::Json => outln!("{json}"),
        Format::Text => {
            out!("{report}");
            eprintln!(
                "wrote {}{}",
                args.output.display(),
                plot_path
                    .map(|p| format!(", {}", p.display()))
                    .unwrap_or_default()
            );
        }
    }
    Ok(())
}
