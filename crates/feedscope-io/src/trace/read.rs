//! What a trace read takes and gives, shared by the CSV and Parquet readers: the options, the
//! report, the error, the rules for channel and column names, and the checks every reader ends
//! with (enough samples, motion, the position screened for glitches). Nothing here reads a
//! file; the readers call it, never the other way round.

use feedscope::diag::{Code, Diagnostic};
use feedscope::trace::glitch::{remove_samples, screen_effort, screen_position, GlitchParams};
use feedscope::trace::{Channel, EffortKind, Trace, MIN_SAMPLES};
use feedscope::units::feed_m_s_to_mm_min;

use super::format::Layout;

/// Why a trace could not be read. Every variant names the input and, where it applies, the line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TraceError {
    /// The file could not be opened or read.
    #[error("{source_name}: cannot read: {error}")]
    Io {
        /// The file.
        source_name: String,
        /// The operating system's error.
        error: std::io::Error,
    },
    /// A line runs on past [`MAX_LINE_BYTES`] without a line end: not a CSV trace (binary
    /// data, a device such as `/dev/zero`, a file of another kind). Refused before it is
    /// held in memory.
    #[error(
        "{source_name}:{line}: the line runs on for more than {max_bytes} bytes without a line \
         end: not a CSV trace (binary data, or a file of another kind)"
    )]
    LineTooLong {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// The limit (bytes).
        max_bytes: usize,
    },
    /// A `# fact KEY = VALUE` line names an unknown fact or a bad value.
    #[error("{source_name}:{line}: {reason}")]
    BadFact {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// What is wrong.
        reason: String,
    },
    /// The input has no header line (empty, or only comments).
    #[error("{source_name}: no header line found (the file is empty or holds only comments)")]
    Empty {
        /// The file.
        source_name: String,
    },
    /// The header does not describe a known layout.
    #[error("{source_name}:{line}: bad header `{found}`: {reason}")]
    BadHeader {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// The header as read (shortened).
        found: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A row has the wrong number of fields.
    #[error("{source_name}:{line}: expected {expected} comma-separated fields, found {found}")]
    FieldCount {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// Fields in the header.
        expected: usize,
        /// Fields in this row.
        found: usize,
    },
    /// A field that must be a number is not.
    #[error("{source_name}:{line}: column `{column}`: `{text}` is not a number")]
    NotANumber {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// Column name.
        column: String,
        /// The text found (shortened).
        text: String,
    },
    /// A number is NaN or infinite.
    #[error("{source_name}:{line}: column `{column}`: `{text}` is not finite")]
    NonFinite {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// Column name.
        column: String,
        /// The text found.
        text: String,
    },
    /// Time does not strictly increase within a channel.
    #[error(
        "{source_name}:{line}: channel `{channel}`: time {} s does not come after the \
         previous sample at {} s (time must strictly increase within a channel)",
        exact_time(.time_s),
        exact_time(.previous_time_s)
    )]
    TimeNotIncreasing {
        /// The file.
        source_name: String,
        /// Channel name.
        channel: String,
        /// 1-based line number.
        line: u64,
        /// The offending time (s).
        time_s: f64,
        /// The previous time of this channel (s).
        previous_time_s: f64,
    },
    /// A required channel is absent.
    #[error("{source_name}: no `{channel}` samples found (channels seen: {found})")]
    MissingChannel {
        /// The file.
        source_name: String,
        /// The channel wanted, e.g. `position_mm`.
        channel: String,
        /// Channel names that were present.
        found: String,
    },
    /// Both current and torque are present and no choice was made.
    #[error(
        "{source_name}: both `current_a` and `torque_nm` are present; choose one \
         (option `effort`)"
    )]
    AmbiguousEffort {
        /// The file.
        source_name: String,
    },
    /// Too few samples to interpolate a channel.
    #[error(
        "{source_name}: channel `{channel}` has {found} samples, at least {needed} are needed"
    )]
    TooFewSamples {
        /// The file.
        source_name: String,
        /// Channel name.
        channel: String,
        /// Samples found.
        found: usize,
        /// Minimum needed.
        needed: usize,
    },
    /// The axis never moves.
    #[error(
        "{source_name}: the position never moves (it spans only {range_mm} mm); \
         friction needs motion"
    )]
    NoMotion {
        /// The file.
        source_name: String,
        /// Range of the position channel (mm).
        range_mm: f64,
    },
    /// A Parquet file cannot be decoded: not Parquet, truncated, corrupt or unsupported.
    #[error("{source_name}: not a readable Parquet file: {reason}")]
    Parquet {
        /// The file.
        source_name: String,
        /// What the decoder reported.
        reason: String,
    },
    /// A Parquet column is missing or of a type that cannot hold what it should.
    #[error("{source_name}: column `{column}`: {reason}")]
    BadColumn {
        /// The file.
        source_name: String,
        /// Column name.
        column: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A Parquet cell that must hold a value does not (a null time, a null or empty channel).
    #[error("{source_name}: row {row}: column `{column}` {reason}")]
    BadCell {
        /// The file.
        source_name: String,
        /// 1-based data row.
        row: u64,
        /// Column name.
        column: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A Parquet value is NaN or infinite ([`TraceError::NonFinite`] of a row, not a line).
    #[error("{source_name}: row {row}: column `{column}`: {value} is not finite")]
    NonFiniteInRow {
        /// The file.
        source_name: String,
        /// 1-based data row.
        row: u64,
        /// Column name.
        column: String,
        /// The value found.
        value: f64,
    },
    /// A channel name of the long layout is too long or holds a control character (a header
    /// column name is [`TraceError::BadHeader`], a Parquet column name
    /// [`TraceError::BadColumn`], a Parquet channel value [`TraceError::BadCell`]).
    #[error("{source_name}:{line}: channel name `{name}` {reason}")]
    BadChannelName {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// The name as found, shortened, control characters escaped.
        name: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The position jumps at a speed the axis cannot reach and does not come back: the trace
    /// is discontinuous (see [`feedscope::trace::glitch`]). Isolated jumps that come back are
    /// dropped instead and listed in [`ReadReport::dropped_position`].
    #[error(
        "{source_name}{}: the position jumps by {} mm between t = {} s and t = {} s, \
         implying {} mm/min, above the limit of {} mm/min, and does not come back \
         (re-homed, or two recordings joined?); split the trace at the jump",
        at(.line, .row),
        mm(*.jump_mm),
        secs(*.previous_time_s),
        secs(*.time_s),
        mm_min(*.speed_mm_min),
        mm_min(*.limit_mm_min)
    )]
    PositionJump {
        /// The file.
        source_name: String,
        /// 1-based line of the sample after the jump (CSV).
        line: Option<u64>,
        /// 1-based data row of the sample after the jump (Parquet).
        row: Option<u64>,
        /// Time of the sample after the jump (s).
        time_s: f64,
        /// Time of the last consistent sample before it (s).
        previous_time_s: f64,
        /// The jump (mm), signed.
        jump_mm: f64,
        /// The speed it implies (mm/min).
        speed_mm_min: f64,
        /// The speed limit of the screening (mm/min).
        limit_mm_min: f64,
    },
    /// A position sample outside the travel the axis file declares, beyond its margin
    /// ([`GlitchParams::travel_m`]): the trace is not this axis in machine coordinates.
    #[error(
        "{source_name}{}: position {} mm at t = {} s is outside the axis travel [{}, {}] mm \
         declared in the axis file (travel_min_mm, travel_max_mm; margin {} mm): the trace is \
         in other coordinates (work offset?), scaled (µm written as mm?) or of another axis; \
         record machine coordinates of this axis, or correct the travel in the axis file",
        at(.line, .row),
        mm(*.position_mm),
        secs(*.time_s),
        mm(*.travel_min_mm),
        mm(*.travel_max_mm),
        mm(*.margin_mm)
    )]
    OutsideTravel {
        /// The file.
        source_name: String,
        /// 1-based line of the sample (CSV).
        line: Option<u64>,
        /// 1-based data row of the sample (Parquet).
        row: Option<u64>,
        /// Its time (s).
        time_s: f64,
        /// Its position (mm).
        position_mm: f64,
        /// Declared lower end of the travel (mm).
        travel_min_mm: f64,
        /// Declared upper end of the travel (mm).
        travel_max_mm: f64,
        /// The margin allowed beyond either end (mm).
        margin_mm: f64,
    },
    /// A sample beyond the bounds of a feed axis ([`super::limits`]): |position| > 100 m,
    /// |current| > 10 kA or |torque| > 1 MN·m is not a ball-screw drive but a corrupt or
    /// mis-scaled file.
    #[error(
        "{source_name}{}: channel `{channel}`: {value:e} {unit} is beyond ±{limit:e} {unit}, \
         which no feed axis reaches (a corrupt or mis-scaled value)",
        at(line, row)
    )]
    Implausible {
        /// The file.
        source_name: String,
        /// 1-based line (CSV).
        line: Option<u64>,
        /// 1-based data row (Parquet).
        row: Option<u64>,
        /// The channel: `position`, `current_a` or `torque_nm`.
        channel: String,
        /// The value, in SI units (m, A, N·m).
        value: f64,
        /// The bound (same unit).
        limit: f64,
        /// The unit.
        unit: &'static str,
    },
    /// Time does not strictly increase within a channel of a Parquet file
    /// ([`TraceError::TimeNotIncreasing`] of a row, not a line).
    #[error(
        "{source_name}: row {row}: channel `{channel}`: time {} s does not come after the \
         previous sample at {} s (time must strictly increase within a channel)",
        exact_time(.time_s),
        exact_time(.previous_time_s)
    )]
    TimeNotIncreasingInRow {
        /// The file.
        source_name: String,
        /// Channel name.
        channel: String,
        /// 1-based data row.
        row: u64,
        /// The offending time (s).
        time_s: f64,
        /// The previous time of this channel (s).
        previous_time_s: f64,
    },
}

