//! Friction along the travel from one trace (paper 000, Section 3, Eq. 5): the steady strokes
//! found, position and effort interpolated with cubic splines, resampled every lead/m of
//! travel, and Eq. 5 solved for the friction force at each point.
//!
//! [`EstimateRequest`] names the trace, axis and output files and runs the streaming engine
//! (strokes estimated while the file is read, in memory for the longest stroke, whenever the
//! result is provably the whole-trace one); [`estimate_recording`] estimates a trace held in
//! memory and keeps every stroke's arrays (the Python module's path). Both report an
//! [`EstimateReport`], the JSON summary written beside the friction CSV; its plain-text view
//! (`Display` and [`EstimateReport::remarks`]) is in the child module `text`.
use std::path::{Path, PathBuf};

use feedscope::axis::AxisParams;
use feedscope::diag::Diagnostic;
use feedscope::estimate::stream::{StreamEstimator, Streamed};
use feedscope::estimate::{
    estimate_pieces_streaming, estimate_streaming, Direction, EffortSign, EstimateError,
    EstimateParams, Move, Outline, PositionSmoothing, ProgrammedMove, StrokeFriction, StrokePiece,
    StrokeSummary, TimeOfPosition, Zone,
};
use feedscope::nc::NcProgram;
use feedscope::spline::EndCondition;
use feedscope::trace::{EffortKind, GlitchParams, Trace};
use feedscope::units::feed_m_s_to_mm_min;
use feedscope::verdict::DataVerdict;
use feedscope_io::friction_csv;
use feedscope_io::trace::{
    stream_trace_file, DroppedSample, ReadOptions, ReadReport, StreamRead, TraceChunk, TraceError,
};
use serde::{Deserialize, Serialize};

use crate::output::{io_error, AtomicFile};
use crate::recording::{read_recording, Effort};
use crate::{AppError, FrontEnd, Recording};

mod text;
pub use text::{
    number_list, stroke_warnings, verdict_reasons, PROFILE_WARNINGS, WARNING_REPEATS_SHOWN,
};

impl From<EstimateError> for AppError {
    fn from(e: EstimateError) -> Self {
        AppError::from_error(e)
    }
}

impl From<TraceError> for AppError {
    fn from(e: TraceError) -> Self {
        AppError::from_error(e)
    }
}

/// Estimate a trace file into a friction CSV.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EstimateRequest {
    /// Trace file: CSV (long `time_s,channel,value` or wide `time_s,position_mm,current_a`
    /// layout) or Parquet with the same columns.
    pub input: PathBuf,
    /// Axis parameters (TOML or JSON).
    pub axis: PathBuf,
    /// Friction CSV to write
    /// (`stroke,direction,position_mm,time_s,velocity_mm_s,accel_mm_s2,current_a|torque_nm,friction_n`).
    pub output: PathBuf,
    /// Settings of the estimation.
    #[serde(flatten)]
    pub options: EstimateOptions,
}

/// How a trace file is read.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ReadMode {
    /// Estimate while reading when the result is provably the whole-trace one, else read the
    /// whole trace first.
    #[default]
    Auto,
    /// Estimate while reading, or fail saying why that cannot be vouched for (an NC program,
    /// Parquet, glitches, rapids without a rapid rate ...).
    Stream,
    /// Read the whole trace first.
    Whole,
}

impl ReadMode {
    /// The value's name in requests (and the CLI's `--read`).
    pub fn name(self) -> &'static str {
        match self {
            ReadMode::Auto => "auto",
            ReadMode::Stream => "stream",
            ReadMode::Whole => "whole",
        }
    }
}

