//! TwinCAT 3 Scope exports (Scope View → Export → CSV/TXT).
//!
//! # The file
//! A semicolon export (tab is the exporter's default):
//! ```text
//! Name;tc3_scope
//! File;C:\scope\axis_test.csv
//! Starttime of export;132959733843760000;Montag, 2. Mai 2022;15:56:24.376
//! Endtime of export;132959733853750000;Montag, 2. Mai 2022;15:56:25.375
//!
//!
//! Name;Axis_X.ActPos;Name;Axis_X.ActTorque
//! SampleTime[ms];1;SampleTime[ms];1
//! …;(Data-Type, SymbolName, NetID, Port, Offset, ScaleFactor, BitMask, …)
//! Unit;mm (Length);Unit;Nm (Torque)
//!
//! 0;12,5;0;0,84
//! 1;12,5001;1;0,85
//! ```
//! A block of `key<sep>value` lines for the file (the start and end of the export as Windows
//! FILETIME: 100 ns ticks since 1601-01-01 UTC, then the local date and time as text), a
//! blank line, then one header row per key with a `key<sep>value` pair per channel, a blank
//! line, and the data: per channel a time column (ms from the start) and a value column.
//! With "exclude double timestamps" the channels that share a sample time share one time
//! column (`Name;a;b;Name;c`): a key cell opens each time column in every header row.
//!
//! # What is read, and how
//! - **Separator** (tab, space, `:`, `;` or `,`) from the first line: the character after
//!   `Name`. Quoted fields (`"Starttime of export"`) are unquoted.
//! - **Decimal mark** `.` or `,`, as the export's option chose; one file holds one mark in its
//!   data (a number with both, or a file that mixes them, is refused: thousands separators are
//!   not read). With `,` as separator a decimal comma splits numbers into two fields; the rows
//!   then have more fields than the header and the file is refused with that reason. The
//!   header's own numbers are written with the PC's decimal mark whatever the option; a header
//!   row that does not line up with the channel names is not used, and the listing says so.
//! - **Channels** by name (or `SymbolName`); position and effort are found by their `Unit`
//!   (`mm (Length)` → mm; `A`, `mA`, `Nm`) or by name (`…ActPos…`; `…ActTorque…`,
//!   `…Current…`) when exactly one channel fits each, else named with
//!   [`TwincatParams::position`] and [`TwincatParams::effort`]. Units from the `Unit` row or a
//!   flag.
//! - **Values** as exported. TwinCAT Scope applies `ScaleFactor`/`Offset` and the unit scaling
//!   when it exports (the default); a channel that declares a scaling gets a warning, since an
//!   export without "scale values" would hold raw numbers.
//! - **Samples.** A blank cell (`" "`) or a row that ends before the channel's columns is no
//!   sample: channels of different lengths end at different rows. An `EOF` line ends the data.
//!   `time_s` is the time column / 1000, from the start of the export, whose absolute time
//!   (the FILETIME) is kept as time zero.
//!
//! The data is streamed line by line; only the two converted channels are kept.
//!
//! # Example
//! ```
//! use feedscope_io::import::twincat::{parse_twincat, TwincatParams};
//!
//! let csv = "Name;scope\nFile;x.csv\n\
//!     Starttime of export;132959733843760000;Montag, 2. Mai 2022;15:56:24.376\n\n\
//!     Name;Axis_Z.ActPos;Name;Axis_Z.ActCurrent\n\
//!     SampleTime[ms];1;SampleTime[ms];1\n\
//!     Unit;mm (Length);Unit;A (Current)\n\n\
//!     0;10,000;0;1,25\n1;10,001;1;1,27\n2;10,002;2;1,26\n3;10,003;3;1,28\n";
//! let imp = parse_twincat(csv.as_bytes(), "scope.csv", &TwincatParams::default())?;
//! // The FILETIME is UTC; the text beside it is the PC's local time (CEST).
//! let t0 = imp.imported.report.time_zero.unwrap();
//! assert_eq!(t0.to_string(), "2022-05-02T13:56:24.376Z");
//! let t = &imp.imported.trace;
//! assert!((t.position_m.value[3] - 0.010003).abs() < 1e-15); // decimal comma, mm → m
//! assert!((t.effort.time_s[2] - 0.002).abs() < 1e-15); // ms → s
//! # Ok::<(), feedscope_io::import::ImportError>(())
//! ```
//!
//! # Errors
//! Exit-2 errors name the file and line (and the channel): a first line that is not `Name`,
//! no channel header, a data row with more fields than the header (decimal-comma confusion), a
//! cell that is not a number, NaN or infinite, mixed decimal marks, a time without a value or a
//! value without a time, time not increasing within a channel, a value beyond the limits of
//! [`super::units`], an unknown channel (with the list), a converted channel with fewer than 4
//! samples, a last line cut short.
use std::borrow::Cow;
use std::io::{BufRead, BufReader, Write};
use std::path::Path;

use super::units::{self, EffortUnit, PositionUnit};
use super::{shorten, ChannelReport, ImportError, ImportReport, Imported, Timestamp};
use feedscope::diag::{Code, Diagnostic};
use feedscope::trace::{Channel, EffortKind, RecordingFacts, Trace, MIN_SAMPLES};

/// Seconds from 1601-01-01 (the FILETIME epoch) to 1970-01-01.
const FILETIME_UNIX_OFFSET_S: i64 = 11_644_473_600;

/// A Windows FILETIME (100 ns ticks since 1601-01-01 UTC) as a [`Timestamp`].
pub fn filetime_to_timestamp(ticks: u64) -> Timestamp {
    let s = (ticks / 10_000_000) as i64 - FILETIME_UNIX_OFFSET_S;
    Timestamp {
        unix_s: s,
        nanos: (ticks % 10_000_000) as u32 * 100,
    }
}

