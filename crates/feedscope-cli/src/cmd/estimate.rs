//! `feedscope estimate`: friction along the travel from a trace file.
use crate::output::outln;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::ValueEnum;
use feedscope::axis::AxisParams;
use feedscope::estimate::stream::{StreamEstimator, Streamed};
use feedscope::estimate::{
    estimate_pieces_streaming, EffortSign, EstimateParams, Move, MoveKind, PositionSmoothing,
    StrokeFriction, StrokePiece, StrokeSummary, TimeOfPosition, Zone,
};
use feedscope::spline::EndCondition;
use feedscope::trace::{EffortKind, GlitchParams, Trace};
use feedscope::units::feed_m_s_to_mm_min;
use feedscope::verdict::{DataVerdict, FrictionSign};
use feedscope_io::friction_csv;
use feedscope_io::trace::{
    read_trace_file_with, stream_trace_file, DroppedSample, ReadOptions, ReadReport, StreamRead,
    TraceChunk, TraceError,
};
use serde::Serialize;

use crate::output::{bar, AtomicFile};
use crate::plot;

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

/// The JSON summary written beside the friction CSV.
#[derive(Debug, Serialize)]
pub struct Summary {
    pub source: String,
    pub effort: EffortKind,
    /// What the recording supports (see `feedscope::verdict`).
    pub verdict: DataVerdict,
    pub axis: AxisParams,
    pub params: EstimateParams,
    pub strokes: Vec<StrokeSummary>,
    pub moves: Vec<Move>,
    pub notes: Vec<String>,
    pub zones: Vec<Zone>,
    pub skipped: Vec<String>,
    pub ignored_rows: u64,
    pub ignored_channels: Vec<String>,
    /// Position samples dropped as logger glitches (impossible jumps), with time and line.
    pub dropped_position_samples: Vec<DroppedPosition>,
    /// The speed limit the glitch screen used (mm/min).
    pub max_axis_speed_mm_min: Option<f64>,
    /// The CSV's last data line when the file does not end with a line end (a cut file).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unterminated_last_line: Option<u64>,
}

/// A dropped position sample as the summary reports it (user units).
#[derive(Debug, Serialize)]
pub struct DroppedPosition {
    pub time_s: f64,
    pub position_mm: f64,
    /// 1-based CSV line, when read from CSV.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub line: Option<u64>,
    /// 1-based Parquet data row, when read from Parquet.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub row: Option<u64>,
}

impl From<&DroppedSample> for DroppedPosition {
    fn from(d: &DroppedSample) -> Self {
        Self {
            time_s: d.time_s,
            position_mm: d.position_m * 1e3,
            line: d.line,
            row: d.row,
        }
    }
}

/// Plot data kept while streaming: decimated friction per stroke.
#[derive(Default)]
pub struct PlotData {
    pub forward: Vec<Vec<(f64, f64)>>,
    pub backward: Vec<Vec<(f64, f64)>>,
    /// Stroke numbers of `forward` and `backward`, as the console table numbers them.
    pub numbers: [Vec<usize>; 2],
    /// Whether each stroke is drawn as its mean level only (its data support no profile).
    pub mean_only: [Vec<bool>; 2],
    /// Every how many of a new stroke's points is kept, per direction (0 or 1: every one):
    /// doubled whenever a direction's points pass [`PLOT_POINTS_PER_DIRECTION`], so that the
    /// plot of many strokes, and the memory it takes, stays bounded.
    thin: [usize; 2],
    /// The friction's sign comes from the direction of motion (the effort is a magnitude).
    pub sign_from_direction: bool,
}

const PLOT_POINTS_PER_STROKE: usize = 4000;
/// Points of all strokes of one direction at most (see [`PlotData::thin`]).
const PLOT_POINTS_PER_DIRECTION: usize = 100_000;
/// Up to this many strokes of a direction are each drawn in a colour of their own and named
/// in the legend; more are drawn thin in one colour per kind, with one legend entry per kind
/// that counts them.
const PLOT_NAMED_STROKES: usize = 6;

/// Every `n`-th point and the last one.
fn every_nth(points: Vec<(f64, f64)>, n: usize) -> Vec<(f64, f64)> {
    let last = points.len().saturating_sub(1);
    points
        .into_iter()
        .enumerate()
        .filter(|(j, _)| j % n == 0 || *j == last)
        .map(|(_, p)| p)
        .collect()
}