/// Settings of the estimation, as a user gives them; [`EstimateOptions::params`] checks them
/// and gives the library's [`EstimateParams`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EstimateOptions {
    /// Resampling points per screw lead (m in paper 000; the position step is lead/m), 1 to
    /// 1,000,000.
    pub samples_per_lead: u32,
    /// Spline end condition.
    pub end_condition: EndCondition,
    /// How the run time t(z) at each resampled position is found.
    pub time_of_position: TimeOfPosition,
    /// Position smoothing before differentiation: `"auto"` (a cut-off per stroke from its
    /// sampling rate, position quantum, effort noise and settling time), `"off"` (interpolate,
    /// as paper 000) or a fixed cut-off in Hz.
    #[serde(with = "cutoff_serde")]
    pub position_cutoff_hz: PositionSmoothing,
    /// Also estimate rapids and jogs (marked with their kind).
    pub include_rapids: bool,
    /// Whether the effort carries its sign.
    pub effort_sign: EffortSign,
    /// Which effort channel to use when the file has both current and torque.
    pub effort: Option<Effort>,
    /// The NC program that made the trace: labels each stroke with its block and programmed
    /// feed, G0 blocks as rapids, unprogrammed motion as jogs.
    pub program: Option<PathBuf>,
    /// Axis address of this axis in the program (a letter).
    pub program_axis: char,
    /// How the trace file is read (a trace in memory is estimated whole).
    pub read: ReadMode,
}

impl Default for EstimateOptions {
    fn default() -> Self {
        let p = EstimateParams::default();
        Self {
            samples_per_lead: p.samples_per_lead,
            end_condition: p.end_condition,
            time_of_position: p.time_of_position,
            position_cutoff_hz: p.position_smoothing,
            include_rapids: p.include_rapids,
            effort_sign: p.effort_sign,
            effort: None,
            program: None,
            program_axis: 'Z',
            read: ReadMode::Auto,
        }
    }
}

/// `"auto"`, `"off"` (or `"none"`) or a cut-off in Hz, as a user writes it: the field
/// `position_cutoff_hz` of a request, the CLI's `--position-cutoff-hz`.
///
/// # Errors
/// Anything else, or a cut-off that is not a finite number above 0 (at most 1 MHz).
pub fn parse_cutoff(text: &str) -> Result<PositionSmoothing, String> {
    match text.trim() {
        "auto" => Ok(PositionSmoothing::Auto),
        "off" | "none" => Ok(PositionSmoothing::Off),
        other => match other.parse::<f64>() {
            Ok(f) if cutoff_ok(f) => Ok(PositionSmoothing::CutoffHz(f)),
            _ => Err(cutoff_refused(other)),
        },
    }
}

fn cutoff_ok(f: f64) -> bool {
    f.is_finite() && f > 0.0 && f <= 1e6
}

fn cutoff_refused(text: &str) -> String {
    format!("`{text}` is not `auto`, `off` or a cut-off in Hz (a number above 0)")
}

/// `position_cutoff_hz` in a request: `"auto"`, `"off"` or a number (Hz).
mod cutoff_serde {
    use feedscope::estimate::PositionSmoothing;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    #[derive(Serialize, Deserialize)]
    #[serde(untagged)]
    enum Form {
        Hz(f64),
        Word(String),
    }