/// A [`Timestamp`] as a FILETIME (`None` before 1601).
pub fn timestamp_to_filetime(t: Timestamp) -> Option<u64> {
    let s = u64::try_from(t.unix_s + FILETIME_UNIX_OFFSET_S).ok()?;
    Some(s * 10_000_000 + u64::from(t.nanos / 100))
}

/// One channel of the header.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScopeChannel {
    /// Its `Name`.
    pub name: String,
    /// 0-based column of its time.
    pub time_col: usize,
    /// 0-based column of its values.
    pub value_col: usize,
    /// Every header row's text for this channel, `(key, value)`, in file order.
    pub header: Vec<(String, String)>,
}

impl ScopeChannel {
    /// The header text of `key` (`Unit`, `SampleTime[ms]`, …), `None` when absent or empty.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.header
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
            .filter(|v| !v.is_empty())
    }

    /// The unit symbol of the `Unit` row (`mm` of `mm (Length)`), `None` for `(None)`.
    pub fn unit_symbol(&self) -> Option<&str> {
        self.get("Unit").and_then(units::unit_symbol)
    }

    /// A header number (either decimal mark).
    fn number(&self, key: &str) -> Option<f64> {
        self.get(key)
            .and_then(|s| s.replace(',', ".").parse::<f64>().ok())
    }

    /// `SampleTime[ms]`.
    pub fn sample_time_ms(&self) -> Option<f64> {
        self.number("SampleTime[ms]")
    }

    /// The declared scalings that are not the identity, as `ScaleFactor -1, Offset 1`.
    pub fn scaling(&self) -> Option<String> {
        let v: Vec<String> = [
            ("ScaleFactor", 1.0),
            ("Offset", 0.0),
            ("Unit ScaleFactor", 1.0),
            ("Unit Offset", 0.0),
        ]
        .into_iter()
        .filter_map(|(k, identity)| {
            let x = self.number(k)?;
            ((x - identity).abs() > 0.0).then(|| format!("{k} {}", self.get(k).unwrap_or("")))
        })
        .collect();
        (!v.is_empty()).then(|| v.join(", "))
    }

    fn lower_names(&self) -> String {
        format!("{} {}", self.name, self.get("SymbolName").unwrap_or("")).to_ascii_lowercase()
    }

    /// A length unit, or no unit and a name with `ActPos` (not a set value).
    pub fn may_be_position(&self) -> bool {
        match self.unit_symbol() {
            Some(u) => PositionUnit::from_symbol(u).is_some(),
            None => {
                let n = self.lower_names();
                n.contains("actpos") && !n.contains("set")
            }
        }
    }

    /// A current or torque unit, or no unit and a name with `Torque` or `Current`.
    pub fn may_be_effort(&self) -> bool {
        match self.unit_symbol() {
            Some(u) => EffortUnit::from_symbol(u).is_some(),
            None => {
                let n = self.lower_names();
                ["torque", "current"].iter().any(|w| n.contains(w))
            }
        }
    }

    fn is_named(&self, wanted: &str) -> bool {
        self.name == wanted
            || self.get("SymbolName") == Some(wanted)
            || self.name.eq_ignore_ascii_case(wanted)
    }
}

/// The header of an export.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScopeHeader {
    /// The file.
    pub source_name: String,
    /// The scope's `Name`.
    pub scope_name: Option<String>,
    /// `Starttime of export` (FILETIME).
    pub start: Option<Timestamp>,
    /// `Endtime of export` (FILETIME).
    pub end: Option<Timestamp>,
    /// The field separator.
    pub separator: char,
    /// Fields of the channel `Name` row.
    pub columns: usize,
    /// The channels, in header order.
    pub channels: Vec<ScopeChannel>,
    /// Header rows that could not be used, and why.
    pub notes: Vec<String>,
    /// 1-based line of the channel `Name` row.
    pub header_line: u64,
}

impl ScopeHeader {
    /// Whether channels share time columns ("exclude double timestamps").
    pub fn shared_time(&self) -> bool {
        let mut t: Vec<usize> = self.channels.iter().map(|c| c.time_col).collect();
        t.dedup();
        t.len() < self.channels.len()
    }

    /// Separator as a word for people.
    pub fn separator_name(&self) -> &'static str {
        match self.separator {
            '\t' => "tab",
            ' ' => "space",
            ':' => "colon",
            ';' => "semicolon",
            ',' => "comma",
            _ => "other",
        }
    }

    /// The channels converted by default: the only one that may be the position, the only
    /// one that may be the effort (`None` where none or several fit).
    pub fn default_channels(&self) -> (Option<usize>, Option<usize>) {
        let only = |fits: fn(&ScopeChannel) -> bool| {
            let v: Vec<usize> = (0..self.channels.len())
                .filter(|&k| fits(&self.channels[k]))
                .collect();
            (v.len() == 1).then(|| v[0])
        };
        (
            only(ScopeChannel::may_be_position),
            only(ScopeChannel::may_be_effort),
        )
    }

    fn channel_list(&self) -> String {
        self.channels
            .iter()
            .map(|c| match c.get("Unit") {
                Some(u) => format!("{} [{u}]", c.name),
                None => c.name.clone(),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Counts of one channel's data.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChannelCounts {
    /// Samples.
    pub samples: u64,
    /// First and last time (s).
    pub span_s: Option<(f64, f64)>,
    /// Smallest and largest value (file unit).
    pub range: Option<(f64, f64)>,
}

/// Header and counts of an export (`feedscope import twincat --list`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TwincatListing {
    /// The header.
    pub header: ScopeHeader,
    /// Per channel, same order as the header's.
    pub counts: Vec<ChannelCounts>,
    /// Data rows.
    pub rows: u64,
    /// The decimal mark of the data (`None` when no number had a fraction).
    pub decimal: Option<char>,
    /// Whether the data ended with an `EOF` line.
    pub eof_marker: bool,
}

/// Options of [`read_twincat`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TwincatParams {
    /// Position channel by `Name` or `SymbolName` [default: the only channel with a length
    /// unit, or named `…ActPos…`].
    pub position: Option<String>,
    /// Effort channel [default: the only channel with a current or torque unit, or named
    /// `…ActTorque…`, `…Current…`].
    pub effort: Option<String>,
    /// Unit of the position values [default: its `Unit` row].
    pub position_unit: Option<PositionUnit>,
    /// Unit of the effort values [default: its `Unit` row].
    pub effort_unit: Option<EffortUnit>,
}