impl PlotData {
    /// Friction vs position of one stroke, decimated for plotting ((mm, N) pairs).
    /// A stroke whose data support no profile is drawn as its mean level: a flat line, not
    /// the spline's swings between sparse samples.
    /// The same of one piece of a stroke's rows, decimated by the whole stroke's length (a
    /// stroke whose data support no profile is reduced to its mean level by [`Self::add`]).
    fn points(s: &StrokeFriction) -> Vec<(f64, f64)> {
        if mean_only(&s.summary) {
            return Vec::new();
        }
        let stride = s.summary.points.div_ceil(PLOT_POINTS_PER_STROKE).max(1);
        s.position_m
            .iter()
            .zip(&s.friction_n)
            .step_by(stride)
            .map(|(z, f)| (z * 1e3, *f))
            .collect()
    }

    fn add(&mut self, s: &StrokeSummary, mut points: Vec<(f64, f64)>) {
        let flat = mean_only(s);
        if flat {
            let m = s.mean_friction_n;
            points = vec![(s.start_mm, m), (s.end_mm, m)];
        }
        let k = usize::from(s.direction == feedscope::estimate::Direction::Backward);
        let dst = if k == 0 {
            &mut self.forward
        } else {
            &mut self.backward
        };
        let thin = &mut self.thin[k];
        if !flat && *thin > 1 {
            points = every_nth(points, *thin);
        }
        dst.push(points);
        self.numbers[k].push(s.stroke);
        self.mean_only[k].push(flat);
        // Every stroke is drawn: many of them thin out, all alike.
        while dst.iter().map(Vec::len).sum::<usize>() > PLOT_POINTS_PER_DIRECTION
            && dst.iter().any(|p| p.len() > 2)
        {
            *thin = (*thin).max(1) * 2;
            for p in dst.iter_mut() {
                *p = every_nth(std::mem::take(p), 2);
            }
        }
    }

    /// Friction vs position: one panel per direction, with optional extra series (e.g. the
    /// truth) per direction. Every stroke is drawn: a profile as a line, a stroke whose data
    /// support only its mean level as a flat segment at that level with a marker at its middle.
    /// Up to [`PLOT_NAMED_STROKES`] strokes a panel are named one by one; more are drawn thin,
    /// in the direction's colour, and the legend counts them.
    pub fn svg(
        &self,
        title: &str,
        mut extra_forward: Vec<plot::Series>,
        mut extra_backward: Vec<plot::Series>,
    ) -> Result<String> {
        let mut charts_series = Vec::new();
        for (d, (label, strokes, extra)) in [
            ("forward", &self.forward, &mut extra_forward),
            ("backward", &self.backward, &mut extra_backward),
        ]
        .into_iter()
        .enumerate()
        {
            if strokes.is_empty() {
                continue;
            }
            let (numbers, flat) = (&self.numbers[d], &self.mean_only[d]);
            let is_flat = |k: usize| flat.get(k).copied().unwrap_or(false);
            let mut series: Vec<plot::Series> = if strokes.len() <= PLOT_NAMED_STROKES {
                strokes
                    .iter()
                    .enumerate()
                    .map(|(k, pts)| plot::Series {
                        // Numbered as in the console table and the CSV, not within the plot.
                        name: match (strokes.len() > 1, is_flat(k)) {
                            (_, true) => format!(
                                "{label} stroke {}: mean level only (no profile supported)",
                                numbers[k]
                            ),
                            (true, false) => format!("{label} stroke {}", numbers[k]),
                            (false, false) => {
                                format!("{label} stroke {} (estimated)", numbers[k])
                            }
                        },
                        points: pts.clone(),
                        style: if is_flat(k) {
                            plot::Style::Level { colour: k }
                        } else {
                            plot::Style::Line
                        },
                    })
                    .collect()
            } else {
                let n_flat = (0..strokes.len()).filter(|&k| is_flat(k)).count();
                let n_profile = strokes.len() - n_flat;
                let (mut named_profile, mut named_flat) = (false, false);
                strokes
                    .iter()
                    .enumerate()
                    .map(|(k, pts)| {
                        let (name, style) = if is_flat(k) {
                            let name = (!std::mem::replace(&mut named_flat, true)).then(|| {
                                format!(
                                    "{label}: {n_flat} of {} strokes, mean level only (no \
                                     profile supported)",
                                    strokes.len()
                                )
                            });
                            (name, plot::Style::Level { colour: d + 2 })
                        } else {
                            let name = (!std::mem::replace(&mut named_profile, true)).then(|| {
                                format!(
                                    "{label}: {n_profile} of {} strokes, friction along the \
                                     travel",
                                    strokes.len()
                                )
                            });
                            (name, plot::Style::Thin { colour: d })
                        };
                        plot::Series {
                            name: name.unwrap_or_default(),
                            points: pts.clone(),
                            style,
                        }
                    })
                    .collect()
            };
            series.append(extra);
            charts_series.push((label, series));
        }
        let titles: Vec<String> = charts_series
            .iter()
            .map(|(label, _)| format!("{title}: {label}"))
            .collect();
        let charts: Vec<plot::LineChart> = charts_series
            .into_iter()
            .zip(&titles)
            .map(|((_, series), t)| plot::LineChart {
                title: t,
                x_label: "position (mm)",
                y_label: if self.sign_from_direction {
                    "friction F_f (N, sign from the direction of motion)"
                } else {
                    "friction F_f (N, signed as Eq. 5)"
                },
                series,
            })
            .collect();
        plot::stacked_svg(&charts)
    }
}