    pub fn serialize<S: Serializer>(p: &PositionSmoothing, s: S) -> Result<S::Ok, S::Error> {
        match p {
            PositionSmoothing::Auto => Form::Word("auto".into()),
            PositionSmoothing::Off => Form::Word("off".into()),
            PositionSmoothing::CutoffHz(f) => Form::Hz(*f),
        }
        .serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<PositionSmoothing, D::Error> {
        match Form::deserialize(d)? {
            // Checked by `EstimateOptions::params`, which names the field.
            Form::Hz(f) => Ok(PositionSmoothing::CutoffHz(f)),
            Form::Word(w) => super::parse_cutoff(&w).map_err(serde::de::Error::custom),
        }
    }
}

/// An NC program read for an estimation, with the axis letter whose moves it labels.
#[derive(Debug, Clone)]
pub struct Program {
    /// The program file.
    pub path: PathBuf,
    /// The axis address (upper case).
    pub axis_letter: char,
    /// The parsed program.
    pub program: NcProgram,
}

impl EstimateOptions {
    /// Check the settings and give the estimation's parameters (without the program, which
    /// needs the trace: [`Program::label`]).
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field in the front end's spelling: samples per lead
    /// out of range, a cut-off that is not a positive number of Hz, an axis address that is
    /// not a letter.
    pub fn params(&self, front: &dyn FrontEnd) -> Result<EstimateParams, AppError> {
        if !(1..=1_000_000).contains(&self.samples_per_lead) {
            return Err(AppError::invalid(
                "samples_per_lead",
                format!(
                    "{} = {} is not in 1..=1000000",
                    front.name("samples_per_lead"),
                    self.samples_per_lead
                ),
            ));
        }
        if let PositionSmoothing::CutoffHz(f) = self.position_cutoff_hz {
            if !cutoff_ok(f) {
                return Err(AppError::invalid(
                    "position_cutoff_hz",
                    format!(
                        "{}: {}",
                        front.name("position_cutoff_hz"),
                        cutoff_refused(&f.to_string())
                    ),
                ));
            }
        }
        if !self.program_axis.is_ascii_alphabetic() {
            return Err(AppError::invalid(
                "program_axis",
                format!(
                    "{}: `{}` is not an axis address (a letter such as Z)",
                    front.name("program_axis"),
                    self.program_axis
                ),
            ));
        }
        Ok(EstimateParams {
            position_smoothing: self.position_cutoff_hz,
            include_rapids: self.include_rapids,
            effort_sign: self.effort_sign,
            samples_per_lead: self.samples_per_lead,
            end_condition: self.end_condition,
            time_of_position: self.time_of_position,
            ..EstimateParams::default()
        })
    }