/// A converted trace with its channels.
#[derive(Debug, Clone)]
pub struct TwincatImport {
    /// Trace and report.
    pub imported: Imported,
    /// The position channel.
    pub position: ScopeChannel,
    /// The effort channel.
    pub effort: ScopeChannel,
    /// Header and counts (counts of the two converted channels only).
    pub listing: TwincatListing,
}

// ---------------------------------------------------------------------------------------------
// Lines and fields.

/// A line reader: LF or CRLF endings, a UTF-8 BOM dropped, invalid UTF-8 replaced; remembers
/// whether the last line ended with a line break.
struct Lines<R> {
    r: R,
    buf: Vec<u8>,
    /// The current line, without its ending.
    text: String,
    line: u64,
    last_ended: bool,
}

impl<R: BufRead> Lines<R> {
    fn new(r: R) -> Self {
        Self {
            r,
            buf: Vec::new(),
            text: String::new(),
            line: 0,
            last_ended: true,
        }
    }

    /// Read the next line into `text`; false at the end of the file.
    fn next(&mut self) -> std::io::Result<bool> {
        self.buf.clear();
        let n = self.r.read_until(b'\n', &mut self.buf)?;
        if n == 0 {
            return Ok(false);
        }
        self.line += 1;
        self.last_ended = self.buf.last() == Some(&b'\n');
        let mut b = &self.buf[..];
        if self.last_ended {
            b = &b[..b.len() - 1];
        }
        if b.last() == Some(&b'\r') {
            b = &b[..b.len() - 1];
        }
        if self.line == 1 {
            b = b.strip_prefix(&[0xEF, 0xBB, 0xBF]).unwrap_or(b);
        }
        self.text.clear();
        self.text.push_str(&String::from_utf8_lossy(b));
        Ok(true)
    }
}

/// Split a line at `sep`; `"…"` fields unquoted (`""` is a quote); fields trimmed unless the
/// separator is a space.
fn split_fields(line: &str, sep: char) -> Vec<Cow<'_, str>> {
    fn trim(s: &str, sep: char) -> &str {
        if sep == ' ' {
            s
        } else {
            s.trim()
        }
    }
    if !line.contains('"') {
        return line
            .split(sep)
            .map(|f| Cow::Borrowed(trim(f, sep)))
            .collect();
    }
    let mut out = Vec::new();
    let mut rest = line;
    loop {
        let t = if sep == ' ' { rest } else { rest.trim_start() };
        if let Some(q) = t.strip_prefix('"') {
            let mut s = String::new();
            let mut chars = q.char_indices().peekable();
            let mut end = q.len();
            while let Some((k, c)) = chars.next() {
                if c == '"' {
                    if let Some(&(_, '"')) = chars.peek() {
                        s.push('"');
                        chars.next();
                        continue;
                    }
                    end = k + 1;
                    break;
                }
                s.push(c);
            }
            out.push(Cow::Owned(s));
            let after = &q[end.min(q.len())..];
            match after.find(sep) {
                Some(k) => rest = &after[k + sep.len_utf8()..],
                None => break,
            }
        } else {
            match rest.find(sep) {
                Some(k) => {
                    out.push(Cow::Borrowed(trim(&rest[..k], sep)));
                    rest = &rest[k + sep.len_utf8()..];
                }
                None => {
                    out.push(Cow::Borrowed(trim(rest, sep)));
                    break;
                }
            }
        }
    }
    out
}

