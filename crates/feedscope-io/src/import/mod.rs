//! Importing real controller exports into feedscope [`Trace`]s.
//!
//! Four sources are read:
//! - **MTConnect SHDR** adapter logs ([`shdr`]) with the device model `Devices.xml`
//!   ([`devices`]): pipe-separated `timestamp|key|value|key|value…` lines, change-only and
//!   asynchronous. Axis position is a `POSITION` sample (mm) and the drive's effort a `LOAD`
//!   sample in percent, so a torque needs the user's N·m at 100 % load.
//! - **UMich SMART CNC mill** CSV files ([`umich`]): 10 Hz rows without timestamps, position (mm)
//!   and motor current (A) per axis.
//! - **SINUMERIK Operate servo traces** ([`sinumerik`]): XML `traceData` frames of `rec`
//!   records, change-only, the signals named by NCK path; units from the descriptions.
//! - **TwinCAT 3 Scope CSV exports** ([`twincat`]): a header block per channel, then time and
//!   value columns; separators and decimal marks as the export wrote them.
//!
//! Everything returned is SI (position in metres), as in the rest of the library; the times of
//! an SHDR log are relative to a chosen origin ([`shdr::TimeOrigin`]) whose absolute value is
//! kept in [`ImportReport::time_zero`] and written as a `#` comment above the CSV by
//! [`write_trace_csv`], a line [`crate::trace::read_trace_file`] skips.
//!
//! # Example
//! ```
//! use feedscope_io::import::{devices::DeviceModel, shdr::{parse_shdr, ShdrConvertParams}};
//!
//! let xml = r#"<MTConnectDevices><Devices><Device id="d" name="mill"><Components>
//!   <Axes id="ax"><Components><Linear id="z" name="Z">
//!     <DataItems>
//!       <DataItem id="zp" name="Zabs" category="SAMPLE" type="POSITION" subType="ACTUAL" units="MILLIMETER"/>
//!       <DataItem id="zl" name="Zload" category="SAMPLE" type="LOAD" units="PERCENT"/>
//!     </DataItems>
//!   </Linear></Components></Axes></Components></Device></Devices></MTConnectDevices>"#;
//! let model = DeviceModel::parse(xml, "Devices.xml")?;
//! let log = "2024-01-01T00:00:00Z|Zabs|10.0|Zload|5\n\
//!            2024-01-01T00:00:00.5Z|Zabs|10.5|Zload|6\n\
//!            2024-01-01T00:00:01Z|Zabs|11.0|Zload|7\n\
//!            2024-01-01T00:00:01.5Z|Zabs|11.5|Zload|7|Zload|8\n";
//! let log = parse_shdr(log, "log.txt", &model, None)?;
//! let params = ShdrConvertParams { torque_per_load_nm: Some(20.0), ..Default::default() };
//! let imported = log.to_trace(&model, "Z", &params)?;
//! assert!((imported.trace.position_m.value[3] - 0.0115).abs() < 1e-15); // 11.5 mm in m
//! // Load 8 % of 20 N·m; the repeated `Zload` at 1.5 s kept its last value and was counted.
//! assert!((imported.trace.effort.value[3] - 1.6).abs() < 1e-12);
//! assert_eq!(imported.report.effort.repeated_times, 1);
//! # Ok::<(), feedscope_io::import::ImportError>(())
//! ```
use std::io::Write;

use feedscope::calendar::{civil_from_days, days_from_civil, days_in_month};
use feedscope::trace::Trace;

use crate::trace::{write_csv, Layout};

pub mod devices;
pub mod shdr;
pub mod sinumerik;
pub mod twincat;
pub mod umich;
pub mod units;