    /// Read the program, when one is given (before the expensive trace read, so that a bad
    /// block is refused first, naming its line).
    ///
    /// # Errors
    /// The program reader's error, naming the file and line.
    pub fn read_program(&self) -> Result<Option<Program>, AppError> {
        let Some(path) = &self.program else {
            return Ok(None);
        };
        let opts = feedscope::nc::ParseOptions {
            axis_letter: self.program_axis.to_ascii_uppercase(),
            ..Default::default()
        };
        let program = feedscope_io::nc::read_program(path, &opts)
            .map_err(|e| AppError::from_error(e).for_field("program"))?;
        Ok(Some(Program {
            path: path.clone(),
            axis_letter: opts.axis_letter,
            program,
        }))
    }
}

impl Program {
    /// Label the strokes of `trace` with the program's blocks: its positions are resolved from
    /// where the trace starts.
    ///
    /// # Errors
    /// [`AppError::invalid`] (`program_axis`) when no block moves the axis.
    pub fn label(
        &self,
        params: &mut EstimateParams,
        trace: &Trace,
        front: &dyn FrontEnd,
    ) -> Result<(), AppError> {
        let start_mm = trace.position_m.value.first().copied().unwrap_or(0.0) * 1e3;
        params.program = ProgrammedMove::from_steps(&self.program.resolve(start_mm));
        if params.program.is_empty() {
            return Err(AppError::invalid(
                "program_axis",
                format!(
                    "{}: no block moves axis {} (use {})",
                    self.path.display(),
                    self.axis_letter,
                    front.name("program_axis")
                ),
            ));
        }
        Ok(())
    }
}

/// The JSON summary of an estimation (`OUT.json` beside the friction CSV).
#[derive(Debug, Clone, Serialize)]
pub struct EstimateReport {
    /// The trace's file, or the name of data held in memory.
    pub source: String,
    pub effort: EffortKind,
    /// What the recording supports (see `feedscope::verdict`).
    pub verdict: DataVerdict,
    pub axis: AxisParams,
    pub params: EstimateParams,
    pub strokes: Vec<StrokeSummary>,
    pub moves: Vec<Move>,
    pub notes: Vec<Diagnostic>,
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

impl EstimateReport {
    fn new(
        outline: Outline,
        strokes: Vec<StrokeSummary>,
        read: &ReadReport,
        source: &str,
        effort: EffortKind,
        axis: &AxisParams,
        params: &EstimateParams,
    ) -> Self {
        Self {
            source: source.to_string(),
            effort,
            verdict: outline.verdict,
            axis: axis.clone(),
            params: params.clone(),
            strokes,
            moves: outline.moves,
            notes: outline.notes,
            zones: outline.zones,
            skipped: outline.skipped,
            ignored_rows: read.ignored_rows,
            ignored_channels: read.ignored_channels.clone(),
            dropped_position_samples: read.dropped_position.iter().map(Into::into).collect(),
            max_axis_speed_mm_min: read.max_axis_speed_m_s.map(feed_m_s_to_mm_min),
            unterminated_last_line: read.unterminated_last_line,
        }
    }
}

/// A dropped position sample as the summary reports it (user units).
#[derive(Debug, Clone, Serialize)]
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

/// The strokes of a trace held in memory, with their arrays.
#[derive(Debug)]
pub struct Strokes {
    /// The summary, as [`EstimateRequest::run`] reports it.
    pub report: EstimateReport,
    /// Every stroke's resampled arrays, in time order (their summaries are the report's).
    pub strokes: Vec<StrokeFriction>,
}

/// Estimate a trace held in memory, keeping every stroke's arrays; an NC program in `options`
/// labels the strokes.
///
/// # Errors
/// As [`EstimateOptions::params`], [`EstimateOptions::read_program`] and [`Program::label`];
/// the estimation's own errors (no stroke, an effort without information).
pub fn estimate_recording(
    recording: &Recording<'_>,
    axis: &AxisParams,
    options: &EstimateOptions,
    front: &dyn FrontEnd,
) -> Result<Strokes, AppError> {
    let mut params = options.params(front)?;
    let trace: &Trace = &recording.trace;
    if let Some(program) = options.read_program()? {
        program.label(&mut params, trace, front)?;
    }
    let mut strokes = Vec::new();
    let total = trace.position_m.len();
    let mut done = 0;
    // In batches of twice the worker threads: the strokes' work arrays are reused from batch
    // to batch instead of all being live at once.
    let outline = estimate_streaming(trace, axis, &params, batch(), |s: StrokeFriction| {
        done += s.summary.position_samples;
        front.progress("estimate", done.min(total), total);
        strokes.push(s);
        Ok::<(), AppError>(())
    })?;
    front.progress("estimate", total, total);
    let summaries = strokes.iter().map(|s| s.summary.clone()).collect();
    let report = EstimateReport::new(
        outline,
        summaries,
        &recording.read,
        &recording.source,
        trace.effort_kind,
        axis,
        &params,
    );
    Ok(Strokes { report, strokes })
}

/// Strokes handed to the estimation at once: twice the worker threads.
fn batch() -> usize {
    2 * rayon::current_num_threads()
}

/// What an estimation to a file produced. The CSV is written but not yet in place
/// ([`AtomicFile::commit`]), so that a front end puts it in place with the rest of its
/// outputs, or not at all.
pub struct Estimated {
    /// The JSON summary.
    pub report: EstimateReport,
    /// Friction against position of every stroke, decimated for a plot.
    pub plot: FrictionPlot,
    /// The friction CSV, not yet committed.
    pub csv: AtomicFile,
}

impl EstimateRequest {
    /// Check the request without reading anything.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field: an empty path, a setting out of range.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        for (field, p) in [
            ("input", &self.input),
            ("axis", &self.axis),
            ("output", &self.output),
        ] {
            if p.as_os_str().is_empty() {
                return Err(AppError::invalid(
                    field,
                    format!("{} names no file", front.name(field)),
                ));
            }
        }
        self.options.params(front).map(|_| ())
    }