/// A piece of a stroke formatted as CSV rows, in chunks.
type CsvRows = Vec<Vec<u8>>;
/// (position mm, friction N) points of a piece, decimated for the plot.
type PlotPoints = Vec<(f64, f64)>;

/// What an estimate run produced; `csv` is written but not yet in place (see
/// [`AtomicFile::commit`]), so the caller can commit all outputs together.
pub struct Outcome {
    pub summary: Summary,
    pub plot: PlotData,
    pub csv: AtomicFile,
}

/// Strokes formatted for the CSV and decimated for the plot, inside the parallel section.
type Formatted = (CsvRows, PlotPoints);
/// What an estimation hands each stroke (or piece of one) to.
type PieceSink<'a> = dyn FnMut(StrokePiece<Formatted>) -> Result<()> + 'a;

/// What the CSV writer thread is handed.
enum ToCsv {
    /// Rows to write.
    Rows(CsvRows),
    /// A long stroke's pieces start here: the rows up to [`ToCsv::Keep`] or
    /// [`ToCsv::Retract`] may be taken back.
    Mark,
    /// The marked stroke's rows stay.
    Keep,
    /// The marked stroke's data support only its mean level: its rows are taken back and
    /// these written instead.
    Retract(CsvRows),
}

/// The writer thread's state: where the marked stroke started (a regular file), or its rows
/// held in memory (an output that cannot be cut back, such as a pipe).
#[derive(Default)]
struct CsvWriter {
    mark: Option<u64>,
    held: Option<CsvRows>,
}

impl CsvWriter {
    fn take(&mut self, out: &mut AtomicFile, msg: ToCsv) -> std::io::Result<()> {
        use std::io::{Seek, SeekFrom};
        let w = out.writer();
        match msg {
            ToCsv::Rows(parts) => match &mut self.held {
                Some(held) => held.extend(parts),
                None => {
                    for buf in parts {
                        w.write_all(&buf)?;
                    }
                }
            },
            ToCsv::Mark => {
                w.flush()?;
                let f = w.get_mut();
                if f.metadata()?.is_file() {
                    self.mark = Some(f.stream_position()?);
                } else {
                    self.held = Some(Vec::new());
                }
            }
            ToCsv::Keep => {
                self.mark = None;
                for buf in self.held.take().unwrap_or_default() {
                    w.write_all(&buf)?;
                }
            }
            ToCsv::Retract(parts) => {
                self.held = None;
                if let Some(at) = self.mark.take() {
                    w.flush()?;
                    let f = w.get_mut();
                    f.set_len(at)?;
                    f.seek(SeekFrom::Start(at))?;
                }
                for buf in parts {
                    w.write_all(&buf)?;
                }
            }
        }
        Ok(())
    }
}

/// What the CSV writer made of the strokes handed to it.
struct Written {
    csv: AtomicFile,
    summaries: Vec<StrokeSummary>,
    plot: PlotData,
}