/// Why an export could not be imported. Every variant names the input and, where there is one,
/// the 1-based line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImportError {
    /// A converted channel holds no information (zero or one constant value; no motion).
    #[error(
        "{source_name}: {channel} {what}: nothing to estimate friction from (check the axis \
         and the data item; --keep-empty-channels writes the trace anyway)"
    )]
    NoInformation {
        /// The file.
        source_name: String,
        /// The channel and where it came from.
        channel: String,
        /// What is wrong with it.
        what: String,
    },
    /// The file could not be opened or read.
    #[error("{source_name}: cannot read: {error}")]
    Io {
        /// The file.
        source_name: String,
        /// The operating system's error.
        error: std::io::Error,
    },
    /// The file holds no data line.
    #[error("{source_name}: the file is empty (no data line)")]
    Empty {
        /// The file.
        source_name: String,
    },
    /// A line's timestamp is not ISO-8601.
    #[error("{source_name}:{line}: bad timestamp `{text}`: {reason}")]
    BadTimestamp {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// The text found (shortened).
        text: String,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// A data item has fewer fields than its kind needs (a line cut short).
    #[error(
        "{source_name}:{line}: `{key}` ({kind}) needs {expected} fields after the key, the line \
         has {found} (truncated line?)"
    )]
    TruncatedItem {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// The data item key.
        key: String,
        /// Its kind, e.g. `CONDITION`.
        kind: &'static str,
        /// Fields needed.
        expected: usize,
        /// Fields present.
        found: usize,
    },
    /// A line that is not a data line, command or asset.
    #[error("{source_name}:{line}: {reason}")]
    Malformed {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// What is wrong.
        reason: String,
    },
    /// The device model is not XML or not an MTConnect device model.
    #[error("{source_name}: not a readable MTConnect device model: {reason}")]
    BadDevices {
        /// The file.
        source_name: String,
        /// What the XML parser or the model check said.
        reason: String,
    },
    /// The device asked for, or the one the log's keys point to, could not be chosen.
    #[error("{source_name}: {reason} (devices: {found})")]
    Device {
        /// The device model file.
        source_name: String,
        /// What went wrong.
        reason: String,
        /// The devices declared.
        found: String,
    },
    /// The axis asked for does not exist.
    #[error("{source_name}: no axis `{wanted}`; axes found: {found}")]
    UnknownAxis {
        /// The file that declares the axes.
        source_name: String,
        /// The axis asked for.
        wanted: String,
        /// The axes that exist.
        found: String,
    },
    /// The axis has no (or no usable) data item of a kind.
    #[error("{source_name}: axis `{axis}`: {reason}")]
    Item {
        /// The file that declares the data items.
        source_name: String,
        /// The axis.
        axis: String,
        /// What is missing or wrong.
        reason: String,
    },
    /// SHDR load is in percent; a torque needs the N·m at 100 % load.
    #[error(
        "{source_name}: `{load_key}` is drive load in percent, not current or torque; give \
         --torque-per-load-nm (the motor torque in N·m at 100 % load, e.g. its rated torque \
         from the drive's data sheet) to convert it to torque_nm"
    )]
    NeedTorqueScale {
        /// The log.
        source_name: String,
        /// The load data item.
        load_key: String,
    },
    /// Columns needed for the axis are missing.
    #[error("{source_name}: axis `{axis}`: missing column(s) {missing}; axes found: {found}")]
    MissingColumns {
        /// The file.
        source_name: String,
        /// The axis asked for.
        axis: String,
        /// The missing columns.
        missing: String,
        /// Axes with both position and current.
        found: String,
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
    /// A field that must be a finite number is not.
    #[error("{source_name}:{line}: column `{column}`: `{text}` is not a finite number")]
    NotANumber {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: u64,
        /// Column or data item name.
        column: String,
        /// The text found (shortened).
        text: String,
    },
    /// Too few samples for a trace feedscope can read.
    #[error(
        "{source_name}: `{channel}` has {found} samples, at least {needed} are needed for a trace"
    )]
    TooFewSamples {
        /// The file.
        source_name: String,
        /// Channel or data item.
        channel: String,
        /// Samples found.
        found: usize,
        /// Minimum needed.
        needed: usize,
    },
    /// An option is out of range.
    #[error("{0}")]
    BadParam(String),
    /// A converted sample is beyond the bounds of a feed axis
    /// ([`crate::trace::limits`]): a corrupt value or a wrong unit scale.
    #[error(
        "{source_name}: {channel} at t = {time_s} s: {value:e} {unit} is beyond ±{limit:e} \
         {unit}, which no feed axis reaches (a corrupt value or a wrong unit scale)"
    )]
    Implausible {
        /// The file.
        source_name: String,
        /// The channel and its source (column or data item).
        channel: String,
        /// Time of the sample in the converted trace (s).
        time_s: f64,
        /// The value (SI: m, A or N·m).
        value: f64,
        /// The bound (same unit).
        limit: f64,
        /// The unit.
        unit: &'static str,
    },
}