    /// Read the axis (and the program), then estimate the trace into the friction CSV: while
    /// reading when the result is provably the whole-trace one (see
    /// `feedscope::estimate::stream`), else from the whole trace. The reader's warnings go to
    /// [`FrontEnd::notice`].
    ///
    /// # Errors
    /// As [`EstimateRequest::validate`]; the readers' errors naming the file and line; with
    /// [`ReadMode::Stream`], a trace that cannot be estimated while reading (the reason
    /// said); the estimation's own errors; writing the CSV.
    pub fn run(&self, front: &dyn FrontEnd) -> Result<Estimated, AppError> {
        self.validate(front)?;
        let axis = feedscope_io::axis::load(&self.axis).map_err(AppError::from_error)?;
        let mut params = self.options.params(front)?;
        let program = self.options.read_program()?;
        let opts = ReadOptions {
            effort: self.options.effort.map(Effort::kind),
            threads: 0,
        };
        let glitch = GlitchParams::for_axis(&axis);
        let streamed = match (self.options.read, &program) {
            (ReadMode::Whole, _) => Err("the whole read was asked for".to_string()),
            (_, Some(_)) => Err("an NC program labels the strokes".to_string()),
            _ => stream_estimate_to_csv(
                &self.input,
                &opts,
                &glitch,
                &axis,
                &params,
                &self.output,
                front,
            )?,
        };
        match streamed {
            Ok((estimated, read)) => {
                if let Some(w) = read.warning() {
                    front.notice(&format!("{}: {w}", self.input.display()));
                }
                Ok(estimated)
            }
            Err(why) if self.options.read == ReadMode::Stream => Err(AppError::invalid(
                "read",
                format!(
                    "{}: cannot estimate while reading ({why}); use {} or whole",
                    self.input.display(),
                    front.spell("read", "auto"),
                ),
            )),
            Err(_) => {
                let recording = read_recording(&self.input, self.options.effort, &axis, front)?;
                if let Some(p) = &program {
                    p.label(&mut params, &recording.trace, front)?;
                }
                estimate_to_csv(&recording, &axis, &params, &self.output, front)
            }
        }
    }
}

/// Estimate a trace held in memory and stream the friction CSV into `csv_path` (atomically,
/// not yet committed); `params` as checked by [`EstimateOptions::params`].
///
/// # Errors
/// The estimation's own errors; creating or writing the CSV.
pub fn estimate_to_csv(
    recording: &Recording<'_>,
    axis: &AxisParams,
    params: &EstimateParams,
    csv_path: &Path,
    front: &dyn FrontEnd,
) -> Result<Estimated, AppError> {
    let trace: &Trace = &recording.trace;
    let total = trace.position_m.len();
    let mut done = 0;
    let mut count = |n: usize| {
        done += n;
        front.progress("estimate", done.min(total), total);
    };
    let (written, outline) =
        write_friction_csv(csv_path, trace.effort_kind, &mut count, |map, sink| {
            estimate_pieces_streaming(trace, axis, params, batch(), map, sink)
        })?;
    front.progress("estimate", total, total);
    Ok(written.finish(
        outline,
        &recording.read,
        &recording.source,
        trace.effort_kind,
        axis,
        params,
    ))
}

/// Friction against position of every stroke, decimated for a plot: per direction, the
/// strokes' (position mm, friction N) points, their numbers and whether each is drawn as its
/// mean level only. Memory stays bounded however many strokes come: a direction's points are
/// thinned when they pass [`FrictionPlot::POINTS_PER_DIRECTION`].
#[derive(Debug, Default)]
pub struct FrictionPlot {
    /// Forward strokes' points ((mm, N) pairs).
    pub forward: Vec<Vec<(f64, f64)>>,
    /// Backward strokes' points.
    pub backward: Vec<Vec<(f64, f64)>>,
    /// Stroke numbers of `forward` and `backward`, as the summary numbers them.
    pub numbers: [Vec<usize>; 2],
    /// Whether each stroke is drawn as its mean level only (its data support no profile): a
    /// flat segment from its start to its end.
    pub mean_only: [Vec<bool>; 2],
    /// The friction's sign comes from the direction of motion (the effort is a magnitude).
    pub sign_from_direction: bool,
    /// Every how many of a new stroke's points is kept, per direction (0 or 1: every one):
    /// doubled whenever a direction's points pass [`Self::POINTS_PER_DIRECTION`].
    thin: [usize; 2],
}

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

