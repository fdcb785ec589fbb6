//! `feedscope plan`: NC programs (G-code) for the friction tests.
use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Subcommand, ValueEnum};
use feedscope::plan::gcode::{write_gcode, Dialect, FanucMachine, GcodeOptions};
use feedscope::plan::{
    identifiability_warning, strokes_program, triangle_program, Limits, Move, StrokeTestParams,
    TestKind, TestProgram, TriangleParams,
};
use feedscope::sim::{RampShape, DEFAULT_JERK_MM_S3};
use feedscope::units::s_to_min;
use serde::Serialize;

use super::estimate::Format;
use feedscope_app::AppError;

/// Sampling interval assumed when none is given (ms): an MTConnect agent's polling.
const DEFAULT_SAMPLE_INTERVAL_MS: f64 = 72.0;

/// Write the NC program (G-code) of a friction test, with its run time and sample counts.
///
/// `strokes`: forward and backward idle strokes at a list of feeds with dwells (paper 000,
/// for `feedscope estimate`). `triangle`: the variable-amplitude, variable-velocity
/// triangular wave (paper 002, for `feedscope identify`). Positions are checked against the
/// travel limits of the axis file (`travel_min_mm`, `travel_max_mm`) or --travel-min /
/// --travel-max, feeds against --feed-limit; a violation is an error naming the limit
/// (exit 2). The header comment states the purpose, travel, feeds, expected run time and the
/// expected number of samples per channel. The run time assumes the control's ramp shape and
/// limits (--accel-mm-s2, --ramp, --jerk-mm-s3; by default jerk-limited at 20 m/s³, as the
/// simulator's default), so that it is what the control (and the twin) takes.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub test: Test,
}

