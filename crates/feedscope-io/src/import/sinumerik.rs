//! SINUMERIK Operate servo trace files (XML, "SINUMERIK Solution Line Trace").
//!
//! # The file
//! ```text
//! <traceSession version="01.00.03.02">
//!   <traceCaptureSetup>…</traceCaptureSetup> <traceDisplaySetup>…</traceDisplaySetup>
//!   <traceData dataFrames="1">
//!     <dataFrame>
//!       <frameHeader startTime="2012-01-20T20:01:47.526Z" stopInc="45.416000" dropOuts="0" …/>
//!       <dataSignal id="f7" key="s11" name="/Nck/!SD/nckServoDataActCurr32 [u1, 7]"
//!                   description="Torque-prod. Current act. Val. i(q) (32 bit)"
//!                   unitsType="current" interval="0.002000" datapointCount="22709" …/>
//!       …
//!       <rec time="0.000000" f1="0.000000" f7="-0.798340" …/>
//!       <rec time="0.002000" f7="-0.791687" f8="-0.005600"/>
//! ```
//! Only `traceData` is read; the capture and display setups repeat the signal list for the
//! HMI. Each `dataSignal` is one recorded variable, named by its NCK path; the bracket holds
//! the unit and the machine axis number (`[u1, 7]`: axis 7). A `rec` holds the time in seconds
//! from the frame's `startTime` and the values of the signals sampled then, as attributes named
//! by the signals' ids.
//!
//! # What is read, and how
//! - **Sparse and change-only records.** Signals of different rates share records (position
//!   every 4 ms, current every 2 ms). The control also leaves out a servo signal's value when it
//!   equals the previous one: in a real 45 s trace the acceleration setpoint holds 2,212 of its
//!   22,709 declared samples, and a closing record at `stopInc` repeats every such signal. A gap
//!   of k × `interval` in a signal whose written values fall short of its `datapointCount` is
//!   therefore k − 1 repeats of the value before it, and they are put back
//!   ([`SignalStats::restored`]), never more than `datapointCount` in all; the trace then holds
//!   the signal as the drive sampled it. A gap that is not a whole number of intervals is left
//!   as it is and counted.
//! - **Invalid samples.** A value of magnitude ≥ [`INVALID_MARK`] (≈ 9.2e18, the control's
//!   mark for "no value", e.g. `9223372036854775807`) is no sample: it is dropped, counted and
//!   reported, never turned into a number, and the repeats after it are invalid too.
//! - **Signals.** The axis's actual position (`measPos1`/`measPos2`, `nckServoDataActPos…`, or a
//!   description "actual position", `unitsType="posn"`) and its motor current
//!   (`unitsType="current"`, e.g. `nckServoDataActCurr32`) or torque (`unitsType="torque"` or
//!   `…Torque…`). Measuring system 1 and the actual current are preferred; any signal can be
//!   named ([`SinumerikParams::position_signal`]). Setpoints, following error and deviations are
//!   never taken for the position.
//! - **Units.** A unit in the description (`(mm)`, `[A]`) or a flag; otherwise `unitsType`:
//!   `posn` is mm (the metric basic system; an inch machine needs
//!   [`SinumerikParams::position_unit`]), `current` A, `torque` N·m. The report says which rule
//!   gave each unit.
//! - **Time.** `time_s` counts from the first frame's `startTime` (kept as the absolute time
//!   zero); later frames are placed by their own `startTime`.
//!
//! Memory: the file is streamed (quick-xml, one element at a time); only the two converted
//! signals are kept, so a trace of tens of MB needs a few MB plus 16 bytes per kept sample.
//!
//! # Example
//! ```
//! use feedscope_io::import::sinumerik::{parse_sinumerik, SinumerikParams};
//!
//! let xml = r#"<traceSession version="01.00.03.02"><traceData dataFrames="1"><dataFrame>
//!   <frameHeader startTime="2026-01-05T08:00:00Z" stopInc="0.008000"/>
//!   <dataSignal id="f1" name="/Nck/!SEMA/measPos1 [u1, 3]" unitsType="posn"
//!     description="Actual position value for measuring system 1."
//!     interval="0.002000" datapointCount="5"/>
//!   <dataSignal id="f2" name="/Nck/!SD/nckServoDataActCurr32 [u1, 3]" unitsType="current"
//!     description="Torque-prod. Current act. Val. i(q) (32 bit)"
//!     interval="0.002000" datapointCount="5"/>
//!   <rec time="0.000000" f1="10.000" f2="1.5"/>
//!   <rec time="0.002000" f1="10.002"/>
//!   <rec time="0.004000" f1="10.004" f2="9223372036854775807"/>
//!   <rec time="0.006000" f1="10.006" f2="1.7"/>
//!   <rec time="0.008000" f1="10.008" f2="1.7"/>
//! </dataFrame></traceData></traceSession>"#;
//! let imp = parse_sinumerik(xml.as_bytes(), "trace.xml", &SinumerikParams::default())?;
//! let t = &imp.imported.trace;
//! assert!((t.position_m.value[4] - 0.010008).abs() < 1e-15); // mm → m
//! // The current at 2 ms was left out as a repeat of 1.5 A and is put back; the invalid mark
//! // at 4 ms is dropped.
//! assert_eq!(t.effort.time_s, [0.0, 0.002, 0.006, 0.008]);
//! assert!((t.effort.value[1] - 1.5).abs() < 1e-15);
//! assert_eq!((imp.effort.1.restored, imp.effort.1.invalid), (1, 1));
//! # Ok::<(), feedscope_io::import::ImportError>(())
//! ```
//!
//! # Errors
//! Exit-2 errors name the file and line: XML that is not well-formed or ends inside an element
//! (a truncated file), a `dataSignal` without `id` or `name`, a `rec` without `time`, a value
//! that is not a number, NaN or infinite, a record time not after the one before, a value for
//! an undeclared signal, a converted value beyond the limits of [`super::units`], an axis that
//! was not recorded (with the list of axes), a converted signal with no valid sample.
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;

use super::units::{self, EffortUnit, PositionUnit};
use super::{shorten, ChannelReport, ImportError, ImportReport, Imported, Timestamp};
use feedscope::diag::{Code, Diagnostic};
use feedscope::trace::{Channel, EffortKind, RecordingFacts, Trace, MIN_SAMPLES};

/// Values of at least this magnitude are the control's mark of an invalid sample (the largest
/// 64-bit integer is 9.223e18); they are dropped, never read as numbers.
pub const INVALID_MARK: f64 = 9.2e18;

/// Most samples restored or kept per signal (50 M: a 100 min trace at 8 kHz). Protects the
/// memory from a damaged `datapointCount` or time.
const MAX_SAMPLES_PER_SIGNAL: u64 = 50_000_000;

/// Invalid-sample times remembered per signal for the report.
const INVALID_TIMES_KEPT: usize = 5;

/// One `dataSignal` of a data frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SignalDef {
    /// 0-based index of its data frame.
    pub frame: usize,
    /// The attribute name of its values in `rec` elements, e.g. `f7`.
    pub id: String,
    /// The HMI's key, e.g. `s11`.
    pub key: Option<String>,
    /// The NCK path, e.g. `/Nck/!SD/nckServoDataActCurr32 [u1, 7]`.
    pub name: String,
    /// The description, e.g. `Torque-prod. Current act. Val. i(q) (32 bit)`.
    pub description: String,
    /// The quantity: `posn`, `velo`, `accel`, `current`, `torque`, `none`, …
    pub units_type: Option<String>,
    /// `float`, `double`, `uword`, …
    pub data_type: Option<String>,
    /// Sampling interval (s).
    pub interval_s: Option<f64>,
    /// Samples the control recorded (written or left out as repeats).
    pub datapoint_count: Option<u64>,
    /// 1-based line of the `dataSignal` element.
    pub line: u64,
}

/// What a signal can be used for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SignalRole {
    /// An actual position of the axis.
    ActualPosition,
    /// An actual motor current.
    Current,
    /// A motor torque (actual or setpoint).
    Torque,
    /// Anything else.
    Other,
}

impl SignalDef {
    /// The axis of the signal: the last entry of the bracket at the end of its NCK path (`7`
    /// for `[u1, 7]`, the machine axis number), `None` without a bracket.
    pub fn axis(&self) -> Option<&str> {
        let open = self.name.rfind('[')?;
        let close = self.name[open..].find(']')? + open;
        let inner = &self.name[open + 1..close];
        let last = inner.rsplit([',', ';']).next()?.trim();
        (!last.is_empty()).then_some(last)
    }