impl TraceError {
    /// What the error means to a caller: a file that cannot be read is
    /// [`ErrorKind::of_io`](feedscope::ErrorKind::of_io) of the operating system's error (bad input when missing); every other
    /// variant is what the file holds, [`BadInput`](feedscope::ErrorKind::BadInput).
    pub fn kind(&self) -> feedscope::ErrorKind {
        use feedscope::ErrorKind;
        match self {
            TraceError::Io { error, .. } => ErrorKind::of_io(error),
            _ => ErrorKind::BadInput,
        }
    }
}

/// Longest line a CSV trace may hold (bytes): 1 MiB, thousands of times a real row (a wide
/// row of a few numbers is under 100 bytes). A longer line is [`TraceError::LineTooLong`].
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Options for reading a trace.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Which effort channel to use when a file has both current and torque; `None` takes the
    /// one present and fails when both are.
    pub effort: Option<EffortKind>,
    /// Worker threads for parsing; `0` = the rayon pool size.
    pub threads: usize,
}

/// Facts about a file that was read successfully.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadReport {
    /// Rows of the long layout whose channel is not one feedscope uses.
    pub ignored_rows: u64,
    /// Names of the ignored channels (at most 16 listed).
    pub ignored_channels: Vec<String>,
    /// Lines in the file (CSV), or data rows (Parquet).
    pub lines: u64,
    /// The layout detected.
    pub layout: Option<Layout>,
    /// Position samples dropped as glitches (see [`feedscope::trace::glitch`]), in time order;
    /// they are not in the trace.
    pub dropped_position: Vec<DroppedSample>,
    /// The speed limit the position was screened with (m/s); `None` when it was not screened
    /// (a report made by hand).
    pub max_axis_speed_m_s: Option<f64>,
    /// Effort samples dropped as glitches (see
    /// [`feedscope::trace::glitch::screen_effort`]), in time order; they are not in the trace.
    pub dropped_effort: Vec<DroppedEffort>,
    /// The magnitude the effort glitches exceeded (A or N·m, the effort's unit); `None` when
    /// the effort was not screened (too few samples, a mostly zero channel, a report made by
    /// hand).
    pub effort_glitch_limit: Option<f64>,
    /// The 1-based line of a CSV file's last data line when the file does not end with a line
    /// end: a file cut off while being written or copied looks like this, and its last row
    /// may hold a shortened number. The row was read as it stands.
    pub unterminated_last_line: Option<u64>,
}