/// Refuse a converted trace with a sample beyond the bounds of a feed axis
/// ([`crate::trace::limits`]), as the trace readers do.
///
/// # Errors
/// [`ImportError::Implausible`] naming the channel, its source, the time and the value.
pub(crate) fn check_limits(imported: &Imported) -> Result<(), ImportError> {
    let t = &imported.trace;
    let r = &imported.report;
    for (ch, label, source) in [
        (&t.position_m, "position", &r.position.source_key),
        (&t.effort, t.effort_kind.column(), &r.effort.source_key),
    ] {
        let Some((limit, unit)) = crate::trace::limits::bound(label) else {
            continue;
        };
        // NaN is beyond every bound too
        if let Some(k) = ch.value.iter().position(|v| v.abs() > limit || v.is_nan()) {
            return Err(ImportError::Implausible {
                source_name: r.source_name.clone(),
                channel: format!("{label} (from {source})"),
                time_s: ch.time_s[k],
                value: ch.value[k],
                limit,
                unit,
            });
        }
    }
    Ok(())
}

impl ImportError {
    /// What the error means to a caller: a file that cannot be read is
    /// [`ErrorKind::of_io`](feedscope::ErrorKind::of_io) of the operating system's error (bad input when missing); every other
    /// variant is what the file holds or an option, [`BadInput`](feedscope::ErrorKind::BadInput).
    pub fn kind(&self) -> feedscope::ErrorKind {
        use feedscope::ErrorKind;
        match self {
            ImportError::Io { error, .. } => ErrorKind::of_io(error),
            _ => ErrorKind::BadInput,
        }
    }
}

/// An absolute UTC instant with nanosecond resolution (SHDR timestamps carry up to 7 decimals,
/// more than an `f64` of Unix seconds keeps).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Timestamp {
    /// Whole seconds since 1970-01-01T00:00:00Z.
    pub unix_s: i64,
    /// Nanoseconds within the second, `0..1_000_000_000`.
    pub nanos: u32,
}

impl Timestamp {
    /// Parse ISO-8601 `YYYY-MM-DDTHH:MM:SS[.f…][Z|±HH:MM|±HHMM]`. Without a zone the time is
    /// taken as UTC (MTConnect timestamps are UTC). A space is accepted for the `T`.
    ///
    /// # Errors
    /// A short reason when the text is not such a timestamp.
    pub fn parse(text: &str) -> Result<Self, &'static str> {
        let b = text.as_bytes();
        if b.len() < 19 {
            return Err("too short for YYYY-MM-DDTHH:MM:SS");
        }
        let num = |r: std::ops::Range<usize>| -> Result<i64, &'static str> {
            let s = &b[r];
            if s.iter().all(u8::is_ascii_digit) {
                Ok(s.iter().fold(0i64, |a, &d| a * 10 + i64::from(d - b'0')))
            } else {
                Err("expected digits in YYYY-MM-DDTHH:MM:SS")
            }
        };
        if b[4] != b'-' || b[7] != b'-' || !(b[10] == b'T' || b[10] == b' ') {
            return Err("expected YYYY-MM-DDTHH:MM:SS");
        }
        if b[13] != b':' || b[16] != b':' {
            return Err("expected YYYY-MM-DDTHH:MM:SS");
        }
        let (y, mo, d) = (num(0..4)?, num(5..7)?, num(8..10)?);
        let (h, mi, s) = (num(11..13)?, num(14..16)?, num(17..19)?);
        if !(1..=12).contains(&mo) || d < 1 || d > days_in_month(y, mo) {
            return Err("date out of range");
        }
        // 60 allows a leap second.
        if h > 23 || mi > 59 || s > 60 {
            return Err("time of day out of range");
        }
        let mut i = 19;
        let mut nanos = 0u32;
        if i < b.len() && b[i] == b'.' {
            i += 1;
            let start = i;
            let mut scale = 100_000_000u32;
            while i < b.len() && b[i].is_ascii_digit() {
                // Digits beyond nanoseconds are dropped (truncation, < 1 ns).
                nanos += u32::from(b[i] - b'0') * scale;
                scale /= 10;
                i += 1;
            }
            if i == start {
                return Err("no digits after the decimal point");
            }
        }
        let mut offset_s = 0i64;
        match b.get(i) {
            None => {}
            Some(b'Z') | Some(b'z') if i + 1 == b.len() => {}
            Some(&c @ (b'+' | b'-')) => {
                let z = &text[i + 1..];
                let (hh, mm) = match z.len() {
                    5 if z.as_bytes()[2] == b':' => (&z[0..2], &z[3..5]),
                    4 => (&z[0..2], &z[2..4]),
                    2 => (&z[0..2], "00"),
                    _ => return Err("bad zone offset (use Z, ±HH:MM or ±HHMM)"),
                };
                let p = |s: &str| s.parse::<i64>().map_err(|_| "bad zone offset");
                let (hh, mm) = (p(hh)?, p(mm)?);
                if hh > 23 || mm > 59 {
                    return Err("zone offset out of range");
                }
                offset_s = (hh * 3600 + mm * 60) * if c == b'+' { 1 } else { -1 };
            }
            Some(_) => return Err("unexpected text after the time"),
        }
        let days = days_from_civil(y, mo, d);
        let unix_s = days * 86_400 + h * 3600 + mi * 60 + s - offset_s;
        Ok(Self { unix_s, nanos })
    }

    /// Seconds from `origin` to `self` (negative when `self` is earlier), exact to 1 ns for
    /// spans up to about 100 days (f64 keeps 15-16 digits).
    pub fn seconds_since(&self, origin: &Self) -> f64 {
        (self.unix_s - origin.unix_s) as f64
            + (f64::from(self.nanos) - f64::from(origin.nanos)) * 1e-9
    }
}