    /// The NCK variable without path and bracket, e.g. `nckServoDataActCurr32`.
    pub fn variable(&self) -> &str {
        let base = self.name.split('[').next().unwrap_or("").trim();
        base.rsplit('/').next().unwrap_or(base)
    }

    /// What the signal measures, from its unitsType, variable and description.
    pub fn role(&self) -> SignalRole {
        let units = self
            .units_type
            .as_deref()
            .unwrap_or("")
            .to_ascii_lowercase();
        let var = self.variable().to_ascii_lowercase();
        let desc = self.description.to_ascii_lowercase();
        let not_actual = ["setpoint", "following", "deviation", "difference", "error"]
            .iter()
            .any(|w| desc.contains(w))
            || ["cmd", "flwerr", "dev", "des"]
                .iter()
                .any(|w| var.contains(w));
        if units == "posn" || units.is_empty() {
            let named = var.starts_with("measpos")
                || var.contains("actpos")
                || desc.contains("actual position")
                || desc.contains("position actual");
            if named && !not_actual {
                return SignalRole::ActualPosition;
            }
        }
        if units == "current" || (units.is_empty() && var.contains("curr")) {
            return SignalRole::Current;
        }
        if units == "torque" || var.contains("torque") {
            return SignalRole::Torque;
        }
        SignalRole::Other
    }

    /// `f7 /Nck/!SD/nckServoDataActCurr32 [u1, 7]`.
    pub fn label(&self) -> String {
        format!("{} {}", self.id, self.name)
    }

    /// Whether `wanted` names this signal: its id, key or NCK path (spaces ignored).
    fn is_named(&self, wanted: &str) -> bool {
        let squash = |s: &str| s.chars().filter(|c| !c.is_whitespace()).collect::<String>();
        self.id == wanted
            || self.key.as_deref() == Some(wanted)
            || squash(&self.name) == squash(wanted)
            || self.variable() == wanted
    }

    /// Measuring system 1 (`measPos1`, `…1stEnc…`, "measuring system 1"): preferred position.
    fn is_first_measuring_system(&self) -> bool {
        let var = self.variable().to_ascii_lowercase();
        var == "measpos1"
            || var.contains("1stenc")
            || self
                .description
                .to_ascii_lowercase()
                .contains("measuring system 1")
    }

    /// A unit written in the description or name, `(mm)` or `[A]`.
    fn described_unit<U>(&self, parse: impl Fn(&str) -> Option<U>) -> Option<U> {
        for text in [&self.description, &self.name] {
            let mut rest = text.as_str();
            while let Some(k) = rest.find(['(', '[']) {
                let close = if rest.as_bytes()[k] == b'(' { ')' } else { ']' };
                let Some(e) = rest[k + 1..].find(close) else {
                    break;
                };
                if let Some(u) = parse(&rest[k + 1..k + 1 + e]) {
                    return Some(u);
                }
                rest = &rest[k + 1 + e..];
            }
        }
        None
    }
}

/// Counts of one signal's values.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SignalStats {
    /// Values written in records (valid or not).
    pub written: u64,
    /// Repeats put back where the control left a value out (change-only records).
    pub restored: u64,
    /// Samples that were the invalid mark, or repeats of one: dropped.
    pub invalid: u64,
    /// Gaps longer than the interval that are not a whole number of intervals (left as gaps).
    pub irregular_gaps: u64,
    /// Times (s) of the first few invalid samples.
    pub invalid_times_s: Vec<f64>,
    /// First and last valid sample time (s).
    pub span_s: Option<(f64, f64)>,
    /// Smallest and largest valid value, in the file's unit.
    pub range: Option<(f64, f64)>,
}

impl SignalStats {
    /// Valid samples: written or restored, minus the invalid ones.
    pub fn samples(&self) -> u64 {
        (self.written + self.restored).saturating_sub(self.invalid)
    }

    fn valid(&mut self, t: f64, v: f64) {
        self.span_s = Some(self.span_s.map_or((t, t), |(a, _)| (a, t)));
        self.range = Some(self.range.map_or((v, v), |(a, b)| (a.min(v), b.max(v))));
    }

    fn invalid(&mut self, t: f64) {
        self.invalid += 1;
        if self.invalid_times_s.len() < INVALID_TIMES_KEPT {
            self.invalid_times_s.push(t);
        }
    }
}

/// One `dataFrame`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Frame {
    /// `frameHeader startTime`.
    pub start: Option<Timestamp>,
    /// `frameHeader stopInc` (s): the recorded span.
    pub stop_inc_s: Option<f64>,
    /// `frameHeader dropOuts`: samples the control lost.
    pub drop_outs: Option<u64>,
    /// `rec` elements.
    pub records: u64,
    /// First and last record time (s, from this frame's start).
    pub span_s: Option<(f64, f64)>,
    /// Its signals, in file order.
    pub signals: Vec<SignalDef>,
    /// Their counts, same order.
    pub stats: Vec<SignalStats>,
}

impl Frame {
    /// The signals converted by default for `axis` (`None`: every signal): the actual
    /// position, measuring system 1 first, and the actual current, else a torque; indices into
    /// [`Frame::signals`].
    pub fn default_signals(&self, axis: Option<&str>) -> (Option<usize>, Option<usize>) {
        let on_axis = |s: &SignalDef| axis.is_none() || s.axis() == axis;
        let of_role = |role| {
            (0..self.signals.len())
                .filter(move |&k| on_axis(&self.signals[k]) && self.signals[k].role() == role)
        };
        let pos = of_role(SignalRole::ActualPosition)
            .find(|&k| self.signals[k].is_first_measuring_system())
            .or_else(|| of_role(SignalRole::ActualPosition).next());
        let eff = of_role(SignalRole::Current)
            .next()
            .or_else(|| of_role(SignalRole::Torque).next());
        (pos, eff)
    }

    /// The axes of the frame's signals with their numbers of signals, in order of first
    /// appearance.
    pub fn axes(&self) -> Vec<(String, usize)> {
        axes_of(self)
    }
}

/// Everything a trace file declares and holds, with counts per signal (no values).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SinumerikListing {
    /// The file.
    pub source_name: String,
    /// `traceSession version`.
    pub version: Option<String>,
    /// `sessionSettings sessionName`.
    pub session_name: Option<String>,
    /// The data frames.
    pub frames: Vec<Frame>,
}

impl SinumerikListing {
    /// The axes with signals in the first frame that has records, in order of first
    /// appearance, each with its number of signals.
    pub fn axes(&self) -> Vec<(String, usize)> {
        self.frames
            .iter()
            .find(|f| f.records > 0)
            .or(self.frames.first())
            .map_or_else(Vec::new, axes_of)
    }
}

/// The axes of a frame's signals with their numbers of signals, in order of first appearance.
fn axes_of(f: &Frame) -> Vec<(String, usize)> {
    let mut v: Vec<(String, usize)> = Vec::new();
    for s in &f.signals {
        if let Some(a) = s.axis() {
            match v.iter_mut().find(|(x, _)| x == a) {
                Some(e) => e.1 += 1,
                None => v.push((a.to_string(), 1)),
            }
        }
    }
    v
}