impl FrictionPlot {
    /// Points of one stroke at most (a longer one is decimated).
    pub const POINTS_PER_STROKE: usize = 4000;
    /// Points of all strokes of one direction at most.
    pub const POINTS_PER_DIRECTION: usize = 100_000;

    /// The points of one piece of a stroke's rows, decimated by the whole stroke's length; a
    /// stroke whose data support no profile gives none (it is drawn at its mean level).
    fn points(s: &StrokeFriction) -> Vec<(f64, f64)> {
        if friction_csv::is_mean_level(&s.summary) {
            return Vec::new();
        }
        let stride = s.summary.points.div_ceil(Self::POINTS_PER_STROKE).max(1);
        s.position_m
            .iter()
            .zip(&s.friction_n)
            .step_by(stride)
            .map(|(z, f)| (z * 1e3, *f))
            .collect()
    }

    fn add(&mut self, s: &StrokeSummary, mut points: Vec<(f64, f64)>) {
        let flat = friction_csv::is_mean_level(s);
        if flat {
            let m = s.mean_friction_n;
            points = vec![(s.start_mm, m), (s.end_mm, m)];
        }
        let k = usize::from(s.direction == Direction::Backward);
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
        while dst.iter().map(Vec::len).sum::<usize>() > Self::POINTS_PER_DIRECTION
            && dst.iter().any(|p| p.len() > 2)
        {
            *thin = (*thin).max(1) * 2;
            for p in dst.iter_mut() {
                *p = every_nth(std::mem::take(p), 2);
            }
        }
    }
}

/// A piece of a stroke formatted as CSV rows, in chunks.
type CsvRows = Vec<Vec<u8>>;
/// (position mm, friction N) points of a piece, decimated for the plot.
type PlotPoints = Vec<(f64, f64)>;
/// Strokes formatted for the CSV and decimated for the plot, inside the parallel section.
type Formatted = (CsvRows, PlotPoints);
/// What an estimation hands each stroke (or piece of one) to.
type PieceSink<'a> = dyn FnMut(StrokePiece<Formatted>) -> Result<(), AppError> + 'a;
/// What formats a stroke inside the parallel section.
type Format<'a> = dyn Fn(StrokeFriction) -> Formatted + Sync + 'a;

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
        use std::io::{Seek, SeekFrom, Write};
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
    plot: FrictionPlot,
}

impl Written {
    fn finish(
        self,
        outline: Outline,
        read: &ReadReport,
        source: &str,
        effort: EffortKind,
        axis: &AxisParams,
        params: &EstimateParams,
    ) -> Estimated {
        let report =
            EstimateReport::new(outline, self.summaries, read, source, effort, axis, params);
        let mut plot = self.plot;
        plot.sign_from_direction =
            report.verdict.friction_sign == feedscope::verdict::FrictionSign::FromDirection;
        Estimated {
            report,
            plot,
            csv: self.csv,
        }
    }
}