/// Parse the header: everything up to the first data row.
fn parse_header<R: BufRead>(
    lines: &mut Lines<R>,
    source: &str,
) -> Result<ScopeHeader, ImportError> {
    let io = |error| ImportError::Io {
        source_name: source.to_string(),
        error,
    };
    let bad = |line: u64, reason: String| ImportError::Malformed {
        source_name: source.to_string(),
        line,
        reason,
    };
    if !lines.next().map_err(io)? {
        return Err(ImportError::Empty {
            source_name: source.to_string(),
        });
    }
    let first = lines.text.clone();
    // The separator is the character after the leading `Name` (or `"Name"`).
    let rest = first
        .strip_prefix("\"Name\"")
        .or_else(|| first.strip_prefix("Name"));
    let sep = rest.and_then(|r| r.chars().next());
    let Some(sep @ ('\t' | ' ' | ':' | ';' | ',')) = sep else {
        return Err(bad(
            1,
            format!(
                "`{}` is not the first line of a TwinCAT Scope export (expected `Name` and a \
                 separator: tab, space, colon, semicolon or comma)",
                shorten(&first)
            ),
        ));
    };
    let mut h = ScopeHeader {
        source_name: source.to_string(),
        separator: sep,
        ..Default::default()
    };
    h.scope_name = split_fields(&first, sep)
        .get(1)
        .map(|s| s.to_string())
        .filter(|s| !s.is_empty());
    // File block: key/value lines until the channel `Name` row.
    let names: Vec<String> = loop {
        if !lines.next().map_err(io)? {
            return Err(bad(
                lines.line,
                "the file ends before the channel header (a `Name` row with the channel \
                 names): no channels"
                    .into(),
            ));
        }
        let f = split_fields(&lines.text, sep);
        match f.first().map(|s| s.as_ref()) {
            Some("Name") => break f.iter().map(|s| s.to_string()).collect(),
            Some(k @ ("Starttime of export" | "Endtime of export")) => {
                let t = f.get(1).and_then(|s| s.trim().parse::<u64>().ok());
                match t {
                    Some(ticks) => {
                        let ts = Some(filetime_to_timestamp(ticks));
                        if k.starts_with("Start") {
                            h.start = ts;
                        } else {
                            h.end = ts;
                        }
                    }
                    None => h.notes.push(format!(
                        "line {}: `{k}` has no FILETIME (`{}`): time zero unknown",
                        lines.line,
                        shorten(f.get(1).map_or("", |s| s.as_ref()))
                    )),
                }
            }
            _ => {}
        }
    };
    h.header_line = lines.line;
    // Drop trailing empty fields (a trailing separator).
    let mut names = names;
    while names.len() > 1 && names.last().is_some_and(|s| s.is_empty()) {
        names.pop();
    }
    let time_cols: Vec<usize> = (0..names.len()).filter(|&p| names[p] == "Name").collect();
    for (p, name) in names.iter().enumerate().skip(1) {
        if name == "Name" {
            continue;
        }
        let time_col = *time_cols
            .iter()
            .rev()
            .find(|&&t| t < p)
            .expect("column 0 is a key");
        h.channels.push(ScopeChannel {
            name: name.clone(),
            time_col,
            value_col: p,
            header: Vec::new(),
        });
    }
    if h.channels.is_empty() {
        return Err(bad(
            h.header_line,
            "the channel `Name` row names no channel".into(),
        ));
    }
    h.columns = names.len();
    // Key rows until a blank line.
    loop {
        if !lines.next().map_err(io)? {
            return Err(bad(
                lines.line,
                "the file ends in the channel header: no data".into(),
            ));
        }
        if lines.text.trim().is_empty() {
            break;
        }
        let f = split_fields(&lines.text, sep);
        let key = f[0].to_string();
        let mut len = f.len();
        while len > 1 && f[len - 1].is_empty() {
            len -= 1;
        }
        let aligned = len <= h.columns
            && time_cols
                .iter()
                .all(|&p| p >= len || f[p].as_ref() == key.as_str());
        if !aligned {
            h.notes.push(format!(
                "line {}: header row `{key}` does not line up with the channel names ({len} \
                 fields for {} columns{}): not used",
                lines.line,
                h.columns,
                if sep == ',' {
                    "; a decimal comma with ',' as separator?"
                } else {
                    ""
                }
            ));
            continue;
        }
        for c in &mut h.channels {
            let v = f.get(c.value_col).map_or("", |s| s.as_ref()).to_string();
            c.header.push((key.clone(), v));
        }
    }
    Ok(h)
}

/// How a number's decimal mark is checked across the data.
#[derive(Debug, Default)]
struct Marks {
    seen: Option<(char, u64)>,
}

impl Marks {
    /// Parse a data cell; the reason when it is not a finite number.
    fn parse(&mut self, cell: &str, sep: char, line: u64) -> Result<f64, String> {
        let has_point = cell.contains('.');
        let has_comma = sep != ',' && cell.contains(',');
        let text: Cow<'_, str> = match (has_point, has_comma) {
            (true, true) => {
                return Err(format!(
                    "`{}` has both '.' and ',': thousands separators are not read",
                    shorten(cell)
                ))
            }
            (false, true) => Cow::Owned(cell.replacen(',', ".", 1)),
            _ => Cow::Borrowed(cell),
        };
        let mark = if has_comma {
            Some(',')
        } else if has_point {
            Some('.')
        } else {
            None
        };
        let v: f64 = text
            .parse()
            .map_err(|_| format!("`{}` is not a number", shorten(cell)))?;
        if !v.is_finite() {
            return Err(format!("`{}` is not finite", shorten(cell)));
        }
        if let Some(m) = mark {
            match self.seen {
                None => self.seen = Some((m, line)),
                Some((s, l)) if s != m => {
                    return Err(format!(
                        "`{}` uses '{m}' as decimal mark, line {l} used '{s}': decimal-comma \
                         confusion (one export has one mark)",
                        shorten(cell)
                    ))
                }
                _ => {}
            }
        }
        Ok(v)
    }
}

/// A kept channel's file-unit value to SI, checked against the limits (the reason when not).
type Convert<'a> = Box<dyn FnMut(f64) -> Result<f64, String> + 'a>;

/// What the data pass does with the samples of each channel.
struct DataPass<'a> {
    source: &'a str,
    header: &'a ScopeHeader,
    /// Channels read (indices into the header's).
    wanted: Vec<usize>,
    /// Per wanted channel: file-unit values → checked SI samples (or counts only).
    keep: Vec<Option<Convert<'a>>>,
    channels: Vec<Channel>,
    counts: Vec<ChannelCounts>,
    rows: u64,
    marks: Marks,
    eof_marker: bool,
    /// Non-empty cells of the previous data row.
    prev_fields: usize,
}

