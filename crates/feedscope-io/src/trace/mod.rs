//! Trace files: CSV and Parquet, read into a [`Trace`] (SI units) and written from one.
//!
//! Files use the units named in their column headers; the [`Trace`] read holds seconds, metres,
//! amperes and newton-metres, as everywhere in `feedscope`.
//!
//! # Example
//! ```
//! use feedscope::trace::EffortKind;
//! use feedscope_io::trace::{parse_trace, write_csv, Layout, ReadOptions};
//!
//! let csv = "time_s,position_mm,current_a\n0,0,1.0\n0.01,0.1,1.1\n0.02,0.2,1.2\n0.03,0.3,1.3\n";
//! let (trace, report) = parse_trace(csv.as_bytes(), "t.csv", &ReadOptions::default())?;
//! assert_eq!(trace.effort_kind, EffortKind::CurrentA);
//! assert!((trace.position_m.value[3] - 0.3e-3).abs() < 1e-18); // 0.3 mm in m
//! assert_eq!(report.layout, Some(Layout::Wide));
//! let mut back = Vec::new();
//! write_csv(&trace, &mut back, Layout::Wide)?;
//! assert!(back.starts_with(b"time_s,position_mm,current_a\n0.000000,0.000000,1.000000\n"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # File layouts (CSV)
//! - **long** (asynchronous channels): header `time_s,channel,value`, one sample per row; the
//!   channel names carry units: `position_mm` or `position_m`, and `current_a` or `torque_nm`.
//!   Other channel names are ignored (and counted in [`ReadReport::ignored_rows`]).
//! - **wide** (synchronous channels): header `time_s,position_mm,current_a` (or `torque_nm`,
//!   `position_m`) in any column order, extra columns ignored; an empty cell means "no sample of
//!   this channel at this time", so a wide file can also carry asynchronous channels.
//!
//! Either layout may use `time_ms` instead of `time_s`. Lines starting with `#` and blank lines
//! are skipped, a UTF-8 byte-order mark is accepted, and lines may end in LF, CRLF or a bare CR.
//!
//! # Parquet
//! The same columns in the same two layouts. A file is Parquet when it starts with the magic
//! bytes `PAR1` (whatever its name; a `*.parquet` name without them is an error).
//! - **wide**: `time_s` or `time_ms`, `position_mm` or `position_m`, `current_a` and/or
//!   `torque_nm`; a null cell means "no sample of this channel at this time".
//! - **long**: `time_s` or `time_ms`, `channel` (Utf8, LargeUtf8, or a dictionary of them),
//!   `value`; channel names as above.
//!
//! Numeric columns may be Float64, Float32, Int32 or Int64; any other type is an error naming
//! the column. Extra columns are ignored and not decoded. Errors about a value name its 1-based
//! data row ([`TraceError::NonFiniteInRow`], [`TraceError::TimeNotIncreasingInRow`],
//! [`TraceError::BadCell`]). [`write_parquet`] writes either layout, in SI units at full
//! precision, so a round trip gives back the same trace bit for bit.
//!
//! # Names
//! Channel names of the long layout, header column names and Parquet column names are at most
//! [`MAX_NAME_BYTES`] (64) bytes and hold no control character; anything else is a format
//! error naming the line ([`TraceError::BadChannelName`], [`TraceError::BadHeader`]), the
//! column ([`TraceError::BadColumn`]) or the row ([`TraceError::BadCell`]). Known names cost
//! nothing to check; an unknown one is checked when met.
//!
//! # Position glitches
//! Every reader ends by screening the position for samples that imply a speed the axis cannot
//! reach ([`feedscope::trace::glitch`]): above [`GlitchParams::max_axis_speed_m_s`], 200 m/min
//! by default, or 1.25 × the axis' `rapid_rate_mm_min` with [`GlitchParams::for_axis`] (pass it
//! to [`read_trace_file_with`] / [`parse_trace_with`]). Allowing either time stamp to be off by
//! one typical sampling interval and 10 µm of quantisation, a sample must jump by more than
//! about v_lim × 3 sampling intervals to count.
//! - A run of 1-3 samples that jumps away and back (a logger glitch such as `1e308`) is
//!   dropped and listed in [`ReadReport::dropped_position`] with its time, value and line (CSV)
//!   or row (Parquet); [`ReadReport::glitch_warning`] says so in one sentence. So is such a
//!   run at either end of the trace.
//! - A jump that does not come back (re-homing, recordings joined) is refused:
//!   [`TraceError::PositionJump`] names the line or row, the jump (mm) and its speed (mm/min).
//!
//! - With the axis' travel declared (`travel_min_mm`, `travel_max_mm`, through
//!   [`GlitchParams::for_axis`]), a kept position farther outside it than 1 mm + 1 % of the
//!   travel is refused: [`TraceError::OutsideTravel`] names the line or row and the value.
//!
//! The effort channel is not screened: current and torque jump legitimately (acceleration,
//! reversal, saturation) and the axis description gives no bound for them.

use std::fs::File;
use std::path::Path;

use feedscope::trace::{GlitchParams, Trace};

mod csv;
mod format;
pub mod limits;
mod parquet;
mod parquet_pages;
mod read;