impl std::fmt::Display for Timestamp {
    /// ISO-8601 UTC, fraction trimmed of trailing zeros, `Z` suffix.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let days = self.unix_s.div_euclid(86_400);
        let sod = self.unix_s.rem_euclid(86_400);
        let (y, m, d) = civil_from_days(days);
        write!(
            f,
            "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}",
            sod / 3600,
            sod / 60 % 60,
            sod % 60
        )?;
        if self.nanos != 0 {
            let frac = format!("{:09}", self.nanos);
            write!(f, ".{}", frac.trim_end_matches('0'))?;
        }
        f.write_str("Z")
    }
}

/// Line endings seen in a text file (counts of each kind).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LineEndings {
    /// `\n` alone.
    pub lf: u64,
    /// `\r\n`.
    pub crlf: u64,
    /// `\r` alone (classic Mac OS; one UMich file uses it).
    pub cr: u64,
}

impl LineEndings {
    /// A short name of the ending(s) found: `LF`, `CRLF`, `CR`, `mixed` or `none`.
    pub fn describe(&self) -> &'static str {
        match (self.lf > 0, self.crlf > 0, self.cr > 0) {
            (false, false, false) => "none",
            (true, false, false) => "LF",
            (false, true, false) => "CRLF",
            (false, false, true) => "CR",
            _ => "mixed",
        }
    }
}

/// Split text into lines ending in LF, CRLF or a bare CR; yields (1-based line number, line
/// without its ending) and counts the endings.
pub(crate) fn split_lines<'a>(
    text: &'a str,
    endings: &'a mut LineEndings,
) -> impl Iterator<Item = (u64, &'a str)> + 'a {
    let b = text.as_bytes();
    let mut pos = 0usize;
    let mut line = 0u64;
    std::iter::from_fn(move || {
        if pos >= b.len() {
            return None;
        }
        let start = pos;
        match memchr::memchr2(b'\n', b'\r', &b[pos..]) {
            Some(k) => {
                let end = pos + k;
                if b[end] == b'\n' {
                    endings.lf += 1;
                    pos = end + 1;
                } else if b.get(end + 1) == Some(&b'\n') {
                    endings.crlf += 1;
                    pos = end + 2;
                } else {
                    endings.cr += 1;
                    pos = end + 1;
                }
                line += 1;
                Some((line, &text[start..end]))
            }
            None => {
                pos = b.len();
                line += 1;
                Some((line, &text[start..]))
            }
        }
    })
}

/// Read a file as text, replacing invalid UTF-8 and dropping a byte-order mark.
pub(crate) fn read_text(path: &std::path::Path) -> Result<String, ImportError> {
    let bytes = crate::bounded::read(path, crate::bounded::MAX_DATA_BYTES).map_err(|error| {
        ImportError::Io {
            source_name: path.display().to_string(),
            error,
        }
    })?;
    let text = match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
    };
    Ok(match text.strip_prefix('\u{feff}') {
        Some(s) => s.to_string(),
        None => text,
    })
}

/// Shorten text for an error message (at most 60 characters).
pub(crate) fn shorten(s: &str) -> String {
    match s.char_indices().nth(60) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_string(),
    }
}