/// `1 (4 signals), 7 (9 signals)`.
fn axes_text(a: &[(String, usize)]) -> String {
    if a.is_empty() {
        return "none (no signal has an axis bracket)".into();
    }
    a.iter()
        .map(|(x, n)| format!("{x} ({n} signals)"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Options of [`read_sinumerik`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SinumerikParams {
    /// The machine axis number in the signals' brackets (`7` for `[u1, 7]`, or `u1,7`); needed
    /// when several axes were recorded.
    pub axis: Option<String>,
    /// Position signal by id (`f8`), key (`s12`), NCK path or variable name (`measPos2`)
    /// [default: the axis's actual position, measuring system 1 first].
    pub position_signal: Option<String>,
    /// Effort signal, named the same way [default: the axis's actual current, else torque].
    pub effort_signal: Option<String>,
    /// Unit of the position values [default: from the description, else mm for `posn`].
    pub position_unit: Option<PositionUnit>,
    /// Unit of the effort values [default: from the description, else by `unitsType`].
    pub effort_unit: Option<EffortUnit>,
}

/// A converted trace, with the signals it came from.
#[derive(Debug, Clone)]
pub struct SinumerikImport {
    /// Trace and report, as every import returns.
    pub imported: Imported,
    /// The position signal (of the first frame) and its counts over all frames.
    pub position: (SignalDef, SignalStats),
    /// The effort signal and its counts.
    pub effort: (SignalDef, SignalStats),
    /// Everything else the file holds.
    pub listing: SinumerikListing,
}

// ---------------------------------------------------------------------------------------------
// Reading: bytes to events, with line numbers and the encoding of the declaration.

/// A `BufRead` that counts the line breaks of what its consumer consumed, so that an element
/// is named by the line it starts on.
struct LineCounter<R> {
    inner: R,
    newlines: u64,
}

impl<R: BufRead> Read for LineCounter<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.newlines += memchr::memchr_iter(b'\n', &buf[..n]).count() as u64;
        Ok(n)
    }
}

impl<R: BufRead> BufRead for LineCounter<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.inner.fill_buf()
    }

    fn consume(&mut self, amt: usize) {
        // `amt` never exceeds what the last fill_buf returned, which is still buffered.
        if let Ok(b) = self.inner.fill_buf() {
            let k = amt.min(b.len());
            self.newlines += memchr::memchr_iter(b'\n', &b[..k]).count() as u64;
        }
        self.inner.consume(amt);
    }
}

/// ISO-8859-1 bytes as UTF-8 (quick-xml reads UTF-8 only; Operate writes UTF-8, other Siemens
/// tools declare ISO-8859-1). Line breaks stay one byte each, so line numbers are kept.
struct Latin1<R> {
    inner: R,
    pending: Option<u8>,
}

impl<R: Read> Read for Latin1<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        let mut n = 0;
        if let Some(b) = self.pending.take() {
            buf[0] = b;
            n = 1;
        }
        // Read at most half the space left: every byte may become two.
        let room = (buf.len() - n) / 2;
        if room == 0 {
            return Ok(n);
        }
        let mut raw = vec![0u8; room];
        let m = self.inner.read(&mut raw)?;
        for &b in &raw[..m] {
            if b < 0x80 {
                buf[n] = b;
                n += 1;
            } else {
                let c = char::from(b);
                let mut tmp = [0u8; 2];
                let s = c.encode_utf8(&mut tmp);
                buf[n..n + 2].copy_from_slice(s.as_bytes());
                n += 2;
            }
        }
        Ok(n)
    }
}

/// The encoding named by the XML declaration at the start of `head`, lower-case.
fn declared_encoding(head: &[u8]) -> Option<String> {
    let end = memchr::memmem::find(head, b"?>")?;
    let decl = std::str::from_utf8(&head[..end]).ok()?;
    let k = decl.find("encoding")?;
    let rest = decl[k + 8..].trim_start().strip_prefix('=')?.trim_start();
    let q = rest.chars().next()?;
    let rest = &rest[1..];
    let e = rest.find(q)?;
    Some(rest[..e].to_ascii_lowercase())
}

/// Open the byte stream for quick-xml: a UTF-8 BOM dropped, ISO-8859-1 transcoded.
fn xml_reader<'a, R: BufRead + 'a>(
    mut r: R,
) -> std::io::Result<quick_xml::Reader<LineCounter<Box<dyn BufRead + 'a>>>> {
    let head = r.fill_buf()?;
    let bom = head.starts_with(&[0xEF, 0xBB, 0xBF]);
    let latin1 = matches!(
        declared_encoding(&head[..head.len().min(512)]).as_deref(),
        Some("iso-8859-1" | "latin1" | "latin-1" | "iso8859-1" | "windows-1252" | "cp1252")
    );
    if bom {
        r.consume(3);
    }
    let inner: Box<dyn BufRead + 'a> = if latin1 {
        Box::new(BufReader::new(Latin1 {
            inner: r,
            pending: None,
        }))
    } else {
        Box::new(r)
    };
    let mut reader = quick_xml::Reader::from_reader(LineCounter { inner, newlines: 0 });
    let c = reader.config_mut();
    c.trim_text(false);
    c.check_end_names = true;
    c.expand_empty_elements = false;
    Ok(reader)
}

/// An attribute's text with XML escapes resolved (raw when they do not resolve).
fn attr_text(a: &quick_xml::events::attributes::Attribute<'_>) -> String {
    match quick_xml::escape::unescape(&a.value) {
        Ok(s) => s.into_owned(),
        Err(_) => a.value.to_string(),
    }
}

/// What the streaming pass does with the records of the chosen signals.
trait Sink {
    /// At the first record of frame `frame`: which of its signals to keep, as slot numbers.
    fn begin(
        &mut self,
        listing: &SinumerikListing,
        frame: usize,
        line: u64,
    ) -> Result<Vec<Option<usize>>, ImportError>;
    /// A valid sample of a kept signal (time from the first frame's start).
    fn sample(&mut self, slot: usize, t: f64, v: f64, line: u64) -> Result<(), ImportError>;
}

/// Per-signal state of the pass.
#[derive(Debug, Clone, Default)]
struct Track {
    slot: Option<usize>,
    /// Time of the last sample (written or restored).
    last_t: Option<f64>,
    /// Its value, `None` when it was invalid.
    last_v: Option<Option<f64>>,
}

struct Pass<'s, S> {
    source: &'s str,
    listing: SinumerikListing,
    sink: S,
    /// Tracks of the current frame.
    tracks: Vec<Track>,
    /// Signal index by the number in an `fN` id.
    by_num: Vec<Option<usize>>,
    /// Signal index by any other id.
    by_id: HashMap<String, usize>,
    /// Seconds from the first frame's start to the current frame's.
    offset_s: f64,
    began: bool,
    last_record: Option<(f64, u64)>,
}