impl DataPass<'_> {
    fn run<R: BufRead>(&mut self, lines: &mut Lines<R>) -> Result<(), ImportError> {
        let sep = self.header.separator;
        let source = self.source;
        let bad = |line: u64, reason: String| ImportError::Malformed {
            source_name: source.to_string(),
            line,
            reason,
        };
        let io = |error| ImportError::Io {
            source_name: source.to_string(),
            error,
        };
        while lines.next().map_err(io)? {
            let line = lines.line;
            let l = lines.text.as_str();
            if l.trim().is_empty() {
                continue;
            }
            if l.trim() == "EOF" {
                self.eof_marker = true;
                break;
            }
            let f = split_fields(l, sep);
            self.rows += 1;
            if f.len() > self.header.columns {
                return Err(bad(
                    line,
                    format!(
                        "{} fields, the header has {} columns{}",
                        f.len(),
                        self.header.columns,
                        if sep == ',' {
                            ": the export uses ',' as separator and a decimal comma splits \
                             every number in two (decimal-comma confusion); export with the \
                             decimal point or another separator"
                        } else {
                            ""
                        }
                    ),
                ));
            }
            // Row k holds the k-th sample of every channel, so the first row has all columns
            // (trailing channels end early, they never start late). Fewer means the header
            // has more columns than the data: a name or unit split at the separator.
            if self.rows == 1 && f.len() < self.header.columns && lines.last_ended {
                return Err(bad(
                    line,
                    format!(
                        "the first data row has {} fields but the channel header {} columns: \
                         the header does not line up with the data (a channel name holding the \
                         separator{}); export with tab or semicolon as separator",
                        f.len(),
                        self.header.columns,
                        if sep == ' ' {
                            ", e.g. a name or unit with a space"
                        } else {
                            ""
                        }
                    ),
                ));
            }
            let cut = !lines.last_ended;
            // A last line without its line break and with fewer fields than the line before
            // was cut while the file was written or copied (TwinCAT ends every line).
            let n_fields = f.iter().filter(|c| !c.is_empty()).count();
            if cut && n_fields < self.prev_fields {
                return Err(bad(
                    line,
                    format!(
                        "the last line is cut short ({n_fields} cells, the line before has {}, \
                         no line break at the end): truncated file",
                        self.prev_fields
                    ),
                ));
            }
            self.prev_fields = n_fields;
            for k in 0..self.wanted.len() {
                let c = &self.header.channels[self.wanted[k]];
                let cell = |p: usize| f.get(p).map_or("", |s| s.as_ref());
                let (tc, vc) = (cell(c.time_col), cell(c.value_col));
                match (tc.is_empty(), vc.is_empty()) {
                    (true, true) => continue,
                    (false, true) | (true, false) => {
                        let what = if vc.is_empty() {
                            "a time but no value"
                        } else {
                            "a value but no time"
                        };
                        let hint = if cut {
                            " (the last line is cut short: truncated file)"
                        } else {
                            ""
                        };
                        return Err(bad(line, format!("channel `{}` has {what}{hint}", c.name)));
                    }
                    (false, false) => {}
                }
                let t_ms = self
                    .marks
                    .parse(tc, sep, line)
                    .map_err(|r| bad(line, format!("time of channel `{}`: {r}", c.name)))?;
                let v = self
                    .marks
                    .parse(vc, sep, line)
                    .map_err(|r| bad(line, format!("channel `{}`: {r}", c.name)))?;
                let t = t_ms * 1e-3;
                let cnt = &mut self.counts[k];
                if let Some((_, last)) = cnt.span_s {
                    if t <= last {
                        return Err(bad(
                            line,
                            format!(
                                "channel `{}`: time {t_ms} ms is not after the previous \
                                 sample's {} ms: time not increasing",
                                c.name,
                                last * 1e3
                            ),
                        ));
                    }
                }
                cnt.samples += 1;
                cnt.span_s = Some(cnt.span_s.map_or((t, t), |(a, _)| (a, t)));
                cnt.range = Some(cnt.range.map_or((v, v), |(a, b)| (a.min(v), b.max(v))));
                if let Some(conv) = self.keep[k].as_mut() {
                    let si = conv(v).map_err(|r| {
                        bad(line, format!("channel `{}` at {t_ms} ms: {r}", c.name))
                    })?;
                    self.channels[k].time_s.push(t);
                    self.channels[k].value.push(si);
                }
            }
            if cut {
                // A last line without its line break that still parsed: count it, but a file
                // cut inside a number cannot be told from a shorter number.
                break;
            }
        }
        Ok(())
    }
}

fn open(path: &Path, source: &str) -> Result<BufReader<std::fs::File>, ImportError> {
    let f = std::fs::File::open(path).map_err(|error| ImportError::Io {
        source_name: source.to_string(),
        error,
    })?;
    Ok(BufReader::with_capacity(1 << 16, f))
}

/// Read an export for its header and the counts of every channel (`--list`).
///
/// # Errors
/// As [`read_twincat`], without the choice of channels.
pub fn list_twincat(path: &Path) -> Result<TwincatListing, ImportError> {
    let source = path.display().to_string();
    list_twincat_from(open(path, &source)?, &source)
}

/// [`list_twincat`] of an export held in memory or any reader.
///
/// # Errors
/// As [`list_twincat`].
pub fn list_twincat_from<R: BufRead>(
    r: R,
    source_name: &str,
) -> Result<TwincatListing, ImportError> {
    let mut lines = Lines::new(r);
    let header = parse_header(&mut lines, source_name)?;
    let n = header.channels.len();
    let (counts, rows, decimal, eof_marker) = {
        let mut pass = DataPass {
            source: source_name,
            header: &header,
            wanted: (0..n).collect(),
            keep: (0..n).map(|_| None).collect(),
            channels: vec![Channel::default(); n],
            counts: vec![ChannelCounts::default(); n],
            rows: 0,
            marks: Marks::default(),
            eof_marker: false,
            prev_fields: 0,
        };
        pass.run(&mut lines)?;
        (
            pass.counts,
            pass.rows,
            pass.marks.seen.map(|(m, _)| m),
            pass.eof_marker,
        )
    };
    Ok(TwincatListing {
        header,
        counts,
        rows,
        decimal,
        eof_marker,
    })
}

/// Read a TwinCAT Scope export and convert one position and one effort channel.
///
/// # Errors
/// [`ImportError::Io`]; [`ImportError::Empty`]; [`ImportError::Malformed`] naming the line
/// (header, field count, number, time, limits, truncation); [`ImportError::Item`] for an
/// unknown or ambiguous channel (listing the channels) or a unit that is missing or not a
/// length / current / torque; [`ImportError::TooFewSamples`].
pub fn read_twincat(path: &Path, params: &TwincatParams) -> Result<TwincatImport, ImportError> {
    let source = path.display().to_string();
    parse_twincat(open(path, &source)?, &source, params)
}

