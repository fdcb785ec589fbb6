//! A trace as a use case takes it: the samples, the name of where they came from, and what the
//! reader noticed.
use std::borrow::Cow;
use std::path::Path;

use feedscope::axis::AxisParams;
use feedscope::diag::Diagnostic;
use feedscope::trace::{EffortKind, GlitchParams, Trace};
use feedscope::ErrorKind;
use feedscope_io::trace::{read_trace_file_with, ReadOptions, ReadReport, TraceError};
use serde::{Deserialize, Serialize};

use crate::{AppError, FrontEnd};

/// Which effort channel to use when a file has both motor current and torque.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Effort {
    /// Motor current (`current_a`).
    Current,
    /// Motor torque (`torque_nm`).
    Torque,
}

impl Effort {
    /// The value that selects a channel.
    pub fn of(kind: EffortKind) -> Self {
        match kind {
            EffortKind::CurrentA => Effort::Current,
            EffortKind::TorqueNm => Effort::Torque,
        }
    }

    /// The value's name in requests (and the CLI's `--effort`).
    pub fn name(self) -> &'static str {
        match self {
            Effort::Current => "current",
            Effort::Torque => "torque",
        }
    }

    /// The trace channel it selects.
    pub fn kind(self) -> EffortKind {
        match self {
            Effort::Current => EffortKind::CurrentA,
            Effort::Torque => EffortKind::TorqueNm,
        }
    }
}

/// A trace and where it came from.
#[derive(Debug, Clone)]
pub struct Recording<'a> {
    /// The samples (SI units), owned or borrowed from the caller (the Python module's trace
    /// objects are not copied).
    pub trace: Cow<'a, Trace>,
    /// Where they came from (a path as the user gave it, or a name for data held in memory).
    pub source: String,
    /// What the reader noticed (glitches dropped, channels ignored); default for data that
    /// were not read from a file.
    pub read: ReadReport,
}

impl<'a> Recording<'a> {
    /// Samples held in memory, named `source` in messages and reports.
    pub fn in_memory(trace: Trace, source: impl Into<String>) -> Self {
        Self {
            trace: Cow::Owned(trace),
            source: source.into(),
            read: ReadReport::default(),
        }
    }

    /// Samples the caller keeps, named `source`, with what their reader noticed.
    pub fn borrowed(trace: &'a Trace, source: impl Into<String>, read: ReadReport) -> Self {
        Self {
            trace: Cow::Borrowed(trace),
            source: source.into(),
            read,
        }
    }

    /// The reader's warning, prefixed with the source, for a front end's notice.
    pub fn read_warning(&self) -> Option<String> {
        self.read.warning().map(|w| format!("{}: {w}", self.source))
    }

    /// The reader's diagnostics, each message prefixed with the source, for a report.
    pub fn read_diagnostics(&self) -> Vec<Diagnostic> {
        let mut d = self.read.diagnostics();
        for w in &mut d {
            w.message = format!("{}: {}", self.source, w.message);
        }
        d
    }
}

/// Read a trace file (CSV or Parquet), its positions screened for glitches at the axis's speed
/// limit ([`GlitchParams::for_axis`]). `effort` chooses the channel of a file that has both.
/// The reader's warning goes to [`FrontEnd::notice`] at once and stays in the recording.
///
/// # Errors
/// The reader's error, whose message names the file and the line or row; a file with both
/// channels and no `effort`, and an `effort` channel that is absent, name the field `effort`
/// as the front end spells it.
pub fn read_recording(
    path: &Path,
    effort: Option<Effort>,
    axis: &AxisParams,
    front: &dyn FrontEnd,
) -> Result<Recording<'static>, AppError> {
    let source = path.display().to_string();
    front.stage(&format!("reading {source}"));
    let opts = ReadOptions {
        effort: effort.map(Effort::kind),
        threads: 0,
    };
    match read_trace_file_with(path, &opts, &GlitchParams::for_axis(axis)) {
        Ok((trace, read)) => {
            let recording = Recording {
                trace: Cow::Owned(trace),
                source,
                read,
            };
            if let Some(w) = recording.read_warning() {
                front.notice(&w);
            }
            Ok(recording)
        }
        Err(e) => Err(effort_error(e, effort, front)),
    }
}

/// A trace reader's error, restated in the words of the `effort` field that chooses the
/// channel: a file with both channels asks for a choice, as the front end spells it; a channel
/// asked for and absent names the field as given. Other errors pass unchanged
/// ([`AppError::from_error`]).
pub fn effort_error(e: TraceError, asked: Option<Effort>, front: &dyn FrontEnd) -> AppError {
    match e {
        TraceError::AmbiguousEffort { source_name } => AppError::bad_input(format!(
            "{source_name}: both `current_a` and `torque_nm` are present; choose one with {} \
             or {}",
            front.spell("effort", "current"),
            front.spell("effort", "torque")
        ))
        .for_field("effort"),
        TraceError::MissingChannel { ref channel, .. }
            if asked.is_some_and(|k| channel == k.kind().column()) =>
        {
            let value = asked.map_or("", Effort::name);
            AppError::caused(ErrorKind::BadInput, front.spell("effort", value), e)
                .for_field("effort")
        }
        e => AppError::from_error(e),
    }
}
