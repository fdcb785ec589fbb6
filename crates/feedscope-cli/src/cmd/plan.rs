//! `feedscope plan`: NC programs (G-code) for the friction tests; the planning, its checks
//! and the summary are [`feedscope_app::plan`]'s.
use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::{Subcommand, ValueEnum};
use feedscope::plan::gcode::{Dialect, FanucMachine};
use feedscope::sim::RampShape;
use feedscope_app::plan::{PlanRequest, PlanTest, StrokesTest, TriangleTest};
use feedscope_app::FrontEnd;

use super::estimate::Format;
use crate::front::Cli;

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
    #[arg(long, default_value_t = PlanRequest::default().axis_letter)]
    pub axis_letter: char,
    /// FANUC program number (O number, 1-9999).
    #[arg(long, default_value_t = PlanRequest::default().program_number)]
    pub program_number: u32,
    /// Feed of the first move to the start position (mm/min) [default: the highest feed].
    #[arg(long)]
    pub approach_feed: Option<f64>,
    /// Acceleration the control uses for the axis (mm/s²), for run time and planning.
    #[arg(long, default_value_t = PlanRequest::default().accel_mm_s2)]
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
    #[arg(long, default_value_t = StrokesTest::default().repeats)]
    pub repeats: u32,
    /// Dwell after every stroke (s).
    #[arg(long, default_value_t = StrokesTest::default().dwell_s)]
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
    #[arg(long, default_value_t = TriangleTest::default().vs_guess_mm_min)]
    pub vs_guess: f64,
    /// Number of feed levels.
    #[arg(long, default_value_t = TriangleTest::default().levels)]
    pub levels: usize,
    /// Full cycles per level.
    #[arg(long, default_value_t = TriangleTest::default().cycles)]
    pub cycles: usize,
    /// Wanted constant-feed time per stroke (s).
    #[arg(long, default_value_t = TriangleTest::default().cruise_s)]
    pub cruise_s: f64,
    /// Dwell after every stroke (s).
    #[arg(long, default_value_t = TriangleTest::default().dwell_s)]
    pub dwell_s: f64,
    #[command(flatten)]
    pub common: Common,
}

impl From<DialectArg> for Dialect {
    fn from(a: DialectArg) -> Self {
        match a {
            DialectArg::Fanuc => Dialect::Fanuc,
            DialectArg::Siemens => Dialect::Siemens,
        }
    }
}

impl From<MachineArg> for FanucMachine {
    fn from(a: MachineArg) -> Self {
        match a {
            MachineArg::Lathe => FanucMachine::Lathe,
            MachineArg::Mill => FanucMachine::Mill,
        }
    }
}

impl From<RampArg> for RampShape {
    fn from(a: RampArg) -> Self {
        match a {
            RampArg::Trapezoid => RampShape::Trapezoid,
            RampArg::JerkLimited => RampShape::JerkLimited,
            RampArg::Bell => RampShape::Bell,
        }
    }
}

/// Request fields whose flag is not the field's name with `-` for `_` (the flags name no unit).
const FLAGS: &[(&str, &str)] = &[
    ("from_mm", "--from"),
    ("to_mm", "--to"),
    ("travel_min_mm", "--travel-min"),
    ("travel_max_mm", "--travel-max"),
    ("feed_limit_mm_min", "--feed-limit"),
    ("feed_max_mm_min", "--feed-max"),
    ("feed_min_mm_min", "--feed-min"),
    ("vs_guess_mm_min", "--vs-guess"),
    ("approach_feed_mm_min", "--approach-feed"),
];

/// The command line with `plan`'s flags: a value is spelled as clap spells it (`jerk-limited`
/// for the request's `jerk_limited`).
struct PlanFlags(Cli);

impl FrontEnd for PlanFlags {
    fn name(&self, field: &str) -> String {
        FLAGS
            .iter()
            .find(|(f, _)| *f == field)
            .map_or_else(|| self.0.name(field), |(_, flag)| (*flag).to_string())
    }

    fn spell(&self, field: &str, value: &str) -> String {
        format!("{} {}", self.name(field), value.replace('_', "-"))
    }
}

/// The request of the command line: the test's flags and the shared ones.
fn request(args: Args) -> (PlanRequest, Format) {
    let (test, c) = match args.test {
        Test::Strokes(s) => (
            PlanTest::Strokes(StrokesTest {
                from_mm: s.from,
                to_mm: s.to,
                feeds_mm_min: s.feeds,
                repeats: s.repeats,
                dwell_s: s.dwell_s,
            }),
            s.common,
        ),
        Test::Triangle(t) => (
            PlanTest::Triangle(TriangleTest {
                from_mm: t.from,
                to_mm: t.to,
                feed_max_mm_min: t.feed_max,
                feed_min_mm_min: t.feed_min,
                vs_guess_mm_min: t.vs_guess,
                levels: t.levels,
                cycles: t.cycles,
                cruise_s: t.cruise_s,
                dwell_s: t.dwell_s,
            }),
            t.common,
        ),
    };
    let request = PlanRequest {
        test,
        axis: c.axis,
        travel_min_mm: c.travel_min,
        travel_max_mm: c.travel_max,
        feed_limit_mm_min: c.feed_limit,
        dialect: c.dialect.into(),
        fanuc_machine: c.fanuc_machine.into(),
        axis_letter: c.axis_letter,
        program_number: c.program_number,
        approach_feed_mm_min: c.approach_feed,
        accel_mm_s2: c.accel_mm_s2,
        ramp: c.ramp.into(),
        jerk_mm_s3: c.jerk_mm_s3,
        sample_interval_ms: c.sample_interval_ms,
        sample_rate_hz: c.sample_rate_hz,
        output: Some(c.output),
    };
    (request, c.format)
}

pub fn run(args: Args) -> Result<()> {
    let (request, format) = request(args);
    let report = request.run(&PlanFlags(Cli::default()))?.report;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    let mut w = std::io::stdout().lock();
    match format {
        Format::Json => writeln!(w, "{}", serde_json::to_string_pretty(&report)?)?,
        Format::Text => write!(w, "{}", report.text())?,
    }
    Ok(())
}