/// Which channel of the header: named, or the only one that fits.
fn choose(
    h: &ScopeHeader,
    wanted: Option<&str>,
    what: &str,
    flag: &str,
    fits: impl Fn(&ScopeChannel) -> bool,
) -> Result<usize, ImportError> {
    let item = |reason: String| ImportError::Item {
        source_name: h.source_name.clone(),
        axis: what.to_string(),
        reason,
    };
    let hits: Vec<usize> = match wanted {
        Some(w) => (0..h.channels.len())
            .filter(|&k| h.channels[k].is_named(w))
            .collect(),
        None => (0..h.channels.len())
            .filter(|&k| fits(&h.channels[k]))
            .collect(),
    };
    match (hits.as_slice(), wanted) {
        ([k], _) => Ok(*k),
        ([], Some(w)) => Err(item(format!(
            "no channel `{w}`; channels: {}",
            h.channel_list()
        ))),
        ([], None) => Err(item(format!(
            "no channel is recognisably the {what} (by its unit or name); name it with {flag}; \
             channels: {}",
            h.channel_list()
        ))),
        (_, _) => Err(item(format!(
            "{} channels could be the {what} ({}); name one with {flag}",
            hits.len(),
            hits.iter()
                .map(|&k| h.channels[k].name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))),
    }
}

/// [`read_twincat`] of an export held in memory or any reader.
///
/// # Errors
/// As [`read_twincat`].
pub fn parse_twincat<R: BufRead>(
    r: R,
    source_name: &str,
    params: &TwincatParams,
) -> Result<TwincatImport, ImportError> {
    let mut lines = Lines::new(r);
    let h = parse_header(&mut lines, source_name)?;
    let p = choose(
        &h,
        params.position.as_deref(),
        "position",
        "--position",
        ScopeChannel::may_be_position,
    )?;
    let e = choose(
        &h,
        params.effort.as_deref(),
        "effort",
        "--effort",
        ScopeChannel::may_be_effort,
    )?;
    if p == e {
        return Err(ImportError::BadParam(format!(
            "{source_name}: position and effort are the same channel `{}`",
            h.channels[p].name
        )));
    }
    let (pc, ec) = (&h.channels[p], &h.channels[e]);
    let item = |what: &str, reason: String| ImportError::Item {
        source_name: source_name.to_string(),
        axis: what.to_string(),
        reason,
    };
    let mut warnings = Vec::new();
    // Units: the flag, else the Unit row.
    let pu = match (params.position_unit, pc.unit_symbol()) {
        (Some(u), file) => {
            if let Some(f) = file.filter(|f| PositionUnit::from_symbol(f) != Some(u)) {
                warnings.push(Diagnostic::new(
                    Code::UnitOverridden,
                    format!(
                        "channel `{}` declares `{f}`; --position-unit {} was used",
                        pc.name,
                        u.symbol()
                    ),
                ));
            }
            (u, "--position-unit".to_string())
        }
        (None, Some(s)) => match PositionUnit::from_symbol(s) {
            Some(u) => (u, format!("Unit `{}`", pc.get("Unit").unwrap_or(s))),
            None => {
                return Err(item(
                    "position",
                    format!(
                        "channel `{}` has unit `{}`, not a length; give --position-unit if its \
                         values are a position",
                        pc.name,
                        pc.get("Unit").unwrap_or(s)
                    ),
                ))
            }
        },
        (None, None) => {
            return Err(item(
                "position",
                format!(
                    "channel `{}` has no unit (`{}`); give --position-unit mm|um|m|inch",
                    pc.name,
                    pc.get("Unit").unwrap_or("no Unit row")
                ),
            ))
        }
    };
    let eu = match (params.effort_unit, ec.unit_symbol()) {
        (Some(u), file) => {
            if let Some(f) = file.filter(|f| EffortUnit::from_symbol(f) != Some(u)) {
                warnings.push(Diagnostic::new(
                    Code::UnitOverridden,
                    format!(
                        "channel `{}` declares `{f}`; --effort-unit {} was used",
                        ec.name,
                        u.symbol()
                    ),
                ));
            }
            (u, "--effort-unit".to_string())
        }
        (None, Some(s)) => match EffortUnit::from_symbol(s) {
            Some(u) => (u, format!("Unit `{}`", ec.get("Unit").unwrap_or(s))),
            None => {
                return Err(item(
                    "effort",
                    format!(
                        "channel `{}` has unit `{}`, not a current or torque (a percentage \
                         needs the drive's rating); give --effort-unit if its values are one",
                        ec.name,
                        ec.get("Unit").unwrap_or(s)
                    ),
                ))
            }
        },
        (None, None) => {
            return Err(item(
                "effort",
                format!(
                    "channel `{}` has no unit (`{}`); give --effort-unit a|ma|nm",
                    ec.name,
                    ec.get("Unit").unwrap_or("no Unit row")
                ),
            ))
        }
    };
    let (p_unit, e_unit) = (pu.0, eu.0);
    let (position, effort, counts, rows, decimal, eof_marker) = {
        let mut pass = DataPass {
            source: source_name,
            header: &h,
            wanted: vec![p, e],
            keep: vec![
                Some(Box::new(move |v: f64| {
                    let si = v * p_unit.metres();
                    units::check_position(si, p_unit).map(|_| si)
                })),
                Some(Box::new(move |v: f64| {
                    let si = v * e_unit.si();
                    units::check_effort(si, e_unit).map(|_| si)
                })),
            ],
            channels: vec![Channel::default(); 2],
            counts: vec![ChannelCounts::default(); 2],
            rows: 0,
            marks: Marks::default(),
            eof_marker: false,
            prev_fields: 0,
        };
        pass.run(&mut lines)?;
        let mut chans = std::mem::take(&mut pass.channels);
        let effort = chans.pop().expect("two channels");
        let position = chans.pop().expect("two channels");
        (
            position,
            effort,
            std::mem::take(&mut pass.counts),
            pass.rows,
            pass.marks.seen.map(|(m, _)| m),
            pass.eof_marker,
        )
    };
    for (c, ch) in [(pc, &position), (ec, &effort)] {
        if ch.len() < MIN_SAMPLES {
            return Err(ImportError::TooFewSamples {
                source_name: source_name.to_string(),
                channel: c.name.clone(),
                found: ch.len(),
                needed: MIN_SAMPLES,
            });
        }
        if let Some(s) = c.scaling() {
            warnings.push(Diagnostic::new(
                Code::ScaledChannel,
                format!(
                    "channel `{}` declares {s}: its values are taken as exported (TwinCAT \
                     Scope scales them on export by default; an export without \"scale values\" \
                     holds raw numbers)",
                    c.name
                ),
            ));
        }
    }
    let describe = |c: &ScopeChannel, unit: &str, rule: &str| {
        let mut s = format!("`{}`", c.name);
        if let Some(sym) = c.get("SymbolName").filter(|s| *s != c.name) {
            s.push_str(&format!(" ({sym})"));
        }
        s.push_str(&format!(" ({unit}: {rule})"));
        s
    };
    let mut prep = ChannelReport {
        source_key: describe(pc, p_unit.symbol(), &pu.1),
        ..Default::default()
    };
    prep.finish(&position);
    let mut erep = ChannelReport {
        source_key: describe(ec, e_unit.symbol(), &eu.1),
        ..Default::default()
    };
    erep.finish(&effort);
    let kind = e_unit.kind();
    let effort_rule = format!(
        "{} = {}{}",
        kind.column(),
        erep.source_key,
        if e_unit == EffortUnit::Milliampere {
            " / 1000"
        } else {
            ""
        }
    );
    let trace = Trace {
        position_m: position,
        effort,
        effort_kind: kind,
        facts: RecordingFacts {
            recordings: Some(1),
            ..RecordingFacts::default()
        },
    };
    let mut report = ImportReport {
        source_name: source_name.to_string(),
        time_zero: h.start,
        time_zero_rule: if h.start.is_some() {
            "Starttime of export (FILETIME, UTC)".into()
        } else {
            "the export's time 0 (no Starttime of export in the file)".into()
        },
        position: prep,
        effort: erep,
        effort_rule,
        warnings,
    };
    super::sampling_warnings(&mut report, &trace);
    report
        .warnings
        .retain(|w| !(w.code == Code::SlowSampling && super::sinumerik::fast_trace(&trace)));
    let (position, effort) = (pc.clone(), ec.clone());
    let mut full = vec![ChannelCounts::default(); h.channels.len()];
    full[p] = counts[0].clone();
    full[e] = counts[1].clone();
    Ok(TwincatImport {
        imported: Imported { trace, report },
        position,
        effort,
        listing: TwincatListing {
            header: h,
            counts: full,
            rows,
            decimal,
            eof_marker,
        },
    })
}

// ---------------------------------------------------------------------------------------------
// Writing (tests and demos).

/// Options of [`write_twincat_csv`].
#[derive(Debug, Clone, PartialEq)]
pub struct TwincatWriteParams {
    /// Field separator: tab (the export's default), space, `:`, `;` or `,`.
    pub separator: char,
    /// Write `,` as the decimal mark (TwinCAT on a German PC). Not with `,` as separator.
    pub decimal_comma: bool,
    /// One time column for channels with the same times ("exclude double timestamps").
    pub shared_time: bool,
    /// Name of the position channel.
    pub position_name: String,
    /// Name of the effort channel [default: `Axis.ActCurrent` or `Axis.ActTorque`].
    pub effort_name: Option<String>,
    /// The scope's name.
    pub scope_name: String,
    /// Starttime of export (the trace's time 0).
    pub start: Timestamp,
    /// End the data with an `EOF` line.
    pub eof_line: bool,
}

impl Default for TwincatWriteParams {
    fn default() -> Self {
        Self {
            separator: '\t',
            decimal_comma: false,
            shared_time: false,
            position_name: "Axis.NcToPlc.ActPos".into(),
            effort_name: None,
            scope_name: "feedscope twin".into(),
            start: Timestamp {
                unix_s: 1_767_600_000,
                nanos: 0,
            },
            eof_line: false,
        }
    }
}

/// A number with up to 6 decimals, trailing zeros trimmed, in the chosen decimal mark.
fn num(v: f64, comma: bool) -> String {
    let mut s = format!("{v:.6}");
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" {
        s = "0".into();
    }
    if comma {
        s = s.replace('.', ",");
    }
    s
}