/// Run `estimate` with a sink that streams the friction CSV (header for `effort_kind`) into
/// `csv_path` (atomically, not yet committed) on a writer thread, and gathers the summaries
/// and plot points; `count` is told each stroke's position samples.
fn write_friction_csv<R>(
    csv_path: &Path,
    effort_kind: EffortKind,
    count: &mut dyn FnMut(usize),
    estimate: impl FnOnce(&Format<'_>, &mut PieceSink<'_>) -> Result<R, AppError>,
) -> Result<(Written, R), AppError> {
    let writing = |e| io_error(format!("writing {}", csv_path.display()), e);
    let mut out = AtomicFile::create(csv_path)?;
    friction_csv::write_header(out.writer(), effort_kind).map_err(writing)?;
    let mut summaries = Vec::new();
    let mut plot = FrictionPlot::default();
    // A writer thread takes formatted strokes, so the copy into the file overlaps with the
    // estimation of the next batch; the bounded channel caps the memory in flight.
    let (tx, rx) = std::sync::mpsc::sync_channel::<ToCsv>(batch());
    let (estimated, out) = std::thread::scope(|scope| {
        let writer = scope.spawn(move || -> Result<AtomicFile, AppError> {
            let mut w = CsvWriter::default();
            for msg in rx {
                w.take(&mut out, msg).map_err(writing)?;
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
            let rows = if friction_csv::is_mean_level(&s.summary) {
                Vec::new()
            } else {
                friction_csv::format_stroke(&s)
            };
            (rows, FrictionPlot::points(&s))
        };
        let mut sink = |piece: StrokePiece<Formatted>| -> Result<(), AppError> {
            // A send fails only when the writer stopped on an error; join() reports it.
            let send = |m: ToCsv| {
                tx.send(m)
                    .map_err(|_| AppError::failed("the CSV writer stopped"))
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
                    count(summary.position_samples);
                    let rows = held.take().unwrap_or_default();
                    if friction_csv::is_mean_level(&summary) {
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

/// What a streamed estimation gives: the result and the read's report, or why the whole
/// trace must be read instead.
type StreamOutcome = Result<(Estimated, ReadReport), String>;

/// Estimate while reading (see `feedscope::estimate::stream`): strokes are estimated and
/// written as the file is read, in memory that holds the stroke being read, not the file.
/// `Err(why)` when the result could not be vouched for and the whole trace must be read
/// (Parquet, an NC program, glitches, rapids without a rapid rate, anything the whole read
/// refuses: it then gives the exact result or error); a second pass when the first ends with
/// other segmentation statistics than its prefix gave. Progress counts the file's bytes.
fn stream_estimate_to_csv(
    path: &Path,
    opts: &ReadOptions,
    glitch: &GlitchParams,
    axis: &AxisParams,
    params: &EstimateParams,
    csv_path: &Path,
    front: &dyn FrontEnd,
) -> Result<StreamOutcome, AppError> {
    if !params.program.is_empty() {
        return Ok(Err("an NC program labels the strokes".into()));
    }
    let Some(kind) = streamed_effort_kind(path, opts) else {
        return Ok(Err(
            "the file is Parquet, or its first effort rows do not tell the channel".into(),
        ));
    };
    let source = path.display().to_string();
    let size = std::fs::metadata(path).map_or(0, |m| m.len()) as usize;
    let mut given = None;
    for _pass in 0..2 {
        // The estimation's own counting is by samples; the progress counts the file's bytes.
        let (written, (end, report)) =
            write_friction_csv(csv_path, kind, &mut |_| {}, |map, sink| {
                let mut sink = Some(sink);
                let mut est: Option<StreamEstimator<'_, Formatted, AppError>> = None;
                // The file is read and parsed on a thread of its own, so that parsing the next
                // blocks overlaps with estimating the strokes of the last ones; two blocks in
                // flight bound the memory this adds.
                let (tx, rx) = std::sync::mpsc::sync_channel::<Block>(2);
                let (back_tx, back_rx) = std::sync::mpsc::channel::<Block>();
                let read = std::thread::scope(|scope| -> Result<StreamRead, AppError> {
                    let reader = scope.spawn(move || -> Result<StreamRead, AppError> {
                        let mut on_chunk = |c: TraceChunk<'_>| -> Result<bool, AppError> {
                            front.progress("estimate", (c.bytes_read as usize).min(size), size);
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
                            block.both_efforts = opts.effort.is_none()
                                && c.wide_effort.is_none()
                                && !other.is_empty();
                            block.bytes_read = c.bytes_read;
                            block.file_bytes = c.file_bytes;
                            // The estimator hung up: it gave up, or failed.
                            Ok(tx.send(block).is_ok())
                        };
                        stream_trace_file(path, opts, &mut on_chunk)
                    });
                    let estimated = (|| -> Result<(), AppError> {
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
                                    axis,
                                    params,
                                    kind,
                                    c.facts,
                                    *glitch,
                                    batch(),
                                    map,
                                    sink,
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
        front.progress("estimate", size, size);
        match end {
            Ok(Streamed::Done(outline)) => {
                let out = written.finish(outline, &report, &source, kind, axis, params);
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