/// A position sample dropped as a glitch.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DroppedSample {
    /// Its time (s).
    pub time_s: f64,
    /// The position it held (m), as read.
    pub position_m: f64,
    /// Its 1-based line in a CSV file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line: Option<u64>,
    /// Its 1-based data row in a Parquet file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub row: Option<u64>,
}

/// An effort sample dropped as a glitch.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DroppedEffort {
    /// Its time (s).
    pub time_s: f64,
    /// The value it held (A or N·m), as read.
    pub value: f64,
}

/// Dropped samples named in full in [`ReadReport::glitch_warning`]; the rest are counted.
const SHOWN_DROPPED: usize = 5;

impl ReadReport {
    /// What the read warns about, as diagnostics: [`ReadReport::glitch_warning`]
    /// (`position-glitches-dropped`), [`ReadReport::effort_glitch_warning`]
    /// (`effort-glitches-dropped`) and a last line without a line end
    /// (`last-line-unterminated`). Empty for a clean read.
    pub fn diagnostics(&self) -> Vec<Diagnostic> {
        let cut = self.unterminated_last_line.map(|l| {
            format!(
                "the last line (line {l}) has no line end: the file may have been cut off \
                 while being written or copied, and its last row shortened (it was read as it \
                 stands; the recording may end early)"
            )
        });
        [
            (Code::PositionGlitchesDropped, self.glitch_warning()),
            (Code::EffortGlitchesDropped, self.effort_glitch_warning()),
            (Code::LastLineUnterminated, cut),
        ]
        .into_iter()
        .filter_map(|(code, m)| m.map(|m| Diagnostic::new(code, m)))
        .collect()
    }