/// How one channel of an imported trace was built.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ChannelReport {
    /// Where it came from: the SHDR data item key or the CSV column.
    pub source_key: String,
    /// Samples in the trace.
    pub samples: usize,
    /// Samples that repeated the previous sample's timestamp; the later value was kept.
    pub repeated_times: usize,
    /// `UNAVAILABLE` observations (gaps: no sample written).
    pub unavailable: usize,
    /// Samples earlier than an earlier-written sample of the channel (the log is pieced
    /// together from several recordings, or a poll was stamped late); put into time order.
    pub reordered: usize,
    /// Samples of different recordings alternate in time (recordings overlap, not just
    /// follow each other).
    pub interleaved: bool,
    /// Median interval between samples (s); `NaN` with fewer than two samples.
    pub median_interval_s: f64,
    /// First and last sample time (s).
    pub span_s: (f64, f64),
}

impl ChannelReport {
    /// Fill `samples`, `median_interval_s` and `span_s` from the channel.
    fn finish(&mut self, ch: &feedscope::trace::Channel) {
        self.samples = ch.len();
        self.span_s = match (ch.time_s.first(), ch.time_s.last()) {
            (Some(&a), Some(&b)) => (a, b),
            _ => (f64::NAN, f64::NAN),
        };
        let mut dt: Vec<f64> = ch.time_s.windows(2).map(|w| w[1] - w[0]).collect();
        self.median_interval_s = if dt.is_empty() {
            f64::NAN
        } else {
            dt.sort_by(f64::total_cmp);
            dt[dt.len() / 2]
        };
    }
}

/// What an import did: sources, counts and warnings a user should read.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ImportReport {
    /// The input file.
    pub source_name: String,
    /// Absolute instant of time 0 of the trace (SHDR); `None` when the source has no clock
    /// (UMich rows). Serialised as its RFC 3339 text.
    #[serde(serialize_with = "timestamp_text")]
    pub time_zero: Option<Timestamp>,
    /// How time 0 was chosen, in words.
    pub time_zero_rule: String,
    /// The position channel.
    pub position: ChannelReport,
    /// The effort channel.
    pub effort: ChannelReport,
    /// How the effort was obtained, in words (e.g. `Z1load (%) × 0.2 N·m/%`).
    pub effort_rule: String,
    /// Things to know before estimating from this trace, each with a stable code.
    pub warnings: Vec<feedscope::diag::Diagnostic>,
}

impl ImportReport {
    /// The `#` comment lines written above the CSV (each without its newline).
    pub fn comment_lines(&self) -> Vec<String> {
        let mut v = vec![format!(
            "# feedscope import from {}",
            self.source_name.replace(['\n', '\r'], " ")
        )];
        match &self.time_zero {
            Some(t) => v.push(format!("# time zero: {t} ({})", self.time_zero_rule)),
            None => v.push(format!("# time zero: {}", self.time_zero_rule)),
        }
        v.push(format!("# position: {}", self.position.source_key));
        v.push(format!("# effort: {}", self.effort_rule));
        v
    }
}

/// A timestamp as the text it prints (RFC 3339), for the report's serde form.
fn timestamp_text<S: serde::Serializer>(t: &Option<Timestamp>, s: S) -> Result<S::Ok, S::Error> {
    match t {
        Some(t) => s.collect_str(t),
        None => s.serialize_none(),
    }
}

/// A converted trace and how it was made.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The trace (SI units).
    pub trace: Trace,
    /// Counts and warnings.
    pub report: ImportReport,
}

/// Write an imported trace as feedscope CSV: the report's `#` comment lines, then the long
/// layout (`time_s,channel,value`), which keeps asynchronous channels apart.
///
/// # Errors
/// I/O errors of the writer.
pub fn write_trace_csv<W: Write>(imported: &Imported, mut w: W) -> std::io::Result<()> {
    for line in imported.report.comment_lines() {
        writeln!(w, "{line}")?;
    }
    write_csv(&imported.trace, w, Layout::Long)
}

/// Refuse a trace whose position never moves or whose effort is one constant value (zero in
/// every row is the common case: an axis whose current the controller does not report).
///
/// # Errors
/// [`ImportError::NoInformation`] naming the channel and its source.
// Exact equality is the point: one value repeated bit for bit is a channel that never changed.
#[allow(clippy::float_cmp)]
pub fn check_informative(imported: &Imported) -> Result<(), ImportError> {
    let no_info =
        |channel: &ChannelReport, column: &str, what: String| ImportError::NoInformation {
            source_name: imported.report.source_name.clone(),
            channel: format!("{column} (from {})", channel.source_key),
            what,
        };
    let t = &imported.trace;
    if let Some(&p0) = t.position_m.value.first() {
        if t.position_m.value.iter().all(|&p| p == p0) {
            return Err(no_info(
                &imported.report.position,
                "position_mm",
                format!(
                    "never moves (all {} samples are {} mm)",
                    t.position_m.len(),
                    p0 * 1e3
                ),
            ));
        }
    }
    if let Some(&e0) = t.effort.value.first() {
        if t.effort.value.iter().all(|&e| e == e0) {
            return Err(no_info(
                &imported.report.effort,
                t.effort_kind.column(),
                format!("is {e0} in all {} samples", t.effort.len()),
            ));
        }
    }
    Ok(())
}

