//! Controller traces: axis position and servo effort (motor current or torque), each channel
//! with its own timestamps.
//!
//! Inside the library every value is SI: time in seconds, position in metres, current in
//! amperes, torque in newton-metres. Files use the units named in their column headers.
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
//! [`TraceError::BadCell`]). [`Trace::write_parquet`] writes either layout, in SI units at full
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
//! reach ([`glitch`]): above [`GlitchParams::max_axis_speed_m_s`], 200 m/min by default, or
//! 1.25 × the axis' `rapid_rate_mm_min` with [`GlitchParams::for_axis`] (pass it to
//! [`read_trace_file_with`] / [`parse_trace_with`]). Allowing either time stamp to be off by
//! one typical sampling interval and 10 µm of quantisation, a sample must jump by more than
//! about v_lim × 3 sampling intervals to count.
//! - A run of 1-3 samples that jumps away and back (a logger glitch such as `1e308`) is
//!   dropped and listed in [`ReadReport::dropped_position`] with its time, value and line (CSV)
//!   or row (Parquet); [`ReadReport::glitch_warning`] says so in one sentence. So is such a
//!   run at either end of the trace.
//! - A jump that does not come back (re-homing, recordings joined) is refused:
//!   [`TraceError::PositionJump`] names the line or row, the jump (mm) and its speed (mm/min).
//!
//! The effort channel is not screened: current and torque jump legitimately (acceleration,
//! reversal, saturation) and the axis description gives no bound for them.

use std::io::Write;

mod format;
pub mod glitch;
mod parquet;
mod read;
pub use format::push_fixed;
pub use glitch::{screen_position, GlitchParams};
pub use parquet::decoding_untrusted_parquet;
pub use read::{
    parse_trace, parse_trace_with, read_trace_file, read_trace_file_with, DroppedSample,
    ReadOptions, ReadReport, TraceError, MAX_NAME_BYTES, MIN_SAMPLES,
};

/// What the effort channel measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EffortKind {
    /// Servo motor torque current (A); friction needs the torque constant k_e.
    CurrentA,
    /// Motor torque (N·m); k_e is not used.
    TorqueNm,
}

impl EffortKind {
    /// The column / channel name used in files.
    pub fn column(self) -> &'static str {
        match self {
            Self::CurrentA => "current_a",
            Self::TorqueNm => "torque_nm",
        }
    }
}

/// One sampled channel: strictly increasing times and the values taken at them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Channel {
    /// Sample times (s), strictly increasing.
    pub time_s: Vec<f64>,
    /// Sample values in the channel's SI unit.
    pub value: Vec<f64>,
}

impl Channel {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// True when the channel holds no sample.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
}

/// A trace of one axis: position and effort, each with its own timestamps.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Table position (m).
    pub position_m: Channel,
    /// Motor current (A) or torque (N·m), see [`Trace::effort_kind`].
    pub effort: Channel,
    /// What [`Trace::effort`] measures.
    pub effort_kind: EffortKind,
}

/// Layout of a trace file (CSV or Parquet).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// `time_s,channel,value`, one sample per row (asynchronous channels).
    Long,
    /// `time_s,position_mm,current_a` (or `torque_nm`), channels sampled together.
    Wide,
}

impl Trace {
    /// Write the trace as CSV in user units: time in s with 6 decimals (1 µs), position in mm
    /// with 6 decimals (1 nm), current (A) or torque (N·m) with 6 decimals, as a controller
    /// logger would.
    ///
    /// The long layout merges both channels in time order. The wide layout needs both channels
    /// on the same timestamps.
    ///
    /// # Errors
    /// I/O errors; `InvalidInput` when the wide layout is asked for channels with different
    /// timestamps.
    pub fn write_csv<W: Write>(&self, w: W, layout: Layout) -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(w);
        let effort = self.effort_kind.column();
        match layout {
            Layout::Long => {
                writeln!(w, "time_s,channel,value")?;
                let (p, e) = (&self.position_m, &self.effort);
                let (mut i, mut j) = (0, 0);
                let mut line = Vec::with_capacity(64);
                while i < p.len() || j < e.len() {
                    let take_p = j >= e.len() || (i < p.len() && p.time_s[i] <= e.time_s[j]);
                    line.clear();
                    if take_p {
                        push_fixed(&mut line, p.time_s[i], 6);
                        line.extend_from_slice(b",position_mm,");
                        push_fixed(&mut line, p.value[i] * 1e3, 6);
                        i += 1;
                    } else {
                        push_fixed(&mut line, e.time_s[j], 6);
                        line.push(b',');
                        line.extend_from_slice(effort.as_bytes());
                        line.push(b',');
                        push_fixed(&mut line, e.value[j], 6);
                        j += 1;
                    }
                    line.push(b'\n');
                    w.write_all(&line)?;
                }
            }
            Layout::Wide => {
                if self.position_m.time_s != self.effort.time_s {
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::InvalidInput,
                        "the wide layout needs position and effort on the same timestamps",
                    ));
                }
                writeln!(w, "time_s,position_mm,{effort}")?;
                let mut line = Vec::with_capacity(64);
                for k in 0..self.position_m.len() {
                    line.clear();
                    push_fixed(&mut line, self.position_m.time_s[k], 6);
                    line.push(b',');
                    push_fixed(&mut line, self.position_m.value[k] * 1e3, 6);
                    line.push(b',');
                    push_fixed(&mut line, self.effort.value[k], 6);
                    line.push(b'\n');
                    w.write_all(&line)?;
                }
            }
        }
        w.flush()
    }
}