    /// What the read warns about, in one line for people: the messages of
    /// [`ReadReport::diagnostics`]. `None` for a clean read.
    pub fn warning(&self) -> Option<String> {
        let parts: Vec<String> = self.diagnostics().into_iter().map(|d| d.message).collect();
        (!parts.is_empty()).then(|| parts.join("; "))
    }

    /// One sentence for people when effort samples were dropped as glitches: the count, the
    /// bound, and the time and value of the first few. `None` when nothing was dropped.
    pub fn effort_glitch_warning(&self) -> Option<String> {
        let d = &self.dropped_effort;
        if d.is_empty() {
            return None;
        }
        let limit = self
            .effort_glitch_limit
            .map(|l| format!(" beyond ±{}", num(l, 3)))
            .unwrap_or_default();
        let list: Vec<String> = d
            .iter()
            .take(SHOWN_DROPPED)
            .map(|s| format!("{} s ({})", secs(s.time_s), num(s.value, 3)))
            .collect();
        let more = if d.len() > SHOWN_DROPPED {
            format!(" and {} more", d.len() - SHOWN_DROPPED)
        } else {
            String::new()
        };
        let n = d.len();
        let what = if n == 1 {
            "1 effort sample as a logger glitch".to_string()
        } else {
            format!("{n} effort samples as logger glitches")
        };
        Some(format!(
            "dropped {what} (at most {} in a row{limit}, ten times the recording's 99.9th \
             percentile magnitude) at t = {}{more}",
            feedscope::trace::glitch::MAX_GLITCH_RUN,
            list.join(", ")
        ))
    }

    /// One sentence for people when position samples were dropped as glitches: the count, the
    /// limit, and the time (and line or row) of the first few. `None` when nothing was dropped.
    pub fn glitch_warning(&self) -> Option<String> {
        let d = &self.dropped_position;
        if d.is_empty() {
            return None;
        }
        let limit = self
            .max_axis_speed_m_s
            .map(|v| format!(" beyond {} mm/min", mm_min(feed_m_s_to_mm_min(v))))
            .unwrap_or_default();
        let shown: Vec<String> = d
            .iter()
            .take(SHOWN_DROPPED)
            .map(|s| format!("{} s{}", secs(s.time_s), where_in_parens(s.line, s.row)))
            .collect();
        let more = if d.len() > SHOWN_DROPPED {
            format!(" and {} more", d.len() - SHOWN_DROPPED)
        } else {
            String::new()
        };
        let what = if d.len() == 1 {
            format!("1 position sample as a logger glitch (an isolated jump{limit} and back)")
        } else {
            format!(
                "{} position samples as logger glitches (isolated jumps{limit} and back)",
                d.len()
            )
        };
        Some(format!("dropped {what} at t = {}{more}", shown.join(", ")))
    }
}

