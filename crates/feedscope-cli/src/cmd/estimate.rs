//! `feedscope estimate`: friction along the travel from a trace file.
use std::path::PathBuf;

use anyhow::Result;
use clap::ValueEnum;
use feedscope::estimate::{EffortSign, PositionSmoothing, TimeOfPosition};
use feedscope::spline::EndCondition;
use feedscope_app::estimate::{
    parse_cutoff, EstimateOptions, EstimateReport, EstimateRequest, Estimated, ReadMode,
};

use crate::front::Cli;
use crate::output::{out, outln};
use feedscope_app::plot;

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum EndArg {
    /// Third derivative continuous at the second and second-to-last knot (MATLAB `spline`).
    NotAKnot,
    /// Zero curvature at both ends.
    Natural,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum TimeArg {
    /// Invert the position spline z(t) exactly.
    Invert,
    /// Interpolate the knots (z, t) with a spline, as paper 000 does.
    KnotSpline,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum SignArg {
    /// As the trace's `# fact effort_signed` says (written by `feedscope import`); signed
    /// otherwise, with a warning when a never-negative effort suggests a magnitude.
    Auto,
    /// A signed current or torque: friction as Eq. 5.
    Signed,
    /// A magnitude (drive load): friction takes the sign of the direction of motion.
    Magnitude,
    /// A signed current or torque counted against the position (negative for motion towards
    /// +z, as some drives record it): turned, then friction as Eq. 5.
    Negated,
}

impl From<SignArg> for EffortSign {
    fn from(a: SignArg) -> Self {
        match a {
            SignArg::Auto => EffortSign::Auto,
            SignArg::Signed => EffortSign::Signed,
            SignArg::Magnitude => EffortSign::Magnitude,
            SignArg::Negated => EffortSign::Negated,
        }
    }
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum EffortArg {
    /// Use the `current_a` channel (needs torque_constant_nm_per_a).
    Current,
    /// Use the `torque_nm` channel.
    Torque,
}

impl From<EffortArg> for feedscope_app::recording::Effort {
    fn from(e: EffortArg) -> Self {
        match e {
            EffortArg::Current => Self::Current,
            EffortArg::Torque => Self::Torque,
        }
    }
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum Format {
    /// A table for people.
    Text,
    /// The JSON summary on stdout.
    Json,
}

/// Estimate friction along the travel (paper 000, Section 3, Eq. 5).
///
/// Finds the steady forward and backward strokes, interpolates position and current (or
/// torque) with cubic splines, resamples them every lead/m of travel and solves Eq. 5 for the
/// friction force. Writes a CSV with one row per resampled point
/// (`stroke,direction,position_mm,time_s,velocity_mm_s,accel_mm_s2,current_a|torque_nm,friction_n`),
/// a JSON summary per stroke and an SVG plot of friction against position.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Trace file: CSV in the long layout `time_s,channel,value` or the wide layout
    /// `time_s,position_mm,current_a`, or Parquet with the same columns.
    pub trace: PathBuf,
    /// Axis parameters (TOML, or JSON with the same keys).
    #[arg(long)]
    pub axis: PathBuf,
    /// Friction CSV to write.
    #[arg(short = 'o', long = "output", default_value = "friction.csv")]
    pub output: PathBuf,
    /// JSON summary to write [default: OUTPUT with extension .json].
    #[arg(long)]
    pub summary: Option<PathBuf>,
    /// SVG plot of friction vs position [default: OUTPUT with extension .svg].
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Do not write the SVG plot.
    #[arg(long)]
    pub no_plot: bool,
    /// Resampling points per screw lead (m in paper 000; the position step is lead/m).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub samples_per_lead: u32,
    /// Spline end condition.
    #[arg(long, value_enum, default_value_t = EndArg::NotAKnot)]
    pub end_condition: EndArg,
    /// How the run time t(z) at each resampled position is found.
    #[arg(long, value_enum, default_value_t = TimeArg::Invert)]
    pub time_of_position: TimeArg,
    /// Position smoothing before differentiation: `auto` chooses a cut-off per stroke from
    /// its sampling rate, position quantum, effort noise and settling time; a number is a
    /// fixed cut-off in Hz; `off` always interpolates (paper 000).
    #[arg(long, default_value = "auto", value_parser = parse_cutoff)]
    pub position_cutoff_hz: PositionSmoothing,
    /// Also estimate rapids and jogs (marked with their kind in the summary); they
    /// are left out by default.
    #[arg(long)]
    pub include_rapids: bool,
    /// The NC program that made the trace (FANUC or SINUMERIK, as `plan` writes them, or a
    /// hand-written G0/G1/F/G4 program): labels each stroke with its block and programmed feed,
    /// G0 blocks as rapids, unprogrammed motion as jogs.
    #[arg(long)]
    pub program: Option<PathBuf>,
    /// Axis address of this axis in the program.
    #[arg(long, default_value_t = 'Z')]
    pub program_axis: char,
    /// Which effort channel to use when the file has both current and torque.
    #[arg(long, value_enum)]
    pub effort: Option<EffortArg>,
    /// Whether the effort carries its sign.
    #[arg(long, value_enum, default_value_t = SignArg::Auto)]
    pub effort_sign: SignArg,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
    /// How the trace is read: `auto` estimates strokes while reading (memory for the longest
    /// stroke, not the file) whenever the result is the whole-trace one, else reads it whole.
    #[arg(long, value_enum, default_value_t = ReadArg::Auto)]
    pub read: ReadArg,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum ReadArg {
    /// Estimate while reading when the result is provably the whole-trace one, else read the
    /// whole trace first.
    Auto,
    /// Estimate while reading, or fail saying why it cannot be vouched for (NC program,
    /// Parquet, glitches, rapids without a rapid rate ...).
    Stream,
    /// Read the whole trace first.
    Whole,
}

impl From<EndArg> for EndCondition {
    fn from(a: EndArg) -> Self {
        match a {
            EndArg::NotAKnot => EndCondition::NotAKnot,
            EndArg::Natural => EndCondition::Natural,
        }
    }
}

impl From<TimeArg> for TimeOfPosition {
    fn from(a: TimeArg) -> Self {
        match a {
            TimeArg::Invert => TimeOfPosition::Invert,
            TimeArg::KnotSpline => TimeOfPosition::KnotSpline,
        }
    }
}

impl From<ReadArg> for ReadMode {
    fn from(a: ReadArg) -> Self {
        match a {
            ReadArg::Auto => ReadMode::Auto,
            ReadArg::Stream => ReadMode::Stream,
            ReadArg::Whole => ReadMode::Whole,
        }
    }
}

/// The request of `feedscope estimate`.
fn request(args: &Args) -> EstimateRequest {
    EstimateRequest {
        input: args.trace.clone(),
        axis: args.axis.clone(),
        output: args.output.clone(),
        options: EstimateOptions {
            samples_per_lead: args.samples_per_lead,
            end_condition: args.end_condition.into(),
            time_of_position: args.time_of_position.into(),
            position_cutoff_hz: args.position_cutoff_hz,
            include_rapids: args.include_rapids,
            effort_sign: args.effort_sign.into(),
            effort: args.effort.map(Into::into),
            program: args.program.clone(),
            program_axis: args.program_axis,
            read: args.read.into(),
        },
    }
}

pub fn run(args: Args) -> Result<()> {
    let summary_path = args
        .summary
        .clone()
        .unwrap_or_else(|| args.output.with_extension("json"));
    let plot_path = (!args.no_plot).then(|| {
        args.plot
            .clone()
            .unwrap_or_else(|| args.output.with_extension("svg"))
    });
    let estimated = request(&args).run(&Cli::default())?;
    let json = serde_json::to_string_pretty(&estimated.report)?;
    // Everything is rendered before anything is put in place, so an error leaves earlier
    // outputs untouched.
    let svg = match &plot_path {
        Some(_) => Some(plot::estimate_svg(&estimated)?),
        None => None,
    };
    let Estimated { report, csv, .. } = estimated;
    csv.commit()?;
    crate::output::write_atomic(&summary_path, json.as_bytes())?;
    if let (Some(p), Some(svg)) = (&plot_path, svg) {
        crate::output::write_atomic(p, svg.as_bytes())?;
    }
    match args.format {
        Format::Json => outln!("{json}"),
        Format::Text => {
            print_table(&report)?;
            eprintln!(
                "wrote {} ({} strokes), {}{}",
                args.output.display(),
                report.strokes.len(),
                summary_path.display(),
                plot_path
                    .map(|p| format!(", {}", p.display()))
                    .unwrap_or_default()
            );
        }
    }
    Ok(())
}

/// The report's text view on stdout and its remarks (notes, verdicts, warnings) on stderr.
pub fn print_table(report: &EstimateReport) -> Result<()> {
    out!("{report}");
    for line in report.remarks() {
        eprintln!("{line}");
    }
    Ok(())
}