impl<S: Sink> Pass<'_, S> {
    fn bad(&self, line: u64, reason: impl Into<String>) -> ImportError {
        ImportError::Malformed {
            source_name: self.source.to_string(),
            line,
            reason: reason.into(),
        }
    }

    fn frame(&mut self) -> &mut Frame {
        self.listing.frames.last_mut().expect("inside a frame")
    }

    fn start_frame(&mut self) {
        self.listing.frames.push(Frame::default());
        self.tracks.clear();
        self.by_num.clear();
        self.by_id.clear();
        self.began = false;
        self.last_record = None;
    }

    fn frame_header(
        &mut self,
        e: &quick_xml::events::BytesStart<'_>,
        line: u64,
    ) -> Result<(), ImportError> {
        for a in e.attributes() {
            let a = a.map_err(|err| self.bad(line, format!("frameHeader: {err}")))?;
            let v = attr_text(&a);
            match a.key.as_ref() {
                "startTime" => {
                    let t = Timestamp::parse(v.trim()).map_err(|r| {
                        self.bad(
                            line,
                            format!("frameHeader startTime `{}`: {r}", shorten(&v)),
                        )
                    })?;
                    self.frame().start = Some(t);
                }
                "stopInc" => self.frame().stop_inc_s = v.trim().parse().ok(),
                "dropOuts" => self.frame().drop_outs = v.trim().parse().ok(),
                _ => {}
            }
        }
        let first = self.listing.frames[0].start;
        let this = self.listing.frames.last().and_then(|f| f.start);
        if let (Some(a), Some(b)) = (first, this) {
            self.offset_s = b.seconds_since(&a);
        }
        Ok(())
    }

    fn data_signal(
        &mut self,
        e: &quick_xml::events::BytesStart<'_>,
        line: u64,
    ) -> Result<(), ImportError> {
        if self.began {
            return Err(self.bad(line, "dataSignal after the first rec of its dataFrame"));
        }
        let frame = self.listing.frames.len() - 1;
        let mut d = SignalDef {
            frame,
            id: String::new(),
            key: None,
            name: String::new(),
            description: String::new(),
            units_type: None,
            data_type: None,
            interval_s: None,
            datapoint_count: None,
            line,
        };
        let (mut has_id, mut has_name) = (false, false);
        for a in e.attributes() {
            let a = a.map_err(|err| self.bad(line, format!("dataSignal: {err}")))?;
            let v = attr_text(&a);
            match a.key.as_ref() {
                "id" => (d.id, has_id) = (v, true),
                "name" => (d.name, has_name) = (v, true),
                "key" => d.key = Some(v),
                "description" => d.description = v,
                "unitsType" => d.units_type = Some(v),
                "dataType" => d.data_type = Some(v),
                "interval" => {
                    d.interval_s = v
                        .trim()
                        .parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite() && *x > 0.0)
                }
                "datapointCount" => d.datapoint_count = v.trim().parse().ok(),
                _ => {}
            }
        }
        if !has_id || d.id.is_empty() {
            return Err(self.bad(line, "dataSignal without its `id` attribute"));
        }
        if !has_name {
            return Err(self.bad(
                line,
                format!(
                    "dataSignal `{}` without its `name` attribute (the NCK path)",
                    d.id
                ),
            ));
        }
        let idx = self.frame().signals.len();
        let num = d.id.strip_prefix('f').and_then(|n| n.parse::<usize>().ok());
        match num {
            Some(n) if n < 1_000_000 => {
                if self.by_num.len() <= n {
                    self.by_num.resize(n + 1, None);
                }
                if self.by_num[n].is_some() {
                    return Err(self.bad(line, format!("dataSignal id `{}` declared twice", d.id)));
                }
                self.by_num[n] = Some(idx);
            }
            _ => {
                if self.by_id.insert(d.id.clone(), idx).is_some() {
                    return Err(self.bad(line, format!("dataSignal id `{}` declared twice", d.id)));
                }
            }
        }
        self.frame().signals.push(d);
        self.frame().stats.push(SignalStats::default());
        self.tracks.push(Track::default());
        Ok(())
    }

    fn signal_index(&self, id: &str) -> Option<usize> {
        match id.strip_prefix('f').and_then(|n| n.parse::<usize>().ok()) {
            Some(n) => self.by_num.get(n).copied().flatten(),
            None => self.by_id.get(id).copied(),
        }
    }

    fn record(
        &mut self,
        e: &quick_xml::events::BytesStart<'_>,
        line: u64,
        scratch: &mut Vec<(usize, f64)>,
    ) -> Result<(), ImportError> {
        let fi = self.listing.frames.len() - 1;
        if !self.began {
            self.began = true;
            let slots = self.sink.begin(&self.listing, fi, line)?;
            for (t, s) in self.tracks.iter_mut().zip(slots) {
                t.slot = s;
            }
        }
        scratch.clear();
        let mut time: Option<f64> = None;
        for a in e.attributes() {
            let a = a.map_err(|err| self.bad(line, format!("rec: {err}")))?;
            let key = a.key.as_ref();
            let text = a.value.trim();
            let parsed = text.parse::<f64>();
            if key == "time" {
                match parsed {
                    Ok(t) if t.is_finite() => time = Some(t),
                    _ => {
                        return Err(self.bad(
                            line,
                            format!("rec: time `{}` is not a finite number", shorten(text)),
                        ))
                    }
                }
                continue;
            }
            let Some(i) = self.signal_index(key) else {
                return Err(self.bad(
                    line,
                    format!("rec: attribute `{key}` is no signal of this dataFrame (no dataSignal id=\"{key}\")"),
                ));
            };
            let sig = &self.listing.frames[fi].signals[i];
            let v = match parsed {
                // Finite first: an infinity is damage, not the control's mark.
                Ok(v) if v.is_finite() => v,
                Ok(_) => {
                    return Err(self.bad(
                        line,
                        format!("rec: {} = `{}` is not finite", sig.label(), shorten(text)),
                    ))
                }
                Err(_) => {
                    return Err(self.bad(
                        line,
                        format!("rec: {} = `{}` is not a number", sig.label(), shorten(text)),
                    ))
                }
            };
            scratch.push((i, v));
        }
        let Some(t_rel) = time else {
            return Err(self.bad(line, "rec without its `time` attribute"));
        };
        if let Some((prev, prev_line)) = self.last_record {
            if t_rel <= prev {
                return Err(self.bad(
                    line,
                    format!(
                        "rec time {t_rel} s is not after the previous record's {prev} s (line \
                         {prev_line}): time not increasing"
                    ),
                ));
            }
        }
        self.last_record = Some((t_rel, line));
        let t = t_rel + self.offset_s;
        {
            let f = self.frame();
            f.records += 1;
            f.span_s = Some(f.span_s.map_or((t_rel, t_rel), |(a, _)| (a, t_rel)));
        }
        for &(i, v) in scratch.iter() {
            self.value(fi, i, t, v, line)?;
        }
        Ok(())
    }

    /// One written value of signal `i` at `t`: restore the repeats left out before it, then
    /// take it.
    fn value(&mut self, fi: usize, i: usize, t: f64, v: f64, line: u64) -> Result<(), ImportError> {
        self.restore_until(fi, i, t, line, false)?;
        let slot = self.tracks[i].slot;
        let st = &mut self.listing.frames[fi].stats[i];
        st.written += 1;
        if st.written + st.restored > MAX_SAMPLES_PER_SIGNAL {
            let label = self.listing.frames[fi].signals[i].label();
            return Err(self.bad(
                line,
                format!("{label}: more than {MAX_SAMPLES_PER_SIGNAL} samples"),
            ));
        }
        let st = &mut self.listing.frames[fi].stats[i];
        let valid = v.abs() < INVALID_MARK;
        if valid {
            st.valid(t, v);
            if let Some(s) = slot {
                self.sink.sample(s, t, v, line)?;
            }
        } else {
            st.invalid(t);
        }
        let tr = &mut self.tracks[i];
        tr.last_t = Some(t);
        tr.last_v = Some(valid.then_some(v));
        Ok(())
    }

    /// Put back the repeats of signal `i` between its last sample and `t` (before a written
    /// value), or up to and including `t` (`tail`: the frame's last record).
    fn restore_until(
        &mut self,
        fi: usize,
        i: usize,
        t: f64,
        line: u64,
        tail: bool,
    ) -> Result<(), ImportError> {
        let (Some(last_t), Some(last_v)) = (self.tracks[i].last_t, self.tracks[i].last_v) else {
            return Ok(());
        };
        let def = &self.listing.frames[fi].signals[i];
        let (Some(dt), Some(count)) = (def.interval_s, def.datapoint_count) else {
            return Ok(());
        };
        let label = || self.listing.frames[fi].signals[i].label();
        let st = &self.listing.frames[fi].stats[i];
        let have = st.written + st.restored;
        if have >= count {
            return Ok(());
        }
        let gap = t - last_t;
        // Record times carry 6 decimals: a gap is a whole number of intervals within the
        // 1 µs of rounding at its two ends (2 µs), plus 1e-7 of the gap for an interval
        // written with fewer digits than the cycle has.
        let steps = (gap / dt).round();
        let whole = (gap - steps * dt).abs() <= 2e-6 + 1e-7 * gap;
        let missing = if tail {
            // After the last value: the grid points up to the end of the frame.
            ((gap + 2e-6) / dt).floor()
        } else if !whole {
            if gap > 1.5 * dt {
                self.listing.frames[fi].stats[i].irregular_gaps += 1;
            }
            return Ok(());
        } else {
            steps - 1.0
        };
        if missing < 1.0 {
            return Ok(());
        }
        let n = (missing as u64).min(count - have);
        if have + n > MAX_SAMPLES_PER_SIGNAL {
            return Err(self.bad(
                line,
                format!("{}: more than {MAX_SAMPLES_PER_SIGNAL} samples", label()),
            ));
        }
        let slot = self.tracks[i].slot;
        for k in 1..=n {
            let tk = last_t + k as f64 * dt;
            let st = &mut self.listing.frames[fi].stats[i];
            st.restored += 1;
            match last_v {
                Some(v) => {
                    st.valid(tk, v);
                    if let Some(s) = slot {
                        self.sink.sample(s, tk, v, line)?;
                    }
                }
                None => st.invalid(tk),
            }
        }
        let tr = &mut self.tracks[i];
        tr.last_t = Some(last_t + n as f64 * dt);
        Ok(())
    }

    fn end_frame(&mut self, line: u64) -> Result<(), ImportError> {
        let fi = self.listing.frames.len() - 1;
        if let Some((t_end, _)) = self.last_record {
            let t = t_end + self.offset_s;
            for i in 0..self.tracks.len() {
                self.restore_until(fi, i, t, line, true)?;
            }
        }
        Ok(())
    }
}