/// Run `estimate` with a sink that streams the friction CSV (header for `effort_kind`) into
/// `csv_path` (atomically, not yet committed) on a writer thread, and gathers the summaries
/// and plot points; `pb` counts position samples.
fn write_friction_csv<R>(
    csv_path: &Path,
    effort_kind: EffortKind,
    pb: &indicatif::ProgressBar,
    estimate: impl FnOnce(
        &(dyn Fn(StrokeFriction) -> Formatted + Sync),
        &mut PieceSink<'_>,
    ) -> Result<R>,
) -> Result<(Written, R)> {
    let mut out = AtomicFile::create(csv_path)?;
    friction_csv::write_header(out.writer(), effort_kind)
        .with_context(|| format!("writing {}", csv_path.display()))?;
    let n_threads = rayon::current_num_threads();
    let mut summaries = Vec::new();
    let mut plot = PlotData::default();
    // A writer thread takes formatted strokes, so the copy into the file overlaps with the
    // estimation of the next batch; the bounded channel caps the memory in flight.
    let (tx, rx) = std::sync::mpsc::sync_channel::<ToCsv>(2 * n_threads);
    let (estimated, out) = std::thread::scope(|scope| {
        let writer = scope.spawn(move || -> Result<AtomicFile> {
            let mut w = CsvWriter::default();
            for msg in rx {
                w.take(&mut out, msg)
                    .with_context(|| format!("writing {}", csv_path.display()))?;
            }
            Ok(out)
        });
        // A long stroke comes in pieces (rows, then its summary): its points for the plot
        // gather here until the summary says how to draw it.
        let mut pts = Vec::new();
        // The rows of the stroke being handed out, held until its end or its next piece: a
        // stroke in one piece whose data support only its mean level then never reaches the
        // file, and the pieces of a long one are marked so that they can be taken back.
        let mut held: Option<CsvRows> = None;
        let mut pieced = false;
        // Its formatted rows: none for a stroke whose final summary supports no profile (a
        // stroke in one piece, or a long one's last piece).
        let map = |s: StrokeFriction| {
            let rows = if mean_only(&s.summary) {
                Vec::new()
            } else {
                friction_csv::format_stroke(&s)
            };
            (rows, PlotData::points(&s))
        };
        let mut sink = |piece: StrokePiece<Formatted>| -> Result<()> {
            // A send fails only when the writer stopped on an error; join() reports it.
            let send = |m: ToCsv| {
                tx.send(m)
                    .map_err(|_| anyhow::anyhow!("the CSV writer stopped"))
            };
            match piece {
                StrokePiece::Rows((rows, p)) => {
                    if let Some(before) = held.take() {
                        if !pieced {
                            send(ToCsv::Mark)?;
                            pieced = true;
                        }
                        send(ToCsv::Rows(before))?;
                    }
                    held = Some(rows);
                    pts.extend(p);
                }
                StrokePiece::End(summary) => {
                    pb.inc(summary.position_samples as u64);
                    let rows = held.take().unwrap_or_default();
                    if mean_only(&summary) {
                        let level = vec![friction_csv::format_mean_level(&summary)];
                        send(if pieced {
                            ToCsv::Retract(level)
                        } else {
                            ToCsv::Rows(level)
                        })?;
                    } else {
                        send(ToCsv::Rows(rows))?;
                        if pieced {
                            send(ToCsv::Keep)?;
                        }
                    }
                    pieced = false;
                    plot.add(&summary, std::mem::take(&mut pts));
                    summaries.push(*summary);
                }
            }
            Ok(())
        };
        let estimated = estimate(&map, &mut sink);
        drop(tx);
        let out = writer
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p));
        (estimated, out)
    });
    // A writer error explains a failed send better than the send itself.
    let csv = out?;
    let r = estimated?;
    Ok((
        Written {
            csv,
            summaries,
            plot,
        },
        r,
    ))
}

/// The summary of an estimate run.
#[allow(clippy::too_many_arguments)]
fn outcome(
    written: Written,
    outline: feedscope::estimate::Outline,
    report: &ReadReport,
    source: &str,
    effort: EffortKind,
    axis: &AxisParams,
    params: &EstimateParams,
) -> Outcome {
    Outcome {
        csv: written.csv,
        summary: Summary {
            source: source.to_string(),
            effort,
            verdict: outline.verdict.clone(),
            axis: axis.clone(),
            params: params.clone(),
            strokes: written.summaries,
            moves: outline.moves,
            notes: outline.notes,
            zones: outline.zones,
            skipped: outline.skipped,
            ignored_rows: report.ignored_rows,
            ignored_channels: report.ignored_channels.clone(),
            dropped_position_samples: report.dropped_position.iter().map(Into::into).collect(),
            max_axis_speed_mm_min: report.max_axis_speed_m_s.map(feed_m_s_to_mm_min),
            unterminated_last_line: report.unterminated_last_line,
        },
        plot: written.plot,
    }
}