#[derive(Debug, Subcommand)]
pub enum Test {
    /// Idle strokes from --from to --to and back at each feed, --repeats times (paper 000).
    Strokes(StrokesArgs),
    /// Variable-amplitude, variable-velocity triangular wave in the window --from..--to
    /// (paper 002 Eq. 8): feeds geometric from --feed-min (default vs-guess/5) to --feed-max,
    /// each stroke cruising --cruise-s where the window allows.
    Triangle(TriangleArgs),
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum DialectArg {
    /// FANUC 0i / 30i.
    Fanuc,
    /// Siemens SINUMERIK 840D.
    Siemens,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum MachineArg {
    /// FANUC lathe, G-code system A: G98 feed per minute, no G90 (a cutting cycle there).
    Lathe,
    /// FANUC mill / machining centre: G90 G94.
    Mill,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum RampArg {
    /// Constant acceleration (trapezoidal speed; SINUMERIK BRISK).
    Trapezoid,
    /// Jerk-limited S-curve (SINUMERIK SOFT, Heidenhain TNC, Beckhoff TwinCAT NC).
    JerkLimited,
    /// Bell-shaped (raised-cosine) speed changes (FANUC bell-shaped acc./dec. before
    /// interpolation).
    Bell,
}

#[derive(Debug, clap::Args)]
pub struct Common {
    /// Axis file (TOML/JSON); its travel_min_mm / travel_max_mm are the travel limits.
    #[arg(long)]
    pub axis: Option<PathBuf>,
    /// Lower travel limit (mm), overrides the axis file.
    #[arg(long, allow_negative_numbers = true)]
    pub travel_min: Option<f64>,
    /// Upper travel limit (mm), overrides the axis file.
    #[arg(long, allow_negative_numbers = true)]
    pub travel_max: Option<f64>,
    /// Highest feed the test may use (mm/min).
    #[arg(long)]
    pub feed_limit: Option<f64>,
    /// Control dialect.
    #[arg(long, value_enum, default_value_t = DialectArg::Fanuc)]
    pub dialect: DialectArg,
    /// FANUC machine type (decides G98 vs G90 G94).
    #[arg(long, value_enum, default_value_t = MachineArg::Lathe)]
    pub fanuc_machine: MachineArg,
    /// Axis address letter.
    #[arg(long, default_value_t = 'Z')]
    pub axis_letter: char,
    /// FANUC program number (O number, 1-9999).
    #[arg(long, default_value_t = 1000)]
    pub program_number: u32,
    /// Feed of the first move to the start position (mm/min) [default: the highest feed].
    #[arg(long)]
    pub approach_feed: Option<f64>,
    /// Acceleration the control uses for the axis (mm/s²), for run time and planning.
    #[arg(long, default_value_t = 1000.0)]
    pub accel_mm_s2: f64,
    /// Shape of the control's speed changes, for the run time (the simulator's default is
    /// jerk-limited too).
    #[arg(long, value_enum, default_value_t = RampArg::JerkLimited)]
    pub ramp: RampArg,
    /// Jerk limit of the control for the axis (mm/s³), for the run time with --ramp
    /// jerk-limited [default: 20000].
    #[arg(long)]
    pub jerk_mm_s3: Option<f64>,
    /// Sampling interval of the acquisition (ms), for the sample counts and, for the
    /// triangular wave, the check that the test can be identified at it [default: 72, the
    /// polling of an MTConnect agent].
    #[arg(long, conflicts_with = "sample_rate_hz")]
    pub sample_interval_ms: Option<f64>,
    /// Sampling rate of the acquisition (Hz), instead of --sample-interval-ms.
    #[arg(long)]
    pub sample_rate_hz: Option<f64>,
    /// NC program to write.
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

#[derive(Debug, clap::Args)]
pub struct StrokesArgs {
    /// Start of the forward strokes (mm).
    #[arg(long, allow_negative_numbers = true)]
    pub from: f64,
    /// End of the forward strokes (mm).
    #[arg(long, allow_negative_numbers = true)]
    pub to: f64,
    /// Feeds in test order (mm/min), comma separated.
    #[arg(long, value_delimiter = ',', required = true)]
    pub feeds: Vec<f64>,
    /// Forward + backward pairs per feed.
    #[arg(long, default_value_t = 3)]
    pub repeats: u32,
    /// Dwell after every stroke (s).
    #[arg(long, default_value_t = 1.0)]
    pub dwell_s: f64,
    #[command(flatten)]
    pub common: Common,
}

#[derive(Debug, clap::Args)]
pub struct TriangleArgs {
    /// Lower end of the test window (mm) [default: travel minimum].
    #[arg(long, allow_negative_numbers = true)]
    pub from: Option<f64>,
    /// Upper end of the test window (mm) [default: travel maximum].
    #[arg(long, allow_negative_numbers = true)]
    pub to: Option<f64>,
    /// Highest feed of the wave (mm/min) [default: --feed-limit].
    #[arg(long)]
    pub feed_max: Option<f64>,
    /// Lowest feed (mm/min) [default: vs-guess/5].
    #[arg(long)]
    pub feed_min: Option<f64>,
    /// Guess of the Stribeck velocity (mm/min).
    #[arg(long, default_value_t = 60.0)]
    pub vs_guess: f64,
    /// Number of feed levels.
    #[arg(long, default_value_t = 10)]
    pub levels: usize,
    /// Full cycles per level.
    #[arg(long, default_value_t = 1)]
    pub cycles: usize,
    /// Wanted constant-feed time per stroke (s).
    #[arg(long, default_value_t = 2.0)]
    pub cruise_s: f64,
    /// Dwell after every stroke (s).
    #[arg(long, default_value_t = 0.0)]
    pub dwell_s: f64,
    #[command(flatten)]
    pub common: Common,
}

#[derive(Debug, Serialize)]
struct Summary {
    test: TestKind,
    output: String,
    dialect: Dialect,
    start_mm: f64,
    span_mm: (f64, f64),
    feeds_mm_min: Vec<f64>,
    run_time_s: f64,
    sample_interval_s: f64,
    samples_per_channel: u64,
    accel_mm_s2: f64,
    ramp: RampShape,
    jerk_mm_s3: Option<f64>,
    notes: Vec<String>,
    /// What the user must know before running the test (printed on stderr too).
    warnings: Vec<String>,
    moves: Vec<Move>,
}

fn limits(c: &Common) -> Result<Limits> {
    let (mut lo, mut hi) = (None, None);
    if let Some(p) = &c.axis {
        let a = feedscope_io::axis::load(p)?;
        lo = a.travel_min_mm;
        hi = a.travel_max_mm;
    }
    Ok(Limits {
        travel_min_mm: c.travel_min.or(lo),
        travel_max_mm: c.travel_max.or(hi),
        feed_max_mm_min: c.feed_limit,
    })
}

fn options(c: &Common) -> Result<GcodeOptions> {
    let interval_s = match c.sample_rate_hz {
        Some(r) if r.is_finite() && r > 0.0 => 1.0 / r,
        Some(r) => {
            return Err(AppError::bad_input(format!("--sample-rate-hz {r}: must be > 0")).into())
        }
        None => match c.sample_interval_ms {
            Some(ms) if ms.is_finite() && ms > 0.0 => ms * 1e-3,
            Some(ms) => {
                return Err(
                    AppError::bad_input(format!("--sample-interval-ms {ms}: must be > 0")).into(),
                )
            }
            None => DEFAULT_SAMPLE_INTERVAL_MS * 1e-3,
        },
    };
    Ok(GcodeOptions {
        dialect: match c.dialect {
            DialectArg::Fanuc => Dialect::Fanuc,
            DialectArg::Siemens => Dialect::Siemens,
        },
        fanuc_machine: match c.fanuc_machine {
            MachineArg::Lathe => FanucMachine::Lathe,
            MachineArg::Mill => FanucMachine::Mill,
        },
        axis_letter: c.axis_letter,
        program_number: c.program_number,
        sample_interval_s: interval_s,
        approach_feed_mm_min: c.approach_feed,
    })
}

fn bad<E: std::fmt::Display>(e: E) -> anyhow::Error {
    AppError::bad_input(e.to_string()).into()
}

pub fn run(args: Args) -> Result<()> {
    let (prog, common): (TestProgram, &Common) = match &args.test {
        Test::Strokes(s) => {
            let lim = limits(&s.common)?;
            let p = StrokeTestParams {
                from_mm: s.from,
                to_mm: s.to,
                feeds_mm_min: s.feeds.clone(),
                repeats: s.repeats,
                dwell_s: s.dwell_s,
                accel_mm_s2: s.common.accel_mm_s2,
            };
            (strokes_program(&p, &lim).map_err(bad)?, &s.common)
        }
        Test::Triangle(t) => {
            let lim = limits(&t.common)?;
            let from = t.from.or(lim.travel_min_mm).ok_or_else(|| {
                bad("--from is needed (or travel_min_mm in the axis file / --travel-min)")
            })?;
            let to = t.to.or(lim.travel_max_mm).ok_or_else(|| {
                bad("--to is needed (or travel_max_mm in the axis file / --travel-max)")
            })?;
            let feed_max = t
                .feed_max
                .or(lim.feed_max_mm_min)
                .ok_or_else(|| bad("--feed-max or --feed-limit is needed"))?;
            let p = TriangleParams {
                window_min_mm: from,
                window_max_mm: to,
                feed_max_mm_min: feed_max,
                feed_min_mm_min: t.feed_min,
                vs_guess_mm_min: t.vs_guess,
                levels: t.levels,
                cycles_per_level: t.cycles,
                min_cruise_s: t.cruise_s,
                dwell_s: t.dwell_s,
                accel_mm_s2: t.common.accel_mm_s2,
            };
            (triangle_program(&p, &lim).map_err(bad)?, &t.common)
        }
    };
    let ramp = match common.ramp {
        RampArg::Trapezoid => RampShape::Trapezoid,
        RampArg::JerkLimited => RampShape::JerkLimited,
        RampArg::Bell => RampShape::Bell,
    };
    if common.jerk_mm_s3.is_some() && ramp != RampShape::JerkLimited {
        return Err(bad(
            "--jerk-mm-s3 applies only to --ramp jerk-limited (trapezoid and bell ramps have \
             no jerk limit)",
        ));
    }
    let prog = prog
        .with_ramp(ramp, common.jerk_mm_s3)
        .map_err(|e| bad(format!("--jerk-mm-s3: {e}")))?;
    let opts = options(common)?;
    if let Some(f) = common.approach_feed {
        if !(f.is_finite() && f > 0.0) {
            return Err(bad(format!("--approach-feed {f}: must be > 0")));
        }
        limits(common)?.check_feed(f).map_err(bad)?;
    }
    let text = write_gcode(&prog, &opts).map_err(bad)?;
    let mut warnings = Vec::new();
    if let Some(w) = identifiability_warning(&prog, opts.sample_interval_s) {
        let assumed = common.sample_interval_ms.is_none() && common.sample_rate_hz.is_none();
        warnings.push(if assumed {
            format!(
                "{w} (no --sample-interval-ms or --sample-rate-hz was given: \
                 {DEFAULT_SAMPLE_INTERVAL_MS} ms polling was assumed)"
            )
        } else {
            w
        });
    }
    crate::output::write_atomic(&common.output, text.as_bytes())
        .with_context(|| format!("writing {}", common.output.display()))?;
    let summary = Summary {
        test: prog.kind,
        output: common.output.display().to_string(),
        dialect: opts.dialect,
        start_mm: prog.start_mm,
        span_mm: prog.span_mm(),
        feeds_mm_min: prog.feeds_mm_min(),
        run_time_s: prog.run_time_s(),
        sample_interval_s: opts.sample_interval_s,
        samples_per_channel: prog.expected_samples(opts.sample_interval_s),
        accel_mm_s2: prog.accel_mm_s2,
        ramp: prog.ramp,
        jerk_mm_s3: prog.jerk_mm_s3,
        notes: prog.notes.clone(),
        warnings,
        moves: prog.moves.clone(),
    };
    for w in &summary.warnings {
        eprintln!("warning: {w}");
    }
    let mut w = std::io::stdout().lock();
    match common.format {
        Format::Json => writeln!(w, "{}", serde_json::to_string_pretty(&summary)?)?,
        Format::Text => {
            writeln!(
                w,
                "{}: {} moves over {:.3} to {:.3} mm at {} feed(s)",
                summary.output,
                summary.moves.len(),
                summary.span_mm.0,
                summary.span_mm.1,
                summary.feeds_mm_min.len()
            )?;
            let ramp = match (summary.ramp, summary.jerk_mm_s3) {
                (RampShape::JerkLimited, j) => {
                    format!(
                        "jerk-limited ramps, {:.0} mm/s³",
                        j.unwrap_or(DEFAULT_JERK_MM_S3)
                    )
                }
                (RampShape::Bell, _) => "bell-shaped ramps".to_string(),
                _ => "trapezoid ramps".to_string(),
            };
            writeln!(
                w,
                "expected run time {:.1} s ({:.2} min) at {:.0} mm/s², {ramp}",
                summary.run_time_s,
                s_to_min(summary.run_time_s),
                summary.accel_mm_s2
            )?;
            writeln!(
                w,
                "expected samples per channel {} at {:.3} ms",
                summary.samples_per_channel,
                summary.sample_interval_s * 1e3
            )?;
            for n in &summary.notes {
                writeln!(w, "note: {n}")?;
            }
        }
    }
    Ok(())
}
