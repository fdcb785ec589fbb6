//! `feedscope estimate`: friction along the travel from a trace file.
use crate::output::outln;
use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::ValueEnum;
use feedscope::diag::Code;
use feedscope::estimate::{
    EffortSign, Move, MoveKind, PositionSmoothing, StrokeSummary, TimeOfPosition,
};
use feedscope::spline::EndCondition;
use feedscope::verdict::FrictionSign;
use feedscope_app::estimate::{
    parse_cutoff, EstimateOptions, EstimateReport, EstimateRequest, Estimated, ReadMode,
};
use feedscope_io::friction_csv;

use crate::front::Cli;
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
    let report = &estimated.report;
    let json = serde_json::to_string_pretty(report)?;
    // Everything is rendered before anything is put in place, so an error leaves earlier
    // outputs untouched.
    let svg = match &plot_path {
        Some(_) => {
            let name = report.axis.name.as_deref().unwrap_or("axis");
            let v = &report.verdict;
            Some(plot::friction_svg(
                &estimated.plot,
                &format!(
                    "Friction along the travel ({name}); data support: {}{}",
                    v.support.as_str(),
                    if v.friction_sign == FrictionSign::FromDirection {
                        "; sign from direction"
                    } else {
                        ""
                    }
                ),
                vec![],
                vec![],
            )?)
        }
        None => None,
    };
    let Estimated { report, csv, .. } = estimated;
    csv.commit()?;
    crate::output::write_atomic(&summary_path, json.as_bytes())?;
    if let (Some(p), Some(svg)) = (&plot_path, svg) {
        crate::output::write_atomic(p, svg.as_bytes())?;
    }
    match args.format {
        Format::Json => {
            let mut out = std::io::stdout().lock();
            writeln!(out, "{json}")?;
        }
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

/// The stroke table for people.
pub fn print_table(summary: &EstimateReport) -> Result<()> {
    outln!(
        "{:>6}  {:<8}  {:>10}  {:>9}  {:>9}  {:>12}  {:>8}  {:>9}  {:>8}  {:>8}  {:>7}  {}",
        "stroke",
        "dir",
        "feed",
        "from",
        "to",
        "mean F_f",
        "±",
        "floor",
        "cut-off",
        "samples",
        "max",
        "supports"
    );
    outln!(
        "{:>6}  {:<8}  {:>10}  {:>9}  {:>9}  {:>12}  {:>8}  {:>9}  {:>8}  {:>8}  {:>7}",
        "",
        "",
        "(mm/min)",
        "(mm)",
        "(mm)",
        "(N)",
        "(N, SE)",
        "(N RMS)",
        "(Hz)",
        "per lead",
        "order"
    );
    for s in &summary.strokes {
        let kind = if s.kind == MoveKind::Measuring {
            String::new()
        } else {
            format!("  ({})", s.kind.as_str())
        };
        outln!(
            "{:>6}  {:<8}  {:>10.1}  {:>9.2}  {:>9.2}  {:>12.2}  {:>8}  {:>9.2}  {:>8}  {:>8.1}  {:>7.1}  {}{kind}",
            s.stroke,
            s.direction.as_str(),
            s.feed_mm_min,
            s.start_mm,
            s.end_mm,
            s.mean_friction_n,
            s.mean_friction_se_n
                .map_or_else(|| "-".to_string(), |e| format!("{e:.2}")),
            s.noise_floor.total_n,
            s.position_cutoff_hz
                .map_or_else(|| "-".to_string(), |f| format!("{f:.1}")),
            s.raw_samples_per_lead,
            s.max_order,
            s.verdict.as_ref().map_or("-", |v| v.support.as_str())
        );
    }
    // A feed that varies along a stroke by more than ±10 % of its mean (a modulation, an
    // override changed mid-block) is named with its range.
    let varying: Vec<(&StrokeSummary, f64, f64)> = summary
        .strokes
        .iter()
        .filter_map(|s| Some((s, s.feed_min_mm_min?, s.feed_max_mm_min?)))
        .filter(|&(s, lo, hi)| lo < 0.9 * s.feed_mm_min || hi > 1.1 * s.feed_mm_min)
        .collect();
    if !varying.is_empty() {
        outln!();
        outln!("feed varies along strokes (5th-95th percentile of the chord speeds):");
        for (s, lo, hi) in varying {
            outln!(
                "  stroke {:>4}  {:>10.1} mm/min, from {:.1} to {:.1} mm/min ({:+.0} % / {:+.0} %)",
                s.stroke,
                s.feed_mm_min,
                lo,
                hi,
                100.0 * (lo / s.feed_mm_min - 1.0),
                100.0 * (hi / s.feed_mm_min - 1.0)
            );
        }
    }
    outln!();
    outln!("{}", summary.verdict.headline());
    let left_out: Vec<&Move> = summary
        .moves
        .iter()
        .filter(|m| m.strokes.is_empty())
        .collect();
    if !left_out.is_empty() {
        outln!();
        outln!("moves left out (no friction estimated):");
        for m in left_out {
            let feed = match (m.feed_mm_min, m.gap_s) {
                (Some(f), None) => format!("{} mm/min", feed_text(f)),
                (Some(f), Some(g)) => {
                    format!("{} mm/min, spans a gap of {g:.1} s", feed_text(f))
                }
                (None, Some(g)) => format!("spans a gap of {g:.1} s: no feed"),
                (None, None) => "feed unknown".to_string(),
            };
            outln!(
                "  {:<11}  {:<8}  {:>17}  {:>9.2} → {:>9.2} mm  t = {:.3} s to {:.3} s{}",
                m.kind.as_str(),
                m.direction.as_str(),
                feed,
                m.start_mm,
                m.end_mm,
                m.start_time_s,
                m.end_time_s,
                m.program_line
                    .map(|l| format!("  (program line {l})"))
                    .unwrap_or_default()
            );
        }
    }
    for n in &summary.notes {
        eprintln!("note: {n}");
    }
    for r in &summary.verdict.reasons {
        eprintln!("verdict: {r}");
    }
    for (code, (count, first)) in verdict_reasons(&summary.strokes) {
        eprintln!("verdict: {count} stroke(s) limited by {code}; e.g. {first}");
    }
    for line in stroke_warnings(&summary.strokes) {
        eprintln!("warning: {line}");
    }
    for w in &summary.skipped {
        eprintln!("warning: skipped {w}");
    }
    if summary.ignored_rows > 0 {
        eprintln!(
            "note: ignored {} rows of other channels ({})",
            summary.ignored_rows,
            summary.ignored_channels.join(", ")
        );
    }
    Ok(())
}

/// A feed for people (mm/min): to 0.1 mm/min from 10 mm/min up, else to 3 significant
/// digits, so that a slow move never reads "0.0".
fn feed_text(f: f64) -> String {
    let a = f.abs();
    if a >= 10.0 || a == 0.0 || !a.is_finite() {
        format!("{f:.1}")
    } else if a >= 1e-6 {
        let decimals = (2.0 - a.log10().floor()) as usize;
        format!("{f:.decimals$}")
    } else {
        format!("{f:.2e}")
    }
}

/// Warnings of a stroke about its friction profile (its spectrum, its noise against the
/// variation along it): moot for a stroke whose data support only its mean level, where the
/// profile is withheld anyway.
const PROFILE_WARNINGS: [Code; 5] = [
    Code::FewSamplesPerLead,
    Code::PositionSmoothedBelowOrder,
    Code::NoiseFloorHigh,
    Code::FeedChangeUnresolved,
    Code::PositionNotMonotone,
];

/// The strokes' warnings as lines for the terminal: one per stroke and warning, except that a
/// warning about the profile on strokes whose profile is withheld (mean level only), and any
/// warning repeated on more than [`WARNING_REPEATS_SHOWN`] strokes, is one line that counts
/// the strokes, lists them and quotes the first. The JSON summary keeps every one.
fn stroke_warnings(strokes: &[StrokeSummary]) -> Vec<String> {
    let key =
        |s: &StrokeSummary, code: Code| (mean_only(s) && PROFILE_WARNINGS.contains(&code), code);
    let mut by_code: std::collections::BTreeMap<(bool, Code), Vec<&StrokeSummary>> =
        std::collections::BTreeMap::new();
    for s in strokes {
        for w in &s.warnings {
            by_code.entry(key(s, w.code)).or_default().push(s);
        }
    }
    let mut lines = Vec::new();
    let mut collapsed = Vec::new();
    for s in strokes {
        for w in &s.warnings {
            let k = key(s, w.code);
            let moot = k.0;
            let group = &by_code[&k];
            if !moot && group.len() <= WARNING_REPEATS_SHOWN {
                lines.push(format!("stroke {}: {w}", s.stroke));
            } else if std::ptr::eq(group[0], s) {
                let numbers: Vec<usize> = group.iter().map(|g| g.stroke).collect();
                let first = group[0]
                    .warnings
                    .iter()
                    .find(|x| x.code == w.code)
                    .map_or_else(String::new, |x| x.message.clone());
                collapsed.push(format!(
                    "{} stroke(s) ({}){}: {}; e.g. stroke {}: {first} (each in the JSON summary)",
                    numbers.len(),
                    number_list(&numbers),
                    if moot {
                        ", whose profile is withheld anyway (mean level only)"
                    } else {
                        ""
                    },
                    w.code,
                    numbers[0],
                ));
            }
        }
    }
    // The warnings that bear on what is reported come before the moot ones.
    lines.extend(collapsed);
    lines
}

/// Warnings repeated on more strokes than this are one line ([`stroke_warnings`]).
const WARNING_REPEATS_SHOWN: usize = 3;

/// Stroke numbers as ranges: `0-3, 5, 7-8`.
fn number_list(n: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut k = 0;
    while k < n.len() {
        let mut j = k;
        while j + 1 < n.len() && n[j + 1] == n[j] + 1 {
            j += 1;
        }
        parts.push(if j > k {
            format!("{}-{}", n[k], n[j])
        } else {
            n[k].to_string()
        });
        k = j + 1;
    }
    parts.join(", ")
}

/// True when a stroke's data verdict supports no more than its mean level.
fn mean_only(s: &StrokeSummary) -> bool {
    friction_csv::is_mean_level(s)
}

/// The binding reasons of the strokes' verdicts, by code: how many strokes and the first
/// stroke's message.
fn verdict_reasons(strokes: &[StrokeSummary]) -> std::collections::BTreeMap<Code, (usize, String)> {
    let mut by_code = std::collections::BTreeMap::new();
    for s in strokes {
        for r in s.verdict.iter().flat_map(|v| &v.reasons) {
            by_code
                .entry(r.code)
                .or_insert((0, format!("stroke {}: {}", s.stroke, r.message)))
                .0 += 1;
        }
    }
    by_code
}