/// Write a trace as a TwinCAT 3 Scope CSV export: the file block (Name, File, Starttime and
/// Endtime of export as FILETIME with a date text), the 17 header rows of a real export per
/// channel (`Unit` `mm (Length)`, `A (Current)` or `Nm (Torque)`), then time (ms) and value
/// columns, position in mm and effort in A or N·m with up to 6 decimals (1 nm, 1 µA, 1 µN·m)
/// and times to 1 ns. [`TwincatWriteParams::shared_time`] writes one time column when both
/// channels have the same times (else it is ignored).
///
/// For tests and demos: the files that the twin's round trip reads back (`feedscope simulate`
/// → this → `feedscope import twincat` → `feedscope estimate`). The layout follows real exports
/// of TwinCAT 3 Scope 3.4.3145; the unit texts for length, current and torque follow the
/// pattern of the real `V (Voltage)` and are an assumption.
///
/// # Errors
/// I/O errors; [`std::io::ErrorKind::InvalidInput`] for a decimal comma with `,` as separator
/// or a separator TwinCAT does not offer.
pub fn write_twincat_csv<W: Write>(
    trace: &Trace,
    params: &TwincatWriteParams,
    w: W,
) -> std::io::Result<()> {
    let sep = params.separator;
    if !matches!(sep, '\t' | ' ' | ':' | ';' | ',') || (sep == ',' && params.decimal_comma) {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "separator must be tab, space, ':', ';' or ',' (and not ',' with a decimal comma)",
        ));
    }
    let mut w = std::io::BufWriter::new(w);
    let c = params.decimal_comma;
    let (eff_default, eff_unit) = match trace.effort_kind {
        EffortKind::CurrentA => ("Axis.ActCurrent", "A (Current)"),
        EffortKind::TorqueNm => ("Axis.ActTorque", "Nm (Torque)"),
    };
    let effort_name = params
        .effort_name
        .clone()
        .unwrap_or_else(|| eff_default.into());
    let chans = [
        (&params.position_name, &trace.position_m, 1e3, "mm (Length)"),
        (&effort_name, &trace.effort, 1.0, eff_unit),
    ];
    let shared = params.shared_time && trace.position_m.time_s == trace.effort.time_s;
    let end = trace
        .position_m
        .time_s
        .last()
        .copied()
        .unwrap_or(0.0)
        .max(trace.effort.time_s.last().copied().unwrap_or(0.0));
    let ft = |t: Timestamp| timestamp_to_filetime(t).unwrap_or(0);
    let end_ts = Timestamp {
        unix_s: params.start.unix_s + end.floor() as i64,
        nanos: params.start.nanos,
    };
    let s = sep;
    // The file block's texts are quoted when they hold the separator, as TwinCAT does with a
    // space (`"Starttime of export"`); the channel header is written as it is.
    let q = |t: &str| {
        if t.contains(sep) {
            format!("\"{}\"", t.replace('"', "\"\""))
        } else {
            t.to_string()
        }
    };
    writeln!(w, "Name{s}{}", q(&params.scope_name))?;
    writeln!(w, "File{s}feedscope_twin.csv")?;
    for (key, t) in [
        ("Starttime of export", params.start),
        ("Endtime of export", end_ts),
    ] {
        let text = t.to_string();
        let (date, time) = text.split_at(10);
        writeln!(
            w,
            "{}{s}{}{s}{date}{s}{}",
            q(key),
            ft(t),
            time.trim_start_matches('T')
        )?;
    }
    writeln!(w)?;
    writeln!(w)?;
    let interval_ms = |ch: &Channel| {
        let mut d: Vec<f64> = ch.time_s.windows(2).map(|p| p[1] - p[0]).collect();
        d.sort_by(f64::total_cmp);
        d.get(d.len() / 2).map_or(0.0, |x| x * 1e3)
    };
    type Row<'a> = (&'a str, Box<dyn Fn(usize) -> String + 'a>);
    let rows: Vec<Row<'_>> = vec![
        ("Name", Box::new(|k| chans[k].0.to_string())),
        ("SymbolComment", Box::new(|_| String::new())),
        ("Data-Type", Box::new(|_| "REAL64".into())),
        (
            "SampleTime[ms]",
            Box::new(|k| num(interval_ms(chans[k].1), c)),
        ),
        ("VariableSize", Box::new(|_| "8".into())),
        ("SymbolBased", Box::new(|_| "True".into())),
        ("IndexGroup", Box::new(|_| "16448".into())),
        ("IndexOffset", Box::new(|k| (385_000 + 8 * k).to_string())),
        ("SymbolName", Box::new(|k| chans[k].0.to_string())),
        ("NetID", Box::new(|_| "127.0.0.1.1.1".into())),
        ("Port", Box::new(|_| "851".into())),
        ("Offset", Box::new(|_| "0".into())),
        ("ScaleFactor", Box::new(|_| "1".into())),
        ("BitMask", Box::new(|_| "0xffffffffffffffff".into())),
        ("Unit", Box::new(|k| chans[k].3.to_string())),
        ("Unit ScaleFactor", Box::new(|_| "1".into())),
        ("Unit Offset", Box::new(|_| "0".into())),
    ];
    for (key, val) in &rows {
        let mut line = String::new();
        for k in 0..2 {
            if k == 0 || !shared {
                line.push_str(key);
                line.push(s);
            }
            line.push_str(&val(k));
            if k == 0 {
                line.push(s);
            }
        }
        writeln!(w, "{line}")?;
    }
    writeln!(w)?;
    let n = trace.position_m.len().max(trace.effort.len());
    let mut line = String::new();
    for j in 0..n {
        line.clear();
        if shared {
            line.push_str(&num(trace.position_m.time_s[j] * 1e3, c));
            for (_, ch, scale, _) in &chans {
                line.push(s);
                line.push_str(&num(ch.value[j] * scale, c));
            }
        } else {
            // Channels that ended leave blank cells; the row stops after the last that has
            // a sample, as TwinCAT writes it.
            let last = chans
                .iter()
                .rposition(|(_, ch, _, _)| j < ch.len())
                .unwrap_or(0);
            for (k, (_, ch, scale, _)) in chans.iter().enumerate().take(last + 1) {
                if k > 0 {
                    line.push(s);
                }
                if j < ch.len() {
                    line.push_str(&num(ch.time_s[j] * 1e3, c));
                    line.push(s);
                    line.push_str(&num(ch.value[j] * scale, c));
                } else {
                    line.push(' ');
                    line.push(s);
                    line.push(' ');
                }
            }
        }
        writeln!(w, "{line}")?;
    }
    if params.eof_line {
        writeln!(w, "EOF")?;
    }
    w.flush()
}

#[cfg(test)]
mod tests;