/// Estimate `trace` and stream the friction CSV into `csv_path` (atomically).
pub fn estimate_to_csv(
    trace: &Trace,
    report: &ReadReport,
    source: &str,
    axis: &AxisParams,
    params: &EstimateParams,
    csv_path: &Path,
) -> Result<Outcome> {
    let pb = bar(trace.position_m.len() as u64, "estimate");
    let batch = 2 * rayon::current_num_threads();
    let (written, outline) = write_friction_csv(csv_path, trace.effort_kind, &pb, |map, sink| {
        estimate_pieces_streaming(trace, axis, params, batch, map, sink)
    })?;
    pb.finish_and_clear();
    Ok(outcome(
        written,
        outline,
        report,
        source,
        trace.effort_kind,
        axis,
        params,
    ))
}

/// One block of a streamed read, as the reading thread hands it to the estimator.
#[derive(Default)]
struct Block {
    facts: feedscope::trace::RecordingFacts,
    position_m: feedscope::trace::Channel,
    effort: feedscope::trace::Channel,
    /// The block holds both current and torque rows and no choice was made.
    both_efforts: bool,
    bytes_read: u64,
    file_bytes: u64,
}

/// The effort channel a streamed read takes, from its first block with effort samples: the
/// one asked for, the wide layout's column, or the only one of the long layout's rows. `None`
/// when that cannot be told there (the whole read says what is wrong).
fn streamed_effort_kind(path: &Path, opts: &ReadOptions) -> Option<EffortKind> {
    if opts.effort.is_some() {
        return opts.effort;
    }
    let mut kind = None;
    let mut first = |c: TraceChunk<'_>| -> Result<bool, TraceError> {
        kind = match (
            c.wide_effort,
            c.current_a.is_empty(),
            c.torque_nm.is_empty(),
        ) {
            (Some(k), _, _) => Some(k),
            (None, false, true) => Some(EffortKind::CurrentA),
            (None, true, false) => Some(EffortKind::TorqueNm),
            (None, true, true) => return Ok(true),
            (None, false, false) => None,
        };
        Ok(false)
    };
    match stream_trace_file(path, opts, &mut first) {
        Ok(StreamRead::Stopped) => kind,
        _ => None,
    }
}