/// Stream a trace through `sink`; returns the listing with every signal's counts.
fn scan<R: BufRead, S: Sink>(
    r: R,
    source: &str,
    sink: S,
) -> Result<(SinumerikListing, S), ImportError> {
    let io = |error| ImportError::Io {
        source_name: source.to_string(),
        error,
    };
    let mut reader = xml_reader(r).map_err(io)?;
    let mut pass = Pass {
        source,
        listing: SinumerikListing {
            source_name: source.to_string(),
            ..Default::default()
        },
        sink,
        tracks: Vec::new(),
        by_num: Vec::new(),
        by_id: HashMap::new(),
        offset_s: 0.0,
        began: false,
        last_record: None,
    };
    let mut buf = Vec::new();
    let mut scratch = Vec::new();
    // Element names from the root down; only the names matter for where we are.
    let mut stack: Vec<String> = Vec::new();
    let mut root_seen = false;
    let mut trace_data = false;
    loop {
        let line = reader.get_ref().newlines + 1;
        buf.clear();
        let ev = match reader.read_event_into(&mut buf) {
            Ok(ev) => ev,
            Err(e) => {
                let line = reader.get_ref().newlines + 1;
                if let quick_xml::Error::Io(err) = &e {
                    if err.kind() != std::io::ErrorKind::InvalidData
                        && err.kind() != std::io::ErrorKind::UnexpectedEof
                    {
                        return Err(ImportError::Io {
                            source_name: source.to_string(),
                            error: std::io::Error::new(err.kind(), err.to_string()),
                        });
                    }
                }
                let context = stack
                    .last()
                    .map_or(String::new(), |s| format!(" (inside <{s}>)"));
                return Err(pass.bad(line, format!("not well-formed XML{context}: {e}")));
            }
        };
        use quick_xml::events::Event;
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(ev, Event::Empty(_));
                let name = e.name().as_ref().to_string();
                if !root_seen {
                    root_seen = true;
                    if name != "traceSession" {
                        return Err(pass.bad(
                            line,
                            format!(
                                "root element <{}>: not a SINUMERIK trace file (expected \
                                 <traceSession>)",
                                shorten(&name)
                            ),
                        ));
                    }
                }
                // A frame is open only when a <dataFrame> in <traceData> started one.
                let in_frame = stack.last().is_some_and(|s| s == "dataFrame")
                    && !pass.listing.frames.is_empty();
                match name.as_str() {
                    "traceSession" => {
                        for a in e.attributes().flatten() {
                            if a.key.as_ref() == "version" {
                                pass.listing.version = Some(attr_text(&a));
                            }
                        }
                    }
                    "sessionSettings" => {
                        for a in e.attributes().flatten() {
                            if a.key.as_ref() == "sessionName" {
                                pass.listing.session_name = Some(attr_text(&a));
                            }
                        }
                    }
                    "traceData" => trace_data = true,
                    "dataFrame" if stack.last().is_some_and(|s| s == "traceData") => {
                        pass.start_frame();
                        if empty {
                            pass.end_frame(line)?;
                        }
                    }
                    "dataFrame" => {
                        return Err(pass.bad(line, "<dataFrame> outside <traceData>"));
                    }
                    "frameHeader" if in_frame => pass.frame_header(e, line)?,
                    "dataSignal" if in_frame => pass.data_signal(e, line)?,
                    "rec" if in_frame => pass.record(e, line, &mut scratch)?,
                    "rec" | "dataSignal" | "frameHeader" if trace_data => {
                        let reason = match stack.last() {
                            Some(open) if stack.iter().any(|s| s == "dataFrame") => format!(
                                "<{name}> inside <{open}>: an element before it is not closed                                  (not well-formed XML)"
                            ),
                            _ => format!("<{name}> outside a <dataFrame>"),
                        };
                        return Err(pass.bad(line, reason));
                    }
                    _ => {}
                }
                if !empty {
                    stack.push(name);
                }
            }
            Event::End(ref e) => {
                let name = e.name().as_ref().to_string();
                stack.pop();
                if name == "dataFrame" && stack.last().is_some_and(|s| s == "traceData") {
                    pass.end_frame(line)?;
                }
            }
            Event::Text(ref t) if !root_seen => {
                let text = t.xml_content(quick_xml::XmlVersion::Implicit1_0);
                if !text.trim().is_empty() {
                    return Err(pass.bad(
                        line,
                        format!(
                            "`{}` before any XML element: not an XML file (a SINUMERIK trace \
                             is XML)",
                            shorten(text.trim().lines().next().unwrap_or(""))
                        ),
                    ));
                }
            }
            Event::Eof => {
                let line = reader.get_ref().newlines + 1;
                if let Some(open) = stack.last() {
                    let after = match pass.last_record {
                        Some((t, l)) => format!(" after the record at t = {t} s (line {l})"),
                        None => String::new(),
                    };
                    return Err(pass.bad(
                        line,
                        format!(
                            "the file ends inside <{open}>{after}: truncated (the trace was cut \
                             while being written or copied)"
                        ),
                    ));
                }
                if !root_seen {
                    return Err(ImportError::Empty {
                        source_name: source.to_string(),
                    });
                }
                break;
            }
            _ => {}
        }
    }
    if !trace_data {
        return Err(pass.bad(
            reader.get_ref().newlines + 1,
            "no <traceData>: the file holds a trace setup but no recorded data",
        ));
    }
    if pass.listing.frames.iter().all(|f| f.records == 0) {
        return Err(pass.bad(
            reader.get_ref().newlines + 1,
            "no <rec> in any <dataFrame>: the trace holds no samples",
        ));
    }
    Ok((pass.listing, pass.sink))
}

/// Counts only.
struct CountSink;

impl Sink for CountSink {
    fn begin(
        &mut self,
        l: &SinumerikListing,
        f: usize,
        _: u64,
    ) -> Result<Vec<Option<usize>>, ImportError> {
        Ok(vec![None; l.frames[f].signals.len()])
    }
    fn sample(&mut self, _: usize, _: f64, _: f64, _: u64) -> Result<(), ImportError> {
        Ok(())
    }
}

/// Read the whole file for its signals and their counts (`feedscope import sinumerik --list`).
///
/// # Errors
/// As [`read_sinumerik`], without the choice of signals.
pub fn list_sinumerik(path: &Path) -> Result<SinumerikListing, ImportError> {
    let source = path.display().to_string();
    let f = open(path, &source)?;
    Ok(scan(f, &source, CountSink)?.0)
}

/// [`list_sinumerik`] of a trace held in memory or any reader.
///
/// # Errors
/// As [`list_sinumerik`].
pub fn list_sinumerik_from<R: BufRead>(
    r: R,
    source_name: &str,
) -> Result<SinumerikListing, ImportError> {
    Ok(scan(r, source_name, CountSink)?.0)
}

fn open(path: &Path, source: &str) -> Result<BufReader<std::fs::File>, ImportError> {
    let f = std::fs::File::open(path).map_err(|error| ImportError::Io {
        source_name: source.to_string(),
        error,
    })?;
    Ok(BufReader::with_capacity(1 << 16, f))
}

/// How a unit was decided, for the report.
#[derive(Debug, Clone)]
struct UnitChoice<U> {
    unit: U,
    rule: String,
}

/// The conversion: the two chosen signals, their units, the samples.
struct ConvertSink<'p> {
    params: &'p SinumerikParams,
    source: String,
    /// Names of the chosen signals (to find them in later frames).
    chosen: Option<(SignalDef, SignalDef)>,
    pos_unit: Option<UnitChoice<PositionUnit>>,
    eff_unit: Option<UnitChoice<EffortUnit>>,
    position: Channel,
    effort: Channel,
    notes: Vec<Diagnostic>,
}