/// `:line` or `: row N` after a file name, or nothing.
fn at(line: &Option<u64>, row: &Option<u64>) -> String {
    match (line, row) {
        (Some(l), _) => format!(":{l}"),
        (None, Some(r)) => format!(": row {r}"),
        (None, None) => String::new(),
    }
}

/// ` (line N)`, ` (row N)` or nothing.
fn where_in_parens(line: Option<u64>, row: Option<u64>) -> String {
    match (line, row) {
        (Some(l), _) => format!(" (line {l})"),
        (None, Some(r)) => format!(" (row {r})"),
        (None, None) => String::new(),
    }
}

/// A number for messages: at most `decimals` decimals without trailing zeros, or 4
/// significant digits in scientific notation when it is huge (a glitch can be 1e308) or
/// nonzero and too small for the decimals.
fn num(x: f64, decimals: usize) -> String {
    let a = x.abs();
    let smallest = 0.5 * 10f64.powi(-(decimals as i32));
    if a.is_finite() && (a == 0.0 || (smallest..1e9).contains(&a)) {
        let s = format!("{x:.decimals$}");
        let s = if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.')
        } else {
            &s
        };
        if s == "-0" {
            "0".into()
        } else {
            s.into()
        }
    } else {
        format!("{x:.3e}")
    }
}

/// A time (s) for a message that compares two of them: every digit that tells it apart
/// (Rust's shortest round-trip form), in scientific notation when that would be long (below
/// 10⁻⁴ or from 10¹⁵ on; −1e-300 otherwise prints 300 zeros).
fn exact_time(x: &f64) -> String {
    let a = x.abs();
    if a == 0.0 || !a.is_finite() || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Time (s) for messages, to the microsecond.
fn secs(x: f64) -> String {
    num(x, 6)
}

/// Length (mm) for messages, to the micrometre.
fn mm(x: f64) -> String {
    num(x, 3)
}

/// Speed (mm/min) for messages, to the mm/min.
fn mm_min(x: f64) -> String {
    num(x, 0)
}

/// Why a wide header (lower-cased names) is ambiguous, or `None`: a column the readers use
/// appears twice, or in two units (`time_s` and `time_ms`, `position_mm` and `position_m`).
/// Taking the first silently dropped a conflicting copy.
pub(super) fn duplicate_columns(names: &[String]) -> Option<String> {
    for (group, what) in [
        (&["time_s", "time_ms"][..], "time"),
        (&["position_mm", "position_m"], "position"),
        (&["current_a"], "motor current"),
        (&["torque_nm"], "motor torque"),
    ] {
        let at: Vec<usize> = (0..names.len())
            .filter(|&k| group.contains(&names[k].as_str()))
            .collect();
        if let [a, b, ..] = at[..] {
            return Some(format!(
                "columns {} (`{}`) and {} (`{}`) both hold the {what}: which one to read is \
                 not known; keep one",
                a + 1,
                names[a],
                b + 1,
                names[b],
            ));
        }
    }
    None
}

/// Longest channel or column name accepted (bytes of UTF-8).
pub const MAX_NAME_BYTES: usize = 64;

/// Why a channel or column name is refused, or `None` when it is fine: longer than
/// [`MAX_NAME_BYTES`] or holding a control character (C0, DEL or C1).
pub(super) fn name_problem(name: &[u8]) -> Option<String> {
    if name.len() > MAX_NAME_BYTES {
        return Some(format!(
            "is {} bytes long; names are at most {MAX_NAME_BYTES} bytes",
            name.len()
        ));
    }
    String::from_utf8_lossy(name)
        .chars()
        .find(|c| c.is_control())
        .map(|c| format!("holds the control character U+{:04X}", c as u32))
}

/// A name for a message: at most 40 characters, control characters escaped.
pub(super) fn show_name(name: &[u8]) -> String {
    shorten_to(name, 40)
}

/// Text from a file for a message: trimmed, at most 60 characters, control characters escaped
/// (a terminal must not receive the file's escape sequences).
pub(super) fn shorten(b: &[u8]) -> String {
    shorten_to(b, 60)
}

/// [`shorten`] to at most `max_chars` characters (and `…`).
fn shorten_to(b: &[u8], max_chars: usize) -> String {
    // A UTF-8 character is at most 4 bytes: enough bytes for `max_chars` after trimming a few.
    let cap = 4 * max_chars + 8;
    let s = String::from_utf8_lossy(&b[..b.len().min(cap)]);
    let s = s.trim();
    let escape = |c: char| -> String {
        if c.is_control() {
            c.escape_debug().collect()
        } else {
            c.to_string()
        }
    };
    let mut out: String = s.chars().take(max_chars).map(escape).collect();
    if s.chars().count() > max_chars || b.len() > cap {
        out.push('…');
    }
    out
}

/// Where the numbers of [`screen_and_check`]'s `locate` point: CSV lines or Parquet rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Origin {
    Line,
    Row,
}