/// Estimate while reading (see `feedscope::estimate::stream`): strokes are estimated and
/// written as the file is read, in memory that holds the stroke being read, not the file.
/// `None` when the result could not be vouched for and the whole trace must be read
/// (Parquet, an NC program, glitches, rapids without a rapid rate, anything the whole read
/// refuses: it then gives the exact result or error); a second pass when the first ends with
/// other segmentation statistics than its prefix gave.
fn stream_estimate_to_csv(
    path: &Path,
    opts: &ReadOptions,
    glitch: &GlitchParams,
    axis: &AxisParams,
    params: &EstimateParams,
    csv_path: &Path,
) -> Result<Result<(Outcome, ReadReport), String>> {
    if !params.program.is_empty() {
        return Ok(Err("an NC program labels the strokes".into()));
    }
    let Some(kind) = streamed_effort_kind(path, opts) else {
        return Ok(Err(
            "the file is Parquet, or its first effort rows do not tell the channel".into(),
        ));
    };
    let source = path.display().to_string();
    let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let mut given = None;
    for _pass in 0..2 {
        let pb = bar(size, "estimate");
        let batch = 2 * rayon::current_num_threads();
        // The estimation's own counting is by samples; this bar counts the file's bytes.
        let hidden = indicatif::ProgressBar::hidden();
        let (written, (end, report)) = write_friction_csv(csv_path, kind, &hidden, |map, sink| {
            let mut sink = Some(sink);
            let mut est: Option<StreamEstimator<'_, Formatted, anyhow::Error>> = None;
            // The file is read and parsed on a thread of its own, so that parsing the next
            // blocks overlaps with estimating the strokes of the last ones; two blocks in
            // flight bound the memory this adds.
            let (tx, rx) = std::sync::mpsc::sync_channel::<Block>(2);
            let (back_tx, back_rx) = std::sync::mpsc::channel::<Block>();
            let read = std::thread::scope(|scope| -> Result<StreamRead> {
                let pb = &pb;
                let reader = scope.spawn(move || -> Result<StreamRead> {
                    let mut on_chunk = |c: TraceChunk<'_>| -> Result<bool> {
                        pb.set_position(c.bytes_read);
                        let (effort, other) = match kind {
                            EffortKind::CurrentA => (c.current_a, c.torque_nm),
                            EffortKind::TorqueNm => (c.torque_nm, c.current_a),
                        };
                        // A block the estimator is done with, refilled: fresh memory for
                        // every block would be first-touched (page faults) every time.
                        let mut block = back_rx.try_recv().unwrap_or_default();
                        block.facts = *c.facts;
                        for (dst, src) in [
                            (&mut block.position_m, c.position_m),
                            (&mut block.effort, effort),
                        ] {
                            dst.time_s.clear();
                            dst.time_s.extend_from_slice(&src.time_s);
                            dst.value.clear();
                            dst.value.extend_from_slice(&src.value);
                        }
                        // Both current and torque rows: the whole read names the choice.
                        block.both_efforts =
                            opts.effort.is_none() && c.wide_effort.is_none() && !other.is_empty();
                        block.bytes_read = c.bytes_read;
                        block.file_bytes = c.file_bytes;
                        // The estimator hung up: it gave up, or failed.
                        Ok(tx.send(block).is_ok())
                    };
                    stream_trace_file(path, opts, &mut on_chunk)
                });
                let estimated = (|| -> Result<()> {
                    for c in rx.iter() {
                        if c.both_efforts {
                            return Ok(());
                        }
                        if est.is_none() {
                            if c.position_m.is_empty() && c.effort.is_empty() {
                                continue;
                            }
                            let Some(sink) = sink.take() else {
                                return Ok(());
                            };
                            let mut e = StreamEstimator::new(
                                axis, params, kind, c.facts, *glitch, batch, map, sink,
                            );
                            if let Some(g) = given {
                                e = e.with_segmentation(g);
                            }
                            // Room for the whole file at this block's density (5 % spare), so
                            // that holding a long stroke never copies it; room never used is
                            // never touched.
                            if c.bytes_read > 0 {
                                let scale = c.file_bytes as f64 / c.bytes_read as f64 * 1.05;
                                let n = |k: usize| (k as f64 * scale) as usize + 64;
                                e.reserve(n(c.position_m.len()), n(c.effort.len()));
                            }
                            est = Some(e);
                        }
                        let Some(e) = est.as_mut() else {
                            return Ok(());
                        };
                        e.push(&c.position_m, &c.effort)?;
                        if e.gave_up().is_some() {
                            return Ok(());
                        }
                        // The reader may have ended; then the block is simply dropped.
                        let _ = back_tx.send(c);
                    }
                    Ok(())
                })();
                // Hanging up stops the reader at its next block.
                drop(rx);
                let read = reader
                    .join()
                    .unwrap_or_else(|p| std::panic::resume_unwind(p));
                estimated?;
                read
            })?;
            let mut report = match read {
                StreamRead::Done(report) => report,
                StreamRead::Stopped | StreamRead::NotStreamed => ReadReport::default(),
            };
            let Some(e) = est else {
                return Ok((Err("no samples".to_string()), report));
            };
            if let Some(why) = e.gave_up() {
                return Ok((Err(why.to_string()), report));
            }
            if report.layout.is_none() {
                return Ok((Err("both current and torque rows".to_string()), report));
            }
            // What the whole read checks on the kept positions, with none dropped.
            let (lo, hi) = e.position_range_m();
            let bound = feedscope_io::trace::limits::MAX_ABS_POSITION_M;
            let outside_travel = glitch.travel_m.is_some_and(|(a, b)| {
                let m = glitch.travel_margin_m();
                lo < a - m || hi > b + m
            });
            if lo.abs() > bound || hi.abs() > bound || outside_travel {
                return Ok((
                    Err(
                        "a position beyond the travel: a glitch, or a trace the whole read \
                         refuses"
                            .to_string(),
                    ),
                    report,
                ));
            }
            report.max_axis_speed_m_s = Some(glitch.max_axis_speed_m_s);
            Ok((Ok(e.finish()?), report))
        })?;
        pb.finish_and_clear();
        match end {
            Ok(Streamed::Done(outline)) => {
                let out = outcome(written, outline, &report, &source, kind, axis, params);
                return Ok(Ok((out, report)));
            }
            Ok(Streamed::Again(g)) if given.is_none() => given = Some(g),
            Ok(Streamed::Again(_)) => {
                return Ok(Err("a second pass found other statistics again".into()))
            }
            Ok(Streamed::Redo(why)) | Err(why) => return Ok(Err(why)),
        }
    }
    Ok(Err("two passes".into()))
}