impl ConvertSink<'_> {
    fn find_named(&self, f: &Frame, wanted: &str, what: &str) -> Result<usize, ImportError> {
        let hits: Vec<usize> = (0..f.signals.len())
            .filter(|&k| f.signals[k].is_named(wanted))
            .collect();
        match hits[..] {
            [k] => Ok(k),
            [] => Err(ImportError::Item {
                source_name: self.source.clone(),
                axis: self.params.axis.clone().unwrap_or_else(|| "-".into()),
                reason: format!(
                    "no signal `{wanted}` for the {what} (give an id such as f8, a key such as \
                     s12 or the NCK path); signals: {}",
                    signal_list(f, |_| true)
                ),
            }),
            _ => Err(ImportError::Item {
                source_name: self.source.clone(),
                axis: self.params.axis.clone().unwrap_or_else(|| "-".into()),
                reason: format!(
                    "`{wanted}` names several signals ({}); give the id",
                    hits.iter()
                        .map(|&k| f.signals[k].label())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            }),
        }
    }

    /// Choose the two signals of frame `fi`, the first with records.
    fn choose(&self, l: &SinumerikListing, fi: usize) -> Result<(usize, usize), ImportError> {
        let f = &l.frames[fi];
        // Which axis: named, the only one, or none needed when both signals are named.
        let axes = axes_of(f);
        let axes_text = axes_text(&axes);
        let need_axis =
            self.params.position_signal.is_none() || self.params.effort_signal.is_none();
        let axis: Option<String> = match &self.params.axis {
            Some(want) => {
                let squash = |s: &str| -> String {
                    s.chars()
                        .filter(|c| !c.is_whitespace())
                        .collect::<String>()
                        .to_ascii_lowercase()
                };
                let hit = axes
                    .iter()
                    .find(|(a, _)| squash(a) == squash(want))
                    .or_else(|| {
                        // `u1,7`: the whole bracket.
                        f.signals
                            .iter()
                            .find(|s| {
                                s.name.rfind('[').is_some_and(|k| {
                                    squash(&s.name[k..]) == format!("[{}]", squash(want))
                                })
                            })
                            .and_then(|s| axes.iter().find(|(a, _)| Some(a.as_str()) == s.axis()))
                    });
                match hit {
                    Some((a, _)) => Some(a.clone()),
                    None => {
                        return Err(ImportError::UnknownAxis {
                            source_name: self.source.clone(),
                            wanted: want.clone(),
                            found: axes_text.clone(),
                        })
                    }
                }
            }
            None if need_axis && axes.len() > 1 => {
                return Err(ImportError::BadParam(format!(
                    "{}: the trace records {} axes: {}; name one with --axis (the number in \
                     the signals' brackets, e.g. --axis {})",
                    self.source,
                    axes.len(),
                    axes_text,
                    axes[0].0
                )))
            }
            None => axes.first().map(|(a, _)| a.clone()),
        };
        let on_axis = |s: &SignalDef| axis.is_none() || s.axis() == axis.as_deref();
        let axis_label = axis.clone().unwrap_or_else(|| "-".into());
        let missing = |what: &str, flag: &str| ImportError::Item {
            source_name: self.source.clone(),
            axis: axis_label.clone(),
            reason: format!(
                "no {what} signal recorded (record one, or name one with {flag}); signals of \
                 the axis: {}",
                signal_list(f, on_axis)
            ),
        };
        let (dp, de) = f.default_signals(axis.as_deref());
        let pos = match &self.params.position_signal {
            Some(w) => self.find_named(f, w, "position")?,
            None => dp.ok_or_else(|| missing("actual position", "--position-signal"))?,
        };
        let eff = match &self.params.effort_signal {
            Some(w) => self.find_named(f, w, "effort")?,
            None => de.ok_or_else(|| missing("motor current or torque", "--effort-signal"))?,
        };
        Ok((pos, eff))
    }

    fn units(
        &self,
        pos: &SignalDef,
        eff: &SignalDef,
    ) -> Result<(UnitChoice<PositionUnit>, UnitChoice<EffortUnit>), ImportError> {
        let pu = if let Some(u) = self.params.position_unit {
            UnitChoice {
                unit: u,
                rule: "--position-unit".into(),
            }
        } else if let Some(u) = pos.described_unit(PositionUnit::from_symbol) {
            UnitChoice {
                unit: u,
                rule: "from its description".into(),
            }
        } else if pos
            .units_type
            .as_deref()
            .is_none_or(|u| u.eq_ignore_ascii_case("posn"))
        {
            UnitChoice {
                unit: PositionUnit::Millimetre,
                rule: "unitsType posn, metric basic system assumed; --position-unit inch for an \
                       inch machine"
                    .into(),
            }
        } else {
            return Err(ImportError::Item {
                source_name: self.source.clone(),
                axis: pos.axis().unwrap_or("-").to_string(),
                reason: format!(
                    "position signal {} has unitsType `{}`, not a position; give \
                     --position-unit if it is one",
                    pos.label(),
                    pos.units_type.as_deref().unwrap_or("")
                ),
            });
        };
        let ut = eff.units_type.as_deref().unwrap_or("").to_ascii_lowercase();
        let eu = if let Some(u) = self.params.effort_unit {
            UnitChoice {
                unit: u,
                rule: "--effort-unit".into(),
            }
        } else if let Some(u) = eff.described_unit(EffortUnit::from_symbol) {
            UnitChoice {
                unit: u,
                rule: "from its description".into(),
            }
        } else if ut == "current" {
            UnitChoice {
                unit: EffortUnit::Ampere,
                rule: "unitsType current".into(),
            }
        } else if ut == "torque" || (ut.is_empty() && eff.role() == SignalRole::Torque) {
            UnitChoice {
                unit: EffortUnit::NewtonMetre,
                rule: "a torque signal".into(),
            }
        } else {
            return Err(ImportError::Item {
                source_name: self.source.clone(),
                axis: eff.axis().unwrap_or("-").to_string(),
                reason: format!(
                    "effort signal {} has unitsType `{}`, not a current or torque; give \
                     --effort-unit a|ma|nm if it is one",
                    eff.label(),
                    eff.units_type.as_deref().unwrap_or("")
                ),
            });
        };
        Ok((pu, eu))
    }
}

/// `f8 /Nck/!SEMA/measPos1 [u1, 7] (posn)` for the signals that pass `keep`.
fn signal_list(f: &Frame, keep: impl Fn(&SignalDef) -> bool) -> String {
    let v: Vec<String> = f
        .signals
        .iter()
        .filter(|s| keep(s))
        .map(|s| format!("{} ({})", s.label(), s.units_type.as_deref().unwrap_or("-")))
        .collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

impl Sink for ConvertSink<'_> {
    fn begin(
        &mut self,
        l: &SinumerikListing,
        fi: usize,
        line: u64,
    ) -> Result<Vec<Option<usize>>, ImportError> {
        let f = &l.frames[fi];
        let mut slots = vec![None; f.signals.len()];
        if self.chosen.is_none() {
            let (p, e) = self.choose(l, fi)?;
            let (pu, eu) = self.units(&f.signals[p], &f.signals[e])?;
            self.pos_unit = Some(pu);
            self.eff_unit = Some(eu);
            self.chosen = Some((f.signals[p].clone(), f.signals[e].clone()));
            slots[p] = Some(0);
            slots[e] = Some(1);
            if p == e {
                return Err(ImportError::BadParam(format!(
                    "{}: position and effort are the same signal {}",
                    self.source,
                    f.signals[p].label()
                )));
            }
        } else if let Some((p, e)) = &self.chosen {
            for (slot, def) in [(0, p), (1, e)] {
                match f.signals.iter().position(|s| s.name == def.name) {
                    Some(k) => slots[k] = Some(slot),
                    None => self.notes.push(Diagnostic::new(
                        Code::SignalMissingInFrame,
                        format!(
                            "data frame {} (from line {line}) does not record {}: no samples \
                             from it",
                            fi + 1,
                            def.name
                        ),
                    )),
                }
            }
        }
        Ok(slots)
    }

    fn sample(&mut self, slot: usize, t: f64, v: f64, line: u64) -> Result<(), ImportError> {
        let source = &self.source;
        let bad = |reason: String| ImportError::Malformed {
            source_name: source.clone(),
            line,
            reason,
        };
        let (ch, si, what) = if slot == 0 {
            let u = self.pos_unit.as_ref().expect("unit chosen at begin").unit;
            let si = v * u.metres();
            units::check_position(si, u).map_err(|r| bad(format!("rec at t = {t} s: {r}")))?;
            (&mut self.position, si, "position")
        } else {
            let u = self.eff_unit.as_ref().expect("unit chosen at begin").unit;
            let si = v * u.si();
            units::check_effort(si, u).map_err(|r| bad(format!("rec at t = {t} s: {r}")))?;
            (&mut self.effort, si, "effort")
        };
        if let Some(&prev) = ch.time_s.last() {
            // Restored repeats sit on the signal's grid; a later frame must start after the
            // earlier one ends.
            if t <= prev {
                return Err(bad(format!(
                    "{what} sample at t = {t} s is not after the previous one at {prev} s: time \
                     not increasing (overlapping data frames?)"
                )));
            }
        }
        ch.time_s.push(t);
        ch.value.push(si);
        Ok(())
    }
}