/// The checks every reader ends with: enough samples and motion ([`check_channels`]), then the
/// position screened for glitches (dropped samples named by `locate`, which maps ascending
/// position-sample indices to 1-based lines or rows), then the first checks again on what is
/// left.
pub(super) fn screen_and_check(
    name: &str,
    (mut trace, mut report): (Trace, ReadReport),
    glitch: &GlitchParams,
    origin: Origin,
    locate: impl Fn(&[usize]) -> Vec<Option<u64>>,
) -> Result<(Trace, ReadReport), TraceError> {
    check_channels(name, &trace.position_m, &trace.effort, trace.effort_kind)?;
    report.max_axis_speed_m_s = Some(glitch.max_axis_speed_m_s);
    let split = |at: Option<u64>| match origin {
        Origin::Line => (at, None),
        Origin::Row => (None, at),
    };
    let p = &trace.position_m;
    match screen_position(p, glitch) {
        Ok(s) if s.glitches.is_empty() => {}
        Ok(s) => {
            let at = locate(&s.glitches);
            report.dropped_position = s
                .glitches
                .iter()
                .zip(at.into_iter().chain(std::iter::repeat(None)))
                .map(|(&k, at)| {
                    let (line, row) = split(at);
                    DroppedSample {
                        time_s: p.time_s[k],
                        position_m: p.value[k],
                        line,
                        row,
                    }
                })
                .collect();
            remove_samples(&mut trace.position_m, &s.glitches);
            check_channels(name, &trace.position_m, &trace.effort, trace.effort_kind)?;
        }
        Err(j) => {
            let (line, row) = split(locate(&[j.index]).first().copied().flatten());
            return Err(TraceError::PositionJump {
                source_name: name.to_string(),
                line,
                row,
                time_s: p.time_s[j.index],
                previous_time_s: p.time_s[j.from_index],
                jump_mm: j.jump_m * 1e3,
                speed_mm_min: feed_m_s_to_mm_min(j.speed_m_s),
                limit_mm_min: glitch.max_axis_speed_mm_min(),
            });
        }
    }
    // Effort glitches: a few samples far beyond everything else the drive recorded.
    let e = screen_effort(&trace.effort);
    report.effort_glitch_limit = e.limit;
    if !e.glitches.is_empty() {
        report.dropped_effort = e
            .glitches
            .iter()
            .map(|&k| DroppedEffort {
                time_s: trace.effort.time_s[k],
                value: trace.effort.value[k],
            })
            .collect();
        remove_samples(&mut trace.effort, &e.glitches);
        check_channels(name, &trace.position_m, &trace.effort, trace.effort_kind)?;
    }
    // Kept positions beyond the bound of a feed axis: what the glitch screen could not call
    // a glitch (a whole stretch mis-scaled, or times so far apart that any jump is slow).
    let bound = super::limits::MAX_ABS_POSITION_M;
    let p = &trace.position_m;
    if let Some(k) = p.value.iter().position(|z| z.abs() > bound) {
        let (line, row) = split(
            locate(&[k + dropped_before(&report, p.time_s[k])])
                .first()
                .copied()
                .flatten(),
        );
        return Err(TraceError::Implausible {
            source_name: name.to_string(),
            line,
            row,
            channel: "position".into(),
            value: p.value[k],
            limit: bound,
            unit: "m",
        });
    }
    if let Some((lo, hi)) = glitch.travel_m {
        let margin = glitch.travel_margin_m();
        let p = &trace.position_m;
        // NaN cannot be here: the readers refuse it before.
        if let Some(k) = p
            .value
            .iter()
            .position(|&z| z < lo - margin || z > hi + margin)
        {
            let (line, row) = split(
                locate(&[k + dropped_before(&report, p.time_s[k])])
                    .first()
                    .copied()
                    .flatten(),
            );
            return Err(TraceError::OutsideTravel {
                source_name: name.to_string(),
                line,
                row,
                time_s: p.time_s[k],
                position_mm: p.value[k] * 1e3,
                travel_min_mm: lo * 1e3,
                travel_max_mm: hi * 1e3,
                margin_mm: margin * 1e3,
            });
        }
    }
    Ok((trace, report))
}