/// The stroke table for people.
pub fn print_table(summary: &Summary) -> Result<()> {
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
const PROFILE_WARNINGS: [&str; 5] = [
    "few-samples-per-lead",
    "position-smoothed-below-order",
    "noise-floor-high",
    "feed-change-unresolved",
    "position-not-monotone",
];

/// The strokes' warnings as lines for the terminal: one per stroke and warning, except that a
/// warning about the profile on strokes whose profile is withheld (mean level only), and any
/// warning repeated on more than [`WARNING_REPEATS_SHOWN`] strokes, is one line that counts
/// the strokes, lists them and quotes the first. The JSON summary keeps every one.
fn stroke_warnings(strokes: &[StrokeSummary]) -> Vec<String> {
    let key = |s: &StrokeSummary, code: &'_ str| {
        (
            mean_only(s) && PROFILE_WARNINGS.contains(&code),
            code.to_string(),
        )
    };
    let mut by_code: std::collections::BTreeMap<(bool, String), Vec<&StrokeSummary>> =
        std::collections::BTreeMap::new();
    for s in strokes {
        for w in &s.warnings {
            by_code.entry(key(s, &w.code)).or_default().push(s);
        }
    }
    let mut lines = Vec::new();
    let mut collapsed = Vec::new();
    for s in strokes {
        for w in &s.warnings {
            let k = key(s, &w.code);
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
fn verdict_reasons(
    strokes: &[StrokeSummary],
) -> std::collections::BTreeMap<String, (usize, String)> {
    let mut by_code = std::collections::BTreeMap::new();
    for s in strokes {
        for r in s.verdict.iter().flat_map(|v| &v.reasons) {
            by_code
                .entry(r.code.clone())
                .or_insert((0, format!("stroke {}: {}", s.stroke, r.message)))
                .0 += 1;
        }
    }
    by_code
}

/// `auto`, `off` or a cut-off in Hz.
pub fn parse_cutoff(text: &str) -> Result<PositionSmoothing, String> {
    match text.trim() {
        "auto" => Ok(PositionSmoothing::Auto),
        "off" | "none" => Ok(PositionSmoothing::Off),
        other => match other.parse::<f64>() {
            Ok(f) if f.is_finite() && f > 0.0 && f <= 1e6 => Ok(PositionSmoothing::CutoffHz(f)),
            _ => Err(format!(
                "`{other}` is not `auto`, `off` or a cut-off in Hz (a number above 0)"
            )),
        },
    }
}

fn params_from(args: &Args) -> EstimateParams {
    EstimateParams {
        position_smoothing: args.position_cutoff_hz,
        include_rapids: args.include_rapids,
        effort_sign: args.effort_sign.into(),
        samples_per_lead: args.samples_per_lead,
        end_condition: match args.end_condition {
            EndArg::NotAKnot => EndCondition::NotAKnot,
            EndArg::Natural => EndCondition::Natural,
        },
        time_of_position: match args.time_of_position {
            TimeArg::Invert => TimeOfPosition::Invert,
            TimeArg::KnotSpline => TimeOfPosition::KnotSpline,
        },
        ..EstimateParams::default()
    }
}

pub fn run(args: Args) -> Result<()> {
    // Validate everything cheap before the expensive read.
    let axis = feedscope_io::axis::load(&args.axis)?;
    let mut params = params_from(&args);
    // The program is read (and refused, naming its line) before the expensive trace read; its
    // positions are resolved from where the trace starts.
    let program = match &args.program {
        Some(path) => {
            let opts = feedscope::nc::ParseOptions {
                axis_letter: args.program_axis.to_ascii_uppercase(),
                ..Default::default()
            };
            Some((
                path,
                opts.axis_letter,
                feedscope_io::nc::read_program(path, &opts)?,
            ))
        }
        None => None,
    };
    let summary_path = args
        .summary
        .clone()
        .unwrap_or_else(|| args.output.with_extension("json"));
    let plot_path = (!args.no_plot).then(|| {
        args.plot
            .clone()
            .unwrap_or_else(|| args.output.with_extension("svg"))
    });
    let opts = ReadOptions {
        effort: args.effort.map(|e| match e {
            EffortArg::Current => EffortKind::CurrentA,
            EffortArg::Torque => EffortKind::TorqueNm,
        }),
        threads: 0,
    };
    let glitch = GlitchParams::for_axis(&axis);
    // Without a program, estimate while reading; the whole read when that cannot be vouched
    // for (it then gives the exact result or error).
    let streamed = match (args.read, &program) {
        (ReadArg::Whole, _) => Err("--read whole".to_string()),
        (_, Some(_)) => Err("an NC program labels the strokes".to_string()),
        _ => stream_estimate_to_csv(&args.trace, &opts, &glitch, &axis, &params, &args.output)?,
    };
    let outcome = match streamed {
        Ok((outcome, report)) => {
            crate::output::print_read_warnings(&args.trace.display().to_string(), &report);
            outcome
        }
        Err(why) if args.read == ReadArg::Stream => {
            return Err(crate::cmd::BadInput(format!(
                "{}: cannot estimate while reading ({why}); use --read auto or whole",
                args.trace.display()
            ))
            .into())
        }
        Err(_) => read_whole(&args, &opts, &glitch, &axis, &mut params, program.as_ref())?,
    };
    write_outputs(&args, &axis, &summary_path, plot_path, outcome)
}

/// What `--program` gives: the file, its axis letter and the program.
type Program<'a> = (&'a PathBuf, char, feedscope::nc::NcProgram);

/// Read the whole trace, then estimate it.
fn read_whole(
    args: &Args,
    opts: &ReadOptions,
    glitch: &GlitchParams,
    axis: &AxisParams,
    params: &mut EstimateParams,
    program: Option<&Program<'_>>,
) -> Result<Outcome> {
    let spinner = indicatif::ProgressBar::new_spinner();
    spinner.set_message(format!("reading {}", args.trace.display()));
    spinner.enable_steady_tick(std::time::Duration::from_millis(120));
    let read = read_trace_file_with(&args.trace, opts, glitch);
    spinner.finish_and_clear();
    let (trace, report) = read.map_err(|e| super::effort::name_the_flag(e, opts.effort))?;
    crate::output::print_read_warnings(&args.trace.display().to_string(), &report);
    if let Some((path, letter, prog)) = program {
        let start_mm = trace.position_m.value.first().copied().unwrap_or(0.0) * 1e3;
        params.program = feedscope::estimate::ProgrammedMove::from_steps(&prog.resolve(start_mm));
        if params.program.is_empty() {
            return Err(crate::cmd::BadInput(format!(
                "{}: no block moves axis {letter} (use --program-axis)",
                path.display(),
            ))
            .into());
        }
    }
    let source = args.trace.display().to_string();
    estimate_to_csv(&trace, &report, &source, axis, params, &args.output)
}

/// Put the CSV, the JSON summary and the plot in place and print the report.
fn write_outputs(
    args: &Args,
    axis: &AxisParams,
    summary_path: &Path,
    plot_path: Option<PathBuf>,
    mut outcome: Outcome,
) -> Result<()> {
    let json = serde_json::to_string_pretty(&outcome.summary)?;
    // Everything is rendered before anything is put in place, so an error leaves earlier
    // outputs untouched.
    let svg = match &plot_path {
        Some(_) => {
            let name = axis.name.as_deref().unwrap_or("axis");
            let v = &outcome.summary.verdict;
            outcome.plot.sign_from_direction = v.friction_sign == FrictionSign::FromDirection;
            Some(outcome.plot.svg(
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
    outcome.csv.commit()?;
    crate::output::write_atomic(summary_path, json.as_bytes())?;
    if let (Some(p), Some(svg)) = (&plot_path, svg) {
        crate::output::write_atomic(p, svg.as_bytes())?;
    }
    match args.format {
        Format::Json => {
            let mut out = std::io::stdout().lock();
            writeln!(out, "{json}")?;
        }
        Format::Text => {
            print_table(&outcome.summary)?;
            eprintln!(
                "wrote {} ({} strokes), {}{}",
                args.output.display(),
                outcome.summary.strokes.len(),
                summary_path.display(),
                plot_path
                    .map(|p| format!(", {}", p.display()))
                    .unwrap_or_default()
            );
        }
    }
    Ok(())
}
