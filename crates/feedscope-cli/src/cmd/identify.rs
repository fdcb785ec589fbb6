//! `feedscope identify`: J, T_c, T_s, v_s and σ from one triangular-wave trace (paper 002).
use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use feedscope::ident::{IdentParams, Identification};
use feedscope_app::identify::{IdentifyOptions, IdentifyReport, IdentifyRequest};

use super::estimate::{EffortArg, Format};
use crate::front::Cli;
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

/// Measured and computed torque over time, at most ~4000 points per series.
fn svg(id: &Identification, title: &str) -> Result<String> {
    let n = id.time_s.len();
    let step = n.div_ceil(4000).max(1);
    let pts = |f: &dyn Fn(usize) -> f64| -> Vec<(f64, f64)> {
        (0..n)
            .step_by(step)
            .map(|k| (id.time_s[k], f(k)))
            .filter(|p| p.1.is_finite())
            .collect()
    };
    let used: Vec<(f64, f64)> = (0..n)
        .step_by(step)
        .filter(|&k| id.used[k])
        .map(|k| (id.time_s[k], id.regressors.torque_nm[k]))
        .collect();
    Ok(plot::line_chart_svg(&plot::LineChart {
        title,
        x_label: "time (s)",
        y_label: "torque (N·m)",
        series: vec![
            plot::Series {
                name: "measured (kernel average)".to_string(),
                points: pts(&|k| id.regressors.torque_nm[k]),
                style: plot::Style::Line,
            },
            plot::Series {
                name: "computed, J·θ'' + T_f(v)".to_string(),
                points: pts(&|k| id.computed_torque_nm[k]),
                style: plot::Style::Dashed,
            },
            plot::Series {
                name: "used in the fit".to_string(),
                points: used,
                style: plot::Style::Points,
            },
        ],
    })?)
}

fn print_text(out: &IdentifyReport) -> Result<()> {
    let mut w = std::io::stdout().lock();
    let m = &out.set.motor;
    let s = &out.set.std_error;
    let f = &out.set.force;
    writeln!(w, "one-test identification (paper 002) of {}", out.source)?;
    writeln!(
        w,
        "  samples {} used of {}, residual RMS {:.4} N·m, condition {:.1}, {} evaluations",
        out.set.diagnostics.samples_used,
        out.samples_total,
        out.set.diagnostics.residual_rms_nm,
        out.set.diagnostics.condition_number,
        out.set.diagnostics.iterations
    )?;
    let rows: [(&str, f64, f64, &str); 6] = [
        ("J total", m.j_total_kgm2, s.j_total_kgm2, "kg·m²"),
        ("Tc", m.tc_nm, s.tc_nm, "N·m"),
        ("Ts", m.ts_nm, s.ts_nm, "N·m"),
        ("vs", m.vs_mm_min, s.vs_mm_min, "mm/min"),
        ("sigma", m.sigma_nm_s_per_m, s.sigma_nm_s_per_m, "N·m·s/m"),
        ("T0", m.offset_nm, s.offset_nm, "N·m"),
    ];
    let cmp = out.compare.as_ref();
    match cmp {
        Some(_) => writeln!(
            w,
            "  {:<8} {:>14} {:>12} {:>14} {:>12}  unit",
            "", "one test", "± 1σ", "groups", "± 1σ"
        )?,
        None => writeln!(w, "  {:<8} {:>14} {:>12}  unit", "", "value", "± 1σ")?,
    }
    for (k, (name, v, e, unit)) in rows.iter().enumerate() {
        match cmp {
            Some(c) => {
                let cm = &c.set.motor;
                let cs = &c.set.std_error;
                let (gv, ge) = [
                    (cm.j_total_kgm2, cs.j_total_kgm2),
                    (cm.tc_nm, cs.tc_nm),
                    (cm.ts_nm, cs.ts_nm),
                    (cm.vs_mm_min, cs.vs_mm_min),
                    (cm.sigma_nm_s_per_m, cs.sigma_nm_s_per_m),
                    (cm.offset_nm, cs.offset_nm),
                ][k];
                if k == 0 {
                    writeln!(
                        w,
                        "  {name:<8} {v:>14.6} {e:>12.6} {:>14} {:>12}  {unit}",
                        "-", "-"
                    )?;
                } else {
                    writeln!(
                        w,
                        "  {name:<8} {v:>14.6} {e:>12.6} {gv:>14.6} {ge:>12.6}  {unit}"
                    )?;
                }
            }
            None => writeln!(w, "  {name:<8} {v:>14.6} {e:>12.6}  {unit}")?,
        }
    }
    writeln!(
        w,
        "  force side (F = 2π·T/p): Fc {:.2} N, Fs {:.2} N, sigma {:.1} N·s/m, \
         equivalent mass {:.1} kg",
        f.fc_n, f.fs_n, f.sigma_n_s_per_m, f.equivalent_mass_kg
    )?;
    match out.axis_j_total_kgm2 {
        Some(j) => writeln!(w, "  the axis file predicts J total {j:.6} kg·m²")?,
        None => writeln!(w, "  the axis file gives no inertia: J is the test's alone")?,
    }
    if let Some(c) = cmp {
        let d = &c.difference_percent;
        writeln!(
            w,
            "  one test vs {} groups: Tc {:+.1} %, Ts {:+.1} %, vs {:+.1} %, sigma {:+.1} %",
            c.groups.len(),
            d.tc,
            d.ts,
            d.vs,
            d.sigma
        )?;
    }
    for warn in &out.warnings {
        writeln!(w, "  warning: {warn}")?;
    }
    Ok(())
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
    let out = &done.report;
    let json = serde_json::to_string_pretty(out)?;
    // Render everything before writing anything.
    let svg = match &plot_path {
        Some(_) => {
            let name = done.axis.name.as_deref().unwrap_or("axis");
            Some(svg(
                &done.fit,
                &format!("Measured and computed motor torque ({name})"),
            )?)
        }
        None => None,
    };
    crate::output::write_atomic(&args.output, json.as_bytes())?;
    if let (Some(p), Some(svg)) = (&plot_path, svg) {
        crate::output::write_atomic(p, svg.as_bytes())?;
    }
    match args.format {
        Format::Json => writeln!(std::io::stdout().lock(), "{json}")?,
        Format::Text => {
            print_text(out)?;
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