/// Position samples dropped as glitches at or before `time_s`: added to a kept sample's index
/// they give its index in the channel as read (what `locate` maps to a line or row).
fn dropped_before(report: &ReadReport, time_s: f64) -> usize {
    report
        .dropped_position
        .iter()
        .filter(|d| d.time_s <= time_s)
        .count()
}

/// The first checks every reader ends with: enough samples in both channels, and motion.
fn check_channels(
    name: &str,
    position_m: &Channel,
    effort: &Channel,
    effort_kind: EffortKind,
) -> Result<(), TraceError> {
    for (ch, label) in [(position_m, "position"), (effort, effort_kind.column())] {
        if ch.len() < MIN_SAMPLES {
            return Err(TraceError::TooFewSamples {
                source_name: name.to_string(),
                channel: label.into(),
                found: ch.len(),
                needed: MIN_SAMPLES,
            });
        }
    }
    let (lo, hi) = position_m
        .value
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    // Below a nanometre nothing measurable moved.
    if hi - lo <= 1e-9 {
        return Err(TraceError::NoMotion {
            source_name: name.to_string(),
            range_mm: (hi - lo) * 1e3,
        });
    }
    Ok(())
}

/// Why no effort column could be picked.
pub(super) enum EffortChoice {
    /// Both current and torque are present and none was chosen.
    Ambiguous,
    /// The chosen kind is absent.
    Missing(EffortKind),
    /// Neither is present.
    Neither,
}

/// The effort column (any index type) from the current and torque columns found and the
/// user's choice: the one present, or the chosen one.
pub(super) fn choose_effort<T>(
    cur: Option<T>,
    tor: Option<T>,
    choice: Option<EffortKind>,
) -> Result<(T, EffortKind), EffortChoice> {
    match (cur, tor, choice) {
        (Some(c), _, Some(EffortKind::CurrentA)) | (Some(c), None, None) => {
            Ok((c, EffortKind::CurrentA))
        }
        (_, Some(t), Some(EffortKind::TorqueNm)) | (None, Some(t), None) => {
            Ok((t, EffortKind::TorqueNm))
        }
        (Some(_), Some(_), None) => Err(EffortChoice::Ambiguous),
        (_, _, Some(k)) => Err(EffortChoice::Missing(k)),
        (None, None, None) => Err(EffortChoice::Neither),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_numbers() {
        assert_eq!(secs(1.5), "1.5");
        assert_eq!(secs(1.2340000000000002), "1.234");
        assert_eq!(mm_min(200_000.0), "200000");
        assert_eq!(mm_min(59_998_559.7), "59998560");
        assert_eq!(mm(999.975995), "999.976");
        assert_eq!(mm(-0.0), "0");
        assert_eq!(mm(-0.0001), "-1.000e-4");
        assert_eq!(mm(f64::MAX), "1.798e308");
        assert_eq!(mm_min(f64::INFINITY), "inf");
        assert_eq!(secs(1e-7), "1.000e-7");
    }
}