/// Rough warnings common to every source: quantisation, sampling resolution, no motion.
fn sampling_warnings(report: &mut ImportReport, trace: &Trace) {
    let p = &trace.position_m.value;
    let (lo, hi) = p
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    if p.is_empty() || hi - lo <= 0.0 {
        report.warnings.push(feedscope::diag::Diagnostic::new(
            feedscope::diag::Code::PositionNeverMoves,
            "the position never moves in this trace; `feedscope estimate` needs strokes",
        ));
    }
    if trace.effort.value.iter().all(|&v| v == 0.0) {
        report.warnings.push(feedscope::diag::Diagnostic::new(
            feedscope::diag::Code::EffortAllZero,
            format!(
                "the effort ({}) is zero in every sample: nothing to estimate friction from",
                report.effort.source_key
            ),
        ));
    }
    let dt = report
        .position
        .median_interval_s
        .max(report.effort.median_interval_s);
    if dt.is_finite() && dt > 0.0 {
        // Nyquist: a sampling interval dt resolves frequencies below 1/(2 dt); in screw
        // orders at feed v and lead p that is order < p / (2 v dt).
        report.warnings.push(feedscope::diag::Diagnostic::new(
            feedscope::diag::Code::SlowSampling,
            format!(
                "median sampling interval {dt:.3} s resolves only frequencies below {:.2} Hz \
             (screw orders below lead / (2 × feed × {dt:.3} s)): mean friction per stroke, \
             not its ripple",
                0.5 / dt
            ),
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamps_with_and_without_fraction_and_zone() {
        let a = Timestamp::parse("2022-08-08T13:51:34.7167146Z").unwrap();
        let b = Timestamp::parse("2022-08-08T13:51:34Z").unwrap();
        let c = Timestamp::parse("2022-08-08T13:51:34").unwrap();
        let d = Timestamp::parse("2022-08-08T15:51:34+02:00").unwrap();
        assert_eq!(b, c);
        assert_eq!(b, d);
        assert_eq!(a.unix_s, b.unix_s);
        assert_eq!(a.nanos, 716_714_600);
        // 1660 M s since the epoch: checked with `date -u -d 2022-08-08T13:51:34Z +%s`.
        assert_eq!(b.unix_s, 1_659_966_694);
        assert_eq!(a.to_string(), "2022-08-08T13:51:34.7167146Z");
        assert_eq!(b.to_string(), "2022-08-08T13:51:34Z");
        // Exact to the nanosecond: 0.7167146 s is stored as 716_714_600 ns.
        assert!((a.seconds_since(&b) - 0.7167146).abs() < 1e-12);
        let leap = Timestamp::parse("2016-02-29T00:00:00Z").unwrap();
        assert_eq!(leap.to_string(), "2016-02-29T00:00:00Z");
    }

    #[test]
    fn bad_timestamps_are_refused() {
        for t in [
            "",
            "2022-08-08",
            "2022-08-08T13:51",
            "2022-13-08T13:51:34Z",
            "2022-02-30T13:51:34Z",
            "2022-08-08T25:51:34Z",
            "2022-08-08T13:51:34.Z",
            "2022-08-08T13:51:34Zjunk",
            "X1actm",
            "20a2-08-08T13:51:34Z",
        ] {
            assert!(Timestamp::parse(t).is_err(), "{t:?} accepted");
        }
    }

    #[test]
    fn line_endings_lf_crlf_cr() {
        let mut e = LineEndings::default();
        let v: Vec<_> = split_lines("a\nb\r\nc\rd", &mut e).collect();
        assert_eq!(v, vec![(1, "a"), (2, "b"), (3, "c"), (4, "d")]);
        assert_eq!((e.lf, e.crlf, e.cr), (1, 1, 1));
        assert_eq!(e.describe(), "mixed");
        let mut e = LineEndings::default();
        assert_eq!(split_lines("a\rb\r", &mut e).count(), 2);
        assert_eq!(e.describe(), "CR");
    }
}