pub use csv::{write_csv, TraceChunk};
pub use format::Layout;
pub use parquet::{decoding_untrusted_parquet, write_parquet};
pub use read::{
    DroppedSample, ReadOptions, ReadReport, TraceError, MAX_LINE_BYTES, MAX_NAME_BYTES,
};

use format::Format;

/// Read a trace file: CSV or Parquet (told by the magic bytes `PAR1`), either layout, with
/// the position screened for glitches at the default limit ([`GlitchParams::default`], 200
/// m/min). [`read_trace_file_with`] takes the axis' own limit.
///
/// # Errors
/// Any [`TraceError`]: unreadable file, bad header or Parquet columns, malformed or non-finite
/// numbers, a bad channel name, time not increasing within a channel, a missing channel, too
/// few samples, no motion, or a position jump that does not come back.
pub fn read_trace_file(path: &Path, opts: &ReadOptions) -> Result<(Trace, ReadReport), TraceError> {
    read_trace_file_with(path, opts, &GlitchParams::default())
}

/// [`read_trace_file`] with the position screened for glitches at `glitch`'s speed limit (see
/// [`feedscope::trace::glitch`]): isolated jumps that come back are dropped and listed in
/// [`ReadReport::dropped_position`] with their lines (CSV) or rows (Parquet); a jump that does
/// not come back is [`TraceError::PositionJump`].
///
/// # Errors
/// As [`read_trace_file`].
///
/// # Panics
/// When `glitch.max_axis_speed_m_s` is NaN, zero or negative.
pub fn read_trace_file_with(
    path: &Path,
    opts: &ReadOptions,
    glitch: &GlitchParams,
) -> Result<(Trace, ReadReport), TraceError> {
    let name = path.display().to_string();
    let io = |error| TraceError::Io {
        source_name: name.clone(),
        error,
    };
    let mut file = File::open(path).map_err(io)?;
    match Format::of_file(&mut file).map_err(io)? {
        Format::Parquet => parquet::read_file(file, path, &name, opts, glitch),
        Format::Csv if format::named_parquet(path) => Err(TraceError::Parquet {
            source_name: name,
            reason: "the name ends in .parquet but the file does not start with the Parquet \
                     magic bytes `PAR1`"
                .into(),
        }),
        Format::Csv => csv::read_file(file, path, &name, opts, glitch, csv::BLOCK_BYTES),
    }
}

/// How [`stream_trace_file`] ended.
#[derive(Debug)]
pub enum StreamRead {
    /// The whole file was handed out; what [`read_trace_file`] reports besides the samples
    /// (nothing dropped: the caller screens what it streams).
    Done(ReadReport),
    /// The callback asked to stop.
    Stopped,
    /// The file is Parquet, whose row groups are decoded in parallel by [`read_trace_file`]:
    /// read it whole.
    NotStreamed,
}

/// Read a CSV trace block by block and hand each block's samples to `on_chunk` as soon as
/// they are parsed (`on_chunk` returns `false` to stop). Format errors are those of
/// [`read_trace_file`], at the same lines; the checks [`read_trace_file`] makes on the whole
/// trace afterwards (enough samples, motion, glitches, the travel) are the caller's.
///
/// # Errors
/// A [`TraceError`] of the file's format, or what `on_chunk` returns.
pub fn stream_trace_file<E: From<TraceError>>(
    path: &Path,
    opts: &ReadOptions,
    on_chunk: &mut dyn FnMut(TraceChunk<'_>) -> Result<bool, E>,
) -> Result<StreamRead, E> {
    let name = path.display().to_string();
    let io = |error| TraceError::Io {
        source_name: name.clone(),
        error,
    };
    let mut file = File::open(path).map_err(io)?;
    match Format::of_file(&mut file).map_err(io)? {
        Format::Csv if !format::named_parquet(path) => Ok(
            match csv::stream_file(file, &name, opts, csv::BLOCK_BYTES, on_chunk)? {
                Some(report) => StreamRead::Done(report),
                None => StreamRead::Stopped,
            },
        ),
        _ => Ok(StreamRead::NotStreamed),
    }
}

/// Parse a trace held in memory (CSV, or Parquet when it starts with `PAR1`); `source_name`
/// labels errors. The position is screened for glitches at the default limit, as by
/// [`read_trace_file`].
///
/// # Errors
/// As [`read_trace_file`].
pub fn parse_trace(
    bytes: &[u8],
    source_name: &str,
    opts: &ReadOptions,
) -> Result<(Trace, ReadReport), TraceError> {
    parse_trace_with(bytes, source_name, opts, &GlitchParams::default())
}

/// [`parse_trace`] with the position screened at `glitch`'s speed limit, as
/// [`read_trace_file_with`].
///
/// # Errors
/// As [`read_trace_file`].
///
/// # Panics
/// When `glitch.max_axis_speed_m_s` is NaN, zero or negative.
pub fn parse_trace_with(
    bytes: &[u8],
    source_name: &str,
    opts: &ReadOptions,
    glitch: &GlitchParams,
) -> Result<(Trace, ReadReport), TraceError> {
    match Format::of_bytes(bytes) {
        Format::Parquet => parquet::parse_bytes(bytes, source_name, opts, glitch),
        Format::Csv => csv::parse_bytes(bytes, source_name, opts, glitch),
    }
}