/// Read a SINUMERIK trace file and convert one axis.
///
/// # Errors
/// [`ImportError::Io`]; [`ImportError::Malformed`] naming the line (XML, truncation, missing
/// attribute, non-numeric or non-finite value, time not increasing, absurd magnitude);
/// [`ImportError::UnknownAxis`] listing the recorded axes; [`ImportError::BadParam`] when
/// several axes were recorded and none named; [`ImportError::Item`] when the axis has no
/// position or effort signal, a named signal does not exist, or a converted signal has no valid
/// sample; [`ImportError::TooFewSamples`] when it has fewer than 4.
pub fn read_sinumerik(
    path: &Path,
    params: &SinumerikParams,
) -> Result<SinumerikImport, ImportError> {
    let source = path.display().to_string();
    let f = open(path, &source)?;
    parse_sinumerik(f, &source, params)
}

/// [`read_sinumerik`] of a trace held in memory or any reader.
///
/// # Errors
/// As [`read_sinumerik`].
pub fn parse_sinumerik<R: BufRead>(
    r: R,
    source_name: &str,
    params: &SinumerikParams,
) -> Result<SinumerikImport, ImportError> {
    let sink = ConvertSink {
        params,
        source: source_name.to_string(),
        chosen: None,
        pos_unit: None,
        eff_unit: None,
        position: Channel::default(),
        effort: Channel::default(),
        notes: Vec::new(),
    };
    let (listing, sink) = scan(r, source_name, sink)?;
    let (Some((pdef, edef)), Some(pu), Some(eu)) = (sink.chosen, sink.pos_unit, sink.eff_unit)
    else {
        // scan refuses a file without records, so the first frame with one chose.
        unreachable!("signals are chosen at the first record");
    };
    // Counts over all frames, by NCK path.
    let total = |def: &SignalDef| {
        let mut s = SignalStats::default();
        for f in &listing.frames {
            if let Some(k) = f.signals.iter().position(|x| x.name == def.name) {
                let x = &f.stats[k];
                s.written += x.written;
                s.restored += x.restored;
                s.invalid += x.invalid;
                s.irregular_gaps += x.irregular_gaps;
                for &t in &x.invalid_times_s {
                    if s.invalid_times_s.len() < INVALID_TIMES_KEPT {
                        s.invalid_times_s.push(t);
                    }
                }
                s.span_s = match (s.span_s, x.span_s) {
                    (Some((a, _)), Some((_, d))) => Some((a, d)),
                    (a, b) => a.or(b),
                };
                s.range = match (s.range, x.range) {
                    (Some((a, b)), Some((c, d))) => Some((a.min(c), b.max(d))),
                    (a, b) => a.or(b),
                };
            }
        }
        s
    };
    let (pstats, estats) = (total(&pdef), total(&edef));
    let axis = pdef.axis().unwrap_or("-").to_string();
    for (def, ch) in [(&pdef, &sink.position), (&edef, &sink.effort)] {
        if ch.is_empty() {
            let st = total(def);
            return Err(ImportError::Item {
                source_name: source_name.to_string(),
                axis: axis.clone(),
                reason: format!(
                    "signal {} has no valid sample ({} written, {} invalid): an empty channel",
                    def.label(),
                    st.written,
                    st.invalid
                ),
            });
        }
        if ch.len() < MIN_SAMPLES {
            return Err(ImportError::TooFewSamples {
                source_name: source_name.to_string(),
                channel: def.label(),
                found: ch.len(),
                needed: MIN_SAMPLES,
            });
        }
    }
    let mut warnings = sink.notes;
    for (def, st) in [(&pdef, &pstats), (&edef, &estats)] {
        if st.invalid > 0 {
            warnings.push(Diagnostic::new(
                Code::InvalidSamplesDropped,
                format!(
                    "{} of {} samples of {} were the control's invalid mark (|value| ≥ 9.2e18) \
                     and were dropped, first at t = {} s",
                    st.invalid,
                    st.written + st.restored,
                    def.label(),
                    st.invalid_times_s
                        .iter()
                        .map(|t| format!("{t:.6}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        if let Some(n) = def.datapoint_count {
            let have = st.written + st.restored;
            if listing.frames.len() == 1 && have != n {
                warnings.push(Diagnostic::new(
                    Code::DatapointCountMismatch,
                    format!(
                        "{} declares {n} samples, the records hold {} and {} repeats were \
                         restored ({have}): samples may be missing",
                        def.label(),
                        st.written,
                        st.restored
                    ),
                ));
            }
        }
        if st.irregular_gaps > 0 {
            warnings.push(Diagnostic::new(
                Code::IrregularGaps,
                format!(
                    "{} gaps in {} are not a whole number of its {} s interval: left as gaps",
                    st.irregular_gaps,
                    def.label(),
                    def.interval_s.unwrap_or(f64::NAN)
                ),
            ));
        }
    }
    let drop_outs: u64 = listing.frames.iter().filter_map(|f| f.drop_outs).sum();
    if drop_outs > 0 {
        warnings.push(Diagnostic::new(
            Code::DropOuts,
            format!("the control reports {drop_outs} data drop-outs (samples it lost)"),
        ));
    }
    let describe = |def: &SignalDef, st: &SignalStats, unit: &str, rule: &str| {
        let mut s = format!(
            "{} = {} \"{}\" ({unit}: {rule})",
            def.name, def.id, def.description
        );
        if st.restored > 0 {
            s.push_str(&format!("; {} change-only repeats restored", st.restored));
        }
        if st.invalid > 0 {
            s.push_str(&format!("; {} invalid samples dropped", st.invalid));
        }
        s
    };
    let mut prep = ChannelReport {
        source_key: describe(&pdef, &pstats, pu.unit.symbol(), &pu.rule),
        ..Default::default()
    };
    prep.finish(&sink.position);
    let mut erep = ChannelReport {
        source_key: describe(&edef, &estats, eu.unit.symbol(), &eu.rule),
        ..Default::default()
    };
    erep.finish(&sink.effort);
    let kind = eu.unit.kind();
    let effort_rule = format!(
        "{} = {}{}",
        kind.column(),
        erep.source_key,
        match eu.unit {
            EffortUnit::Milliampere => " / 1000",
            _ => "",
        }
    );
    let frames = listing.frames.iter().filter(|f| f.records > 0).count();
    let trace = Trace {
        position_m: sink.position,
        effort: sink.effort,
        effort_kind: kind,
        facts: RecordingFacts {
            recordings: Some(frames.max(1)),
            ..RecordingFacts::default()
        },
    };
    let time_zero = listing.frames.first().and_then(|f| f.start);
    let mut report = ImportReport {
        source_name: source_name.to_string(),
        time_zero,
        time_zero_rule: if time_zero.is_some() {
            "frameHeader startTime of the first data frame".into()
        } else {
            "the first data frame's time 0 (the file has no startTime)".into()
        },
        position: prep,
        effort: erep,
        effort_rule,
        warnings,
    };
    super::sampling_warnings(&mut report, &trace);
    // A servo trace resolves its band; the generic slow-sampling note is for polled logs.
    report
        .warnings
        .retain(|w| !(w.code == Code::SlowSampling && fast_trace(&trace)));
    Ok(SinumerikImport {
        imported: Imported { trace, report },
        position: (pdef, pstats),
        effort: (edef, estats),
        listing,
    })
}

/// Both channels sampled at 100 Hz or faster (a servo or IPO trace), where the generic
/// "slow sampling" warning does not apply.
pub(super) fn fast_trace(t: &Trace) -> bool {
    let med = |c: &Channel| {
        let mut d: Vec<f64> = c.time_s.windows(2).map(|w| w[1] - w[0]).collect();
        if d.is_empty() {
            return f64::INFINITY;
        }
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    };
    med(&t.position_m) <= 0.01 && med(&t.effort) <= 0.01
}

// ---------------------------------------------------------------------------------------------
// Writing (tests and demos).

/// Options of [`write_sinumerik_xml`].
#[derive(Debug, Clone, PartialEq)]
pub struct SinumerikWriteParams {
    /// `frameHeader startTime`, the trace's time 0.
    pub start: Timestamp,
    /// Leave out an effort value equal to the one before, as the control does for servo
    /// signals (only for a channel sampled at one constant interval; the first and last
    /// samples are always written). Default true.
    pub change_only: bool,
    /// `sessionName`.
    pub session_name: String,
}

impl Default for SinumerikWriteParams {
    fn default() -> Self {
        Self {
            start: Timestamp {
                unix_s: 1_767_600_000,
                nanos: 0,
            },
            change_only: true,
            session_name: "feedscope twin".into(),
        }
    }
}

/// XML attribute text.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Median interval (s) of a channel and whether every interval is within 1 µs of it (the
/// records' time resolution).
fn uniform_interval(c: &Channel) -> (f64, bool) {
    let mut d: Vec<f64> = c.time_s.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return (f64::NAN, false);
    }
    d.sort_by(f64::total_cmp);
    let med = d[d.len() / 2];
    let uniform = d.iter().all(|x| (x - med).abs() <= 1e-6);
    (med, uniform)
}

/// Write traces in the layout of a SINUMERIK Operate servo trace file: one data frame, per axis
/// the actual position of measuring system 1 (`/Nck/!SEMA/measPos1 [u1, N]`, mm,
/// `unitsType="posn"`, every sample written, as the control writes IPO signals) and the actual
/// current (`/Nck/!SD/nckServoDataActCurr32 [u1, N]`, A) or the torque
/// (`/Nck/!SD/nckServoDataCmdTorque64 [u1, N]`, N·m, `unitsType="torque"`) left out where it
/// repeats ([`SinumerikWriteParams::change_only`]). Values with 6 decimals (1 nm, 1 µA,
/// 1 µN·m), times with 6 decimals (1 µs), as the control writes them.
///
/// For tests and demos: it makes the files that the twin's round trip reads back
/// (`feedscope simulate` → this → `feedscope import sinumerik` → `feedscope estimate`). The
/// structure follows a real Operate trace; the torque signal's `unitsType` is an assumption.
///
/// # Errors
/// I/O errors of the writer; [`std::io::ErrorKind::InvalidInput`] for a channel without
/// samples.
pub fn write_sinumerik_xml<W: Write>(
    axes: &[(u32, &Trace)],
    params: &SinumerikWriteParams,
    w: W,
) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(w);
    struct Sig<'a> {
        id: String,
        key: String,
        name: String,
        description: &'static str,
        units_type: &'static str,
        data_type: &'static str,
        event: u32,
        ch: &'a Channel,
        scale: f64,
        change_only: bool,
        interval: f64,
    }
    let mut sigs: Vec<Sig<'_>> = Vec::new();
    for &(axis, t) in axes {
        for (k, ch) in [&t.position_m, &t.effort].into_iter().enumerate() {
            if ch.is_empty() {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("axis {axis}: a channel without samples"),
                ));
            }
            let (interval, uniform) = uniform_interval(ch);
            let n = sigs.len() + 1;
            let (name, description, units_type, data_type, event, scale) = if k == 0 {
                (
                    format!("/Nck/!SEMA/measPos1 [u1, {axis}]"),
                    "Actual position value for measuring system 1.",
                    "posn",
                    "double",
                    1,
                    1e3,
                )
            } else if t.effort_kind == EffortKind::CurrentA {
                (
                    format!("/Nck/!SD/nckServoDataActCurr32 [u1, {axis}]"),
                    "Torque-prod. Current act. Val. i(q) (32 bit)",
                    "current",
                    "float",
                    255,
                    1.0,
                )
            } else {
                (
                    format!("/Nck/!SD/nckServoDataCmdTorque64 [u1, {axis}]"),
                    "Torque setpoint (64 bit)",
                    "torque",
                    "double",
                    255,
                    1.0,
                )
            };
            sigs.push(Sig {
                id: format!("f{n}"),
                key: format!("s{n}"),
                name,
                description,
                units_type,
                data_type,
                event,
                ch,
                scale,
                change_only: k == 1 && params.change_only && uniform,
                interval: if interval.is_finite() { interval } else { 0.0 },
            });
        }
    }
    // Records: every time of every channel at 1 µs resolution, merged.
    let us = |t: f64| (t * 1e6).round() as i64;
    for s in &sigs {
        if s.ch.time_s.windows(2).any(|p| us(p[1]) <= us(p[0])) {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "{}: samples closer than the records' 1 µs resolution",
                    s.name
                ),
            ));
        }
    }
    let mut times: Vec<i64> = sigs
        .iter()
        .flat_map(|s| s.ch.time_s.iter().map(|&t| us(t)))
        .collect();
    times.sort_unstable();
    times.dedup();
    // The trace's time 0 is the frame's start (shifted when the trace starts before it).
    let t0 = times.first().copied().unwrap_or(0).min(0);
    let stop = times.last().copied().unwrap_or(0) - t0;
    writeln!(w, "<?xml version=\"1.0\" encoding=\"utf-8\" ?>")?;
    writeln!(
        w,
        "<!--XML file written by feedscope (write_sinumerik_xml) in the layout of SINUMERIK \
         Operate servo trace files-->"
    )?;
    writeln!(w, "<traceSession version=\"01.00.03.02\">")?;
    writeln!(w, "<traceCaptureSetup>")?;
    writeln!(
        w,
        " <sessionSettings sessionName=\"{}\" archiveSetting=\"NCU\"/>",
        esc(&params.session_name)
    )?;
    writeln!(w, " <signalSettings>")?;
    for s in &sigs {
        writeln!(
            w,
            "  <signal domain=\"NCU_1\" event=\"{}\" description=\"{}\" displayRes=\"5\" \
             eventChannel=\"1\" key=\"{}\" name=\"{}\" unitsType=\"{}\" dataType=\"{}\"/>",
            s.event,
            esc(s.description),
            s.key,
            esc(&s.name),
            s.units_type,
            s.data_type
        )?;
    }
    writeln!(w, " </signalSettings>")?;
    writeln!(w, "</traceCaptureSetup>")?;
    writeln!(w)?;
    writeln!(w, "<traceData dataFrames=\"1\">")?;
    writeln!(w, " <dataFrame>")?;
    writeln!(
        w,
        "  <frameHeader stopTriggerInc=\"0.000000\" startTriggerInc=\"0.000000\" dropOuts=\"0\" \
         startTime=\"{}\" stopInc=\"{:.6}\"/>",
        params.start,
        stop as f64 * 1e-6
    )?;
    for s in &sigs {
        writeln!(
            w,
            "  <dataSignal domain=\"NCU_1\" interval=\"{:.6}\" id=\"{}\" event=\"{}\" \
             description=\"{}\" displayRes=\"5\" eventChannel=\"1\" datapointCount=\"{}\" \
             key=\"{}\" name=\"{}\" unitsType=\"{}\" dataType=\"{}\"/>",
            s.interval,
            s.id,
            s.event,
            esc(s.description),
            s.ch.len(),
            s.key,
            esc(&s.name),
            s.units_type,
            s.data_type
        )?;
    }
    let mut next = vec![0usize; sigs.len()];
    let mut last_text: Vec<Option<String>> = vec![None; sigs.len()];
    let mut line = String::new();
    for &t in &times {
        line.clear();
        let mut any = false;
        for (k, s) in sigs.iter().enumerate() {
            let j = next[k];
            if j < s.ch.len() && us(s.ch.time_s[j]) == t {
                next[k] += 1;
                let text = format!("{:.6}", s.ch.value[j] * s.scale);
                let edge = j == 0 || j + 1 == s.ch.len();
                if s.change_only && !edge && last_text[k].as_deref() == Some(text.as_str()) {
                    continue;
                }
                use std::fmt::Write as _;
                let _ = write!(line, " {}=\"{}\"", s.id, text);
                last_text[k] = Some(text);
                any = true;
            }
        }
        if any {
            writeln!(w, "  <rec time=\"{:.6}\"{line}/>", (t - t0) as f64 * 1e-6)?;
        }
    }
    writeln!(w, " </dataFrame>")?;
    writeln!(w, "</traceData>")?;
    writeln!(w, "</traceSession>")?;
    w.flush()
}

#[cfg(test)]
mod tests;
