//! Reading and writing trace CSV files, fast and strictly.
//!
//! A reading thread reads the file in blocks of a few megabytes, ahead of the parser; each
//! block is cut at line ends into one piece per worker thread and the pieces are parsed in
//! parallel, then appended in order. Memory stays at the parsed samples (16 bytes each) plus two
//! blocks. Errors carry the file name and the 1-based line number counted over the whole file
//! (comments and header included).

use std::fs::File;
use std::io::{Read, Write};
use std::path::Path;

use feedscope::trace::{Channel, EffortKind, GlitchParams, RecordingFacts, Trace};

use super::format::Layout;
use super::limits;
use super::read::{
    choose_effort, duplicate_columns, name_problem, screen_and_check, shorten, show_name,
    EffortChoice, Origin, ReadOptions, ReadReport, TraceError, MAX_LINE_BYTES,
};
use crate::fixed::push_fixed;

/// Bytes read ahead of the parser at a time.
pub(super) const BLOCK_BYTES: usize = 8 << 20;

/// Read an open CSV file (its magic already checked: not Parquet) in blocks of about
/// `block_bytes` (tests use small blocks to cross boundaries), then end with the checks of
/// every reader; `path` is opened again only to find the lines of dropped samples.
pub(super) fn read_file(
    file: File,
    path: &Path,
    name: &str,
    opts: &ReadOptions,
    glitch: &GlitchParams,
    block_bytes: usize,
) -> Result<(Trace, ReadReport), TraceError> {
    let size_hint = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut reader = BlockParser::new(name.to_string(), opts, size_hint);
    // A reading thread fills the next block while the workers parse this one. Blocks hold
    // complete lines only (a partial last line moves to the next block); two buffers circulate.
    let (full_tx, full_rx) = std::sync::mpsc::sync_channel::<std::io::Result<(Vec<u8>, bool)>>(1);
    let (empty_tx, empty_rx) = std::sync::mpsc::channel::<Vec<u8>>();
    let result = std::thread::scope(|scope| {
        // Owned by this closure, so an early error drops them and the reading thread ends.
        let (full_rx, empty_tx) = (full_rx, empty_tx);
        scope.spawn(move || read_blocks(file, block_bytes, &full_tx, &empty_rx));
        for _ in 0..2 {
            let _ = empty_tx.send(Vec::new());
        }
        for msg in full_rx.iter() {
            let (buf, eof) = msg.map_err(|e| block_error(name, e, reader.lines))?;
            let consumed = reader.feed(&buf, eof)?;
            debug_assert!(eof || consumed == buf.len());
            // The reader stops when its buffers stop coming back; a failed send just means it
            // is done.
            let _ = empty_tx.send(buf);
        }
        Ok(())
    });
    result?;
    let (trace, report, layout) = reader.finish()?;
    // Lines of dropped samples come from a second pass over the file, only when something was
    // dropped: keeping a line number per sample would cost half again the memory.
    let locate = |wanted: &[usize]| match File::open(path) {
        Ok(f) => position_lines(
            std::io::BufReader::with_capacity(1 << 16, f),
            &layout,
            wanted,
        )
        .unwrap_or_else(|_| vec![None; wanted.len()]),
        Err(_) => vec![None; wanted.len()],
    };
    screen_and_check(name, (trace, report), glitch, Origin::Line, locate)
}

/// What a streamed CSV read hands out after each block: the samples parsed from it.
#[derive(Debug)]
pub struct TraceChunk<'a> {
    /// What the file's `# fact` lines said (all of them come before the header).
    pub facts: &'a feedscope::trace::RecordingFacts,
    /// The effort column of a wide-layout file; `None` for the long layout, whose rows say.
    pub wide_effort: Option<EffortKind>,
    /// Position samples (m).
    pub position_m: &'a Channel,
    /// Current samples (A).
    pub current_a: &'a Channel,
    /// Torque samples (N·m).
    pub torque_nm: &'a Channel,
    /// Bytes of the file parsed so far, and its size (to size buffers for the whole file).
    pub bytes_read: u64,
    /// See `bytes_read`.
    pub file_bytes: u64,
}

/// Read a CSV trace block by block, handing each block's samples to `on_chunk` as soon as
/// they are parsed, in file order; `on_chunk` returns `false` to stop reading. Returns the
/// read report, or `None` when stopped. No glitch screening or whole-trace check is made: the
/// caller streams what [`read_file`] would check afterwards.
pub(super) fn stream_file<E: From<TraceError>>(
    file: File,
    name: &str,
    opts: &ReadOptions,
    block_bytes: usize,
    on_chunk: &mut dyn FnMut(TraceChunk<'_>) -> Result<bool, E>,
) -> Result<Option<ReadReport>, E> {
    let size_hint = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut reader = BlockParser::new(name.to_string(), opts, size_hint);
    reader.streaming = true;
    let (full_tx, full_rx) = std::sync::mpsc::sync_channel::<std::io::Result<(Vec<u8>, bool)>>(1);
    let (empty_tx, empty_rx) = std::sync::mpsc::channel::<Vec<u8>>();
    let stopped = std::thread::scope(|scope| -> Result<bool, E> {
        let (full_rx, empty_tx) = (full_rx, empty_tx);
        scope.spawn(move || read_blocks(file, block_bytes, &full_tx, &empty_rx));
        for _ in 0..2 {
            let _ = empty_tx.send(Vec::new());
        }
        for msg in full_rx.iter() {
            let (buf, eof) = msg.map_err(|e| block_error(name, e, reader.lines))?;
            reader.feed(&buf, eof)?;
            let _ = empty_tx.send(buf);
            let wide_effort = match &reader.header {
                Some(Header::Wide { effort_kind, .. }) => Some(*effort_kind),
                _ => None,
            };
            let go_on = on_chunk(TraceChunk {
                facts: &reader.facts,
                wide_effort,
                position_m: &reader.pos,
                current_a: &reader.cur,
                torque_nm: &reader.tor,
                bytes_read: reader.bytes_seen,
                file_bytes: size_hint,
            })?;
            reader.clear_handed_out();
            if !go_on {
                return Ok(true);
            }
        }
        Ok(false)
    })?;
    if stopped {
        return Ok(None);
    }
    let Some(header) = &reader.header else {
        return Err(TraceError::Empty {
            source_name: name.to_string(),
        }
        .into());
    };
    let layout = match header {
        Header::Wide { .. } => Layout::Wide,
        Header::Long { .. } => Layout::Long,
    };
    Ok(Some(ReadReport {
        ignored_rows: reader.ignored_rows,
        ignored_channels: reader.ignored_names,
        lines: reader.lines,
        layout: Some(layout),
        unterminated_last_line: reader.cut_last_line.then_some(reader.lines),
        ..ReadReport::default()
    }))
}

/// Parse a CSV trace held in memory, then end with the checks of every reader.
pub(super) fn parse_bytes(
    bytes: &[u8],
    source_name: &str,
    opts: &ReadOptions,
    glitch: &GlitchParams,
) -> Result<(Trace, ReadReport), TraceError> {
    let mut reader = BlockParser::new(source_name.to_string(), opts, bytes.len() as u64);
    let consumed = reader.feed(bytes, true)?;
    debug_assert_eq!(consumed, bytes.len());
    let (trace, report, layout) = reader.finish()?;
    let locate = |wanted: &[usize]| {
        position_lines(bytes, &layout, wanted).unwrap_or_else(|_| vec![None; wanted.len()])
    };
    screen_and_check(source_name, (trace, report), glitch, Origin::Line, locate)
}

/// Write a trace as CSV in user units: time in s with 6 decimals (1 µs), position in mm with
/// 6 decimals (1 nm), current (A) or torque (N·m) with 6 decimals, as a controller logger
/// would.
///
/// The long layout merges both channels in time order. The wide layout needs both channels on
/// the same timestamps.
///
/// # Errors
/// I/O errors; `InvalidInput` when the wide layout is asked for channels with different
/// timestamps.
pub fn write_csv<W: Write>(trace: &Trace, w: W, layout: Layout) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(w);
    let effort = trace.effort_kind.column();
    for (key, value) in trace.facts.to_pairs() {
        writeln!(w, "# fact {key} = {value}")?;
    }
    match layout {
        Layout::Long => {
            writeln!(w, "time_s,channel,value")?;
            let (p, e) = (&trace.position_m, &trace.effort);
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
            if trace.position_m.time_s != trace.effort.time_s {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    "the wide layout needs position and effort on the same timestamps",
                ));
            }
            writeln!(w, "time_s,position_mm,{effort}")?;
            let mut line = Vec::with_capacity(64);
            for k in 0..trace.position_m.len() {
                line.clear();
                push_fixed(&mut line, trace.position_m.time_s[k], 6);
                line.push(b',');
                push_fixed(&mut line, trace.position_m.value[k] * 1e3, 6);
                line.push(b',');
                push_fixed(&mut line, trace.effort.value[k], 6);
                line.push(b'\n');
                w.write_all(&line)?;
            }
        }
    }
    w.flush()
}

/// 1-based lines of the position samples with the given indices (ascending; counted from 0 in
/// file order) in a CSV file that parsed without error with `layout`. The line rules are the
/// parser's: a BOM, comments and blank lines, the header, then the rows that hold a position.
/// An index past the end gets `None`.
fn position_lines<R: std::io::BufRead>(
    mut src: R,
    layout: &CsvLayout,
    wanted: &[usize],
) -> std::io::Result<Vec<Option<u64>>> {
    let mut out = vec![None; wanted.len()];
    let (mut line_no, mut count, mut w) = (0u64, 0usize, 0usize);
    let mut header_seen = false;
    let mut buf = Vec::new();
    while w < wanted.len() {
        buf.clear();
        if src.read_until(layout.term, &mut buf)? == 0 {
            break;
        }
        line_no += 1;
        let mut l = &buf[..];
        if line_no == 1 {
            l = l.strip_prefix(&[0xEF, 0xBB, 0xBF]).unwrap_or(l);
        }
        l = l.strip_suffix(&[layout.term]).unwrap_or(l);
        let line = trim_line(l);
        if line.is_empty() || line[0] == b'#' {
            continue;
        }
        if !header_seen {
            header_seen = true;
            continue;
        }
        let holds_position = match &layout.header {
            Header::Long { .. } => line
                .splitn(3, |&b| b == b',')
                .nth(1)
                .map(trim_field)
                .is_some_and(|c| c == b"position_mm" || c == b"position_m"),
            Header::Wide { position, .. } => line
                .split(|&b| b == b',')
                .nth(*position)
                .map(trim_field)
                .is_some_and(|c| !c.is_empty()),
        };
        if holds_position {
            while w < wanted.len() && wanted[w] == count {
                out[w] = Some(line_no);
                w += 1;
            }
            count += 1;
        }
    }
    Ok(out)
}

/// What [`position_lines`] needs to find samples again in a CSV file.
struct CsvLayout {
    term: u8,
    header: Header,
}

/// Read `file` in blocks of about `block_bytes` that end at a line terminator (except at the
/// end of the file) and send them with an end-of-file flag, reusing the buffers sent back.
/// The reading thread's error payload for a line longer than [`MAX_LINE_BYTES`]; the parser
/// side turns it into [`TraceError::LineTooLong`] with the line number it has reached.
#[derive(Debug)]
struct LineTooLong;

impl std::fmt::Display for LineTooLong {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "a line longer than {MAX_LINE_BYTES} bytes")
    }
}

impl std::error::Error for LineTooLong {}

/// The error of a failed block read: [`TraceError::LineTooLong`] for the thread's marker (the
/// long line is the one after the `lines_parsed` lines handed over so far), else
/// [`TraceError::Io`].
fn block_error(name: &str, error: std::io::Error, lines_parsed: u64) -> TraceError {
    if error.get_ref().is_some_and(|e| e.is::<LineTooLong>()) {
        TraceError::LineTooLong {
            source_name: name.to_string(),
            line: lines_parsed + 1,
            max_bytes: MAX_LINE_BYTES,
        }
    } else {
        TraceError::Io {
            source_name: name.to_string(),
            error,
        }
    }
}

fn read_blocks(
    mut file: File,
    block_bytes: usize,
    full: &std::sync::mpsc::SyncSender<std::io::Result<(Vec<u8>, bool)>>,
    empty: &std::sync::mpsc::Receiver<Vec<u8>>,
) {
    let mut carry: Vec<u8> = Vec::new();
    let mut term = None;
    loop {
        let Ok(mut buf) = empty.recv() else { return };
        buf.clear();
        buf.extend_from_slice(&carry);
        carry.clear();
        // Grow until at least one whole line is in: a line longer than a block still works,
        // up to MAX_LINE_BYTES (`/dev/zero` named as a trace would grow without end).
        // `read_to_end` fills the spare capacity without zeroing it first.
        let eof = loop {
            let start = buf.len();
            buf.reserve(block_bytes);
            let eof = match (&mut file).take(block_bytes as u64).read_to_end(&mut buf) {
                Ok(n) => n < block_bytes,
                Err(e) => {
                    let _ = full.send(Err(e));
                    return;
                }
            };
            let t = *term.get_or_insert_with(|| line_terminator(&buf));
            if eof {
                break true;
            }
            if let Some(k) = memchr::memrchr(t, &buf[start..]) {
                carry.extend_from_slice(&buf[start + k + 1..]);
                buf.truncate(start + k + 1);
                break false;
            }
            // No line end in the whole buffer: it is one line so far (the carry holds none).
            if buf.len() > MAX_LINE_BYTES {
                let _ = full.send(Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    LineTooLong,
                )));
                return;
            }
        };
        if full.send(Ok((buf, eof))).is_err() || eof {
            return;
        }
    }
}

/// The line terminator of a file from its first block: LF, or a bare CR (old Mac style) when
/// the block has CRs but no LF at all.
fn line_terminator(buf: &[u8]) -> u8 {
    if memchr::memchr(b'\n', buf).is_none() && memchr::memchr(b'\r', buf).is_some() {
        b'\r'
    } else {
        b'\n'
    }
}

/// Which channel a long-layout row belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    Position,
    Current,
    Torque,
}

#[derive(Debug, Clone)]
enum Header {
    /// `time, channel, value`.
    Long { time_scale: f64 },
    /// Column indices.
    Wide {
        fields: usize,
        time: usize,
        time_scale: f64,
        position: usize,
        position_scale: f64,
        effort: usize,
        effort_kind: EffortKind,
        names: Vec<String>,
    },
}

/// Samples of one piece, with the local line of each channel's first sample.
#[derive(Default)]
struct Piece {
    pos: Channel,
    cur: Channel,
    tor: Channel,
    first_line: [u64; 3],
    lines: u64,
    ignored_rows: u64,
    ignored_names: Vec<String>,
}

struct BlockParser {
    name: String,
    effort_choice: Option<EffortKind>,
    threads: usize,
    size_hint: u64,
    terminator: Option<u8>,
    header: Option<Header>,
    lines: u64,
    pos: Channel,
    cur: Channel,
    tor: Channel,
    ignored_rows: u64,
    ignored_names: Vec<String>,
    facts: RecordingFacts,
    bom_checked: bool,
    /// Bytes fed so far (for [`BlockParser::reserve_for_file`]).
    bytes_seen: u64,
    /// Whether the channels were reserved for the whole file.
    reserved: bool,
    /// The file's last data line has no terminator (see [`ReadReport::unterminated_last_line`]).
    cut_last_line: bool,
    /// Samples are taken out as they are parsed (handed out, then [`BlockParser::clear_handed_out`]): nothing is
    /// reserved for the whole file.
    streaming: bool,
    /// The last time of each channel (position, current, torque) taken out, for the
    /// increasing-time check across what was taken.
    last_time: [Option<f64>; 3],
}

impl BlockParser {
    fn new(name: String, opts: &ReadOptions, size_hint: u64) -> Self {
        let threads = if opts.threads == 0 {
            rayon::current_num_threads().max(1)
        } else {
            opts.threads
        };
        Self {
            name,
            effort_choice: opts.effort,
            threads,
            size_hint,
            terminator: None,
            header: None,
            lines: 0,
            pos: Channel::default(),
            cur: Channel::default(),
            tor: Channel::default(),
            ignored_rows: 0,
            ignored_names: Vec::new(),
            facts: RecordingFacts::default(),
            bom_checked: false,
            bytes_seen: 0,
            reserved: false,
            cut_last_line: false,
            streaming: false,
            last_time: [None; 3],
        }
    }

    /// Forget the samples handed out (keeping the room they took, for the next block's),
    /// remembering each channel's last time.
    fn clear_handed_out(&mut self) {
        for (k, ch) in [&mut self.pos, &mut self.cur, &mut self.tor]
            .into_iter()
            .enumerate()
        {
            if let Some(&t) = ch.time_s.last() {
                self.last_time[k] = Some(t);
            }
            ch.time_s.clear();
            ch.value.clear();
        }
    }

    /// Parse all complete lines of `buf` (all of it when `eof`); returns the bytes consumed.
    fn feed(&mut self, buf: &[u8], eof: bool) -> Result<usize, TraceError> {
        let mut off = 0;
        if !self.bom_checked && (buf.len() >= 3 || eof) {
            self.bom_checked = true;
            if buf.starts_with(&[0xEF, 0xBB, 0xBF]) {
                off = 3;
            }
        }
        let term = *self.terminator.get_or_insert_with(|| line_terminator(buf));
        if eof && !matches!(buf.last(), None | Some(b'\n' | b'\r')) {
            let start = memchr::memrchr(term, buf).map_or(0, |k| k + 1);
            let last = trim_line(&buf[start..]);
            self.cut_last_line = !last.is_empty() && last[0] != b'#';
        }
        // Only complete lines now; the rest waits for the next block.
        let end = if eof {
            buf.len()
        } else {
            match memchr::memrchr(term, buf) {
                Some(k) => k + 1,
                None => return Ok(off),
            }
        };
        // Header first: skip comments and blank lines.
        while self.header.is_none() && off < end {
            let line_end = memchr::memchr(term, &buf[off..end]).map_or(end, |k| off + k);
            let line = trim_line(&buf[off..line_end]);
            self.lines += 1;
            off = (line_end + 1).min(end);
            if line.is_empty() || line[0] == b'#' {
                if let Some((key, value)) = fact_line(line) {
                    self.facts
                        .set(&key, &value)
                        .map_err(|reason| TraceError::BadFact {
                            source_name: self.name.clone(),
                            line: self.lines,
                            reason,
                        })?;
                }
                continue;
            }
            self.header = Some(self.parse_header(line)?);
        }
        let Some(header) = self.header.clone() else {
            return Ok(end);
        };
        if off >= end {
            return Ok(end);
        }
        // Cut [off, end) into pieces at line ends and parse them in parallel.
        let body = &buf[off..end];
        let n = if body.len() < (1 << 20) {
            1
        } else {
            self.threads
        };
        let mut cuts = vec![0usize];
        for k in 1..n {
            let target = body.len() * k / n;
            let prev = *cuts.last().unwrap_or(&0);
            if target <= prev {
                continue;
            }
            match memchr::memchr(term, &body[target..]) {
                Some(j) if target + j + 1 < body.len() => cuts.push(target + j + 1),
                _ => break,
            }
        }
        cuts.push(body.len());
        let pieces: Vec<&[u8]> = cuts.windows(2).map(|w| &body[w[0]..w[1]]).collect();
        let results: Vec<Result<Piece, (u64, TraceError)>> = if pieces.len() == 1 {
            vec![parse_piece(pieces[0], term, &header, &self.name)]
        } else {
            use rayon::prelude::*;
            pieces
                .par_iter()
                .map(|p| parse_piece(p, term, &header, &self.name))
                .collect()
        };
        for r in results {
            let piece = r.map_err(|(local, e)| relocate(e, self.lines + local))?;
            self.append(piece)?;
        }
        self.bytes_seen += end as u64;
        if !self.reserved && !eof && !self.streaming {
            self.reserve_for_file();
        }
        Ok(end)
    }

    /// Reserve every channel for the whole file at the sample density seen so far, so that
    /// growing never reallocates and copies; capacity that stays unused is never touched.
    fn reserve_for_file(&mut self) {
        if self.bytes_seen == 0 || self.pos.is_empty() && self.cur.is_empty() && self.tor.is_empty()
        {
            return;
        }
        self.reserved = true;
        let ratio = self.size_hint as f64 / self.bytes_seen as f64;
        for ch in [&mut self.pos, &mut self.cur, &mut self.tor] {
            let want = (ch.len() as f64 * ratio * 1.05) as usize + 64;
            ch.time_s.reserve(want.saturating_sub(ch.len()));
            ch.value.reserve(want.saturating_sub(ch.len()));
        }
    }

    fn parse_header(&mut self, line: &[u8]) -> Result<Header, TraceError> {
        let text = String::from_utf8_lossy(line);
        let names: Vec<String> = text
            .split(',')
            .map(|s| s.trim().trim_matches('"').to_ascii_lowercase())
            .collect();
        let bad = |reason: String| TraceError::BadHeader {
            source_name: self.name.clone(),
            line: self.lines,
            found: shorten(line),
            reason,
        };
        if let Some(reason) = foreign_header(&text) {
            return Err(bad(reason));
        }
        for (k, n) in names.iter().enumerate() {
            if let Some(why) = name_problem(n.as_bytes()) {
                return Err(bad(format!(
                    "column {} name `{}` {why}",
                    k + 1,
                    show_name(n.as_bytes())
                )));
            }
        }
        if let Some(reason) = duplicate_columns(&names) {
            return Err(bad(reason));
        }
        let time = names
            .iter()
            .position(|n| n == "time_s" || n == "time_ms")
            .ok_or_else(|| {
                bad("the first header needs a time column `time_s` or `time_ms`".into())
            })?;
        let time_scale = if names[time] == "time_ms" { 1e-3 } else { 1.0 };
        if names.len() == 3 && names[1] == "channel" && names[2] == "value" && time == 0 {
            return Ok(Header::Long { time_scale });
        }
        let position = names
            .iter()
            .position(|n| n == "position_mm" || n == "position_m")
            .ok_or_else(|| {
                bad(
                    "expected `time_s,channel,value` (long layout) or a `position_mm` column \
                     (wide layout)"
                        .into(),
                )
            })?;
        let position_scale = if names[position] == "position_mm" {
            1e-3
        } else {
            1.0
        };
        let cur = names.iter().position(|n| n == "current_a");
        let tor = names.iter().position(|n| n == "torque_nm");
        let (effort, effort_kind) = match choose_effort(cur, tor, self.effort_choice) {
            Ok(picked) => picked,
            Err(EffortChoice::Ambiguous) => {
                return Err(TraceError::AmbiguousEffort {
                    source_name: self.name.clone(),
                })
            }
            Err(EffortChoice::Missing(k)) => {
                return Err(TraceError::MissingChannel {
                    source_name: self.name.clone(),
                    channel: k.column().into(),
                    found: names.join(", "),
                })
            }
            Err(EffortChoice::Neither) => {
                return Err(bad("no `current_a` or `torque_nm` column".into()));
            }
        };
        Ok(Header::Wide {
            fields: names.len(),
            time,
            time_scale,
            position,
            position_scale,
            effort,
            effort_kind,
            names,
        })
    }

    fn append(&mut self, piece: Piece) -> Result<(), TraceError> {
        let base = self.lines;
        let taken = self.last_time;
        let chans = [
            (&mut self.pos, piece.pos, "position"),
            (&mut self.cur, piece.cur, "current_a"),
            (&mut self.tor, piece.tor, "torque_nm"),
        ];
        for (k, (dst, src, name)) in chans.into_iter().enumerate() {
            let prev = dst.time_s.last().copied().or(taken[k]);
            if let (Some(prev), Some(&first)) = (prev, src.time_s.first()) {
                if first.partial_cmp(&prev) != Some(std::cmp::Ordering::Greater) {
                    return Err(TraceError::TimeNotIncreasing {
                        source_name: self.name.clone(),
                        channel: name.into(),
                        line: base + piece.first_line[k],
                        time_s: first,
                        previous_time_s: prev,
                    });
                }
            }
            if dst.time_s.is_empty() {
                *dst = src;
            } else {
                dst.time_s.extend_from_slice(&src.time_s);
                dst.value.extend_from_slice(&src.value);
            }
        }
        self.lines += piece.lines;
        self.ignored_rows += piece.ignored_rows;
        for n in piece.ignored_names {
            if self.ignored_names.len() < 16 && !self.ignored_names.contains(&n) {
                self.ignored_names.push(n);
            }
        }
        Ok(())
    }

    /// The trace and report as read, and what finding a sample's line again needs; the final
    /// checks are [`screen_and_check`]'s.
    fn finish(self) -> Result<(Trace, ReadReport, CsvLayout), TraceError> {
        let name = self.name;
        let header = self.header.ok_or_else(|| TraceError::Empty {
            source_name: name.clone(),
        })?;
        let csv_layout = CsvLayout {
            // Set by the first `feed`, which every file gets; LF for an empty input.
            term: self.terminator.unwrap_or(b'\n'),
            header: header.clone(),
        };
        let (effort, effort_kind, layout) = match header {
            Header::Wide { effort_kind, .. } => {
                let ch = match effort_kind {
                    EffortKind::CurrentA => self.cur,
                    EffortKind::TorqueNm => self.tor,
                };
                (ch, effort_kind, Layout::Wide)
            }
            Header::Long { .. } => {
                let seen = || {
                    let mut v = Vec::new();
                    if !self.pos.is_empty() {
                        v.push("position");
                    }
                    if !self.cur.is_empty() {
                        v.push("current_a");
                    }
                    if !self.tor.is_empty() {
                        v.push("torque_nm");
                    }
                    let mut s: Vec<String> = v.into_iter().map(String::from).collect();
                    s.extend(self.ignored_names.iter().cloned());
                    if s.is_empty() {
                        "none".to_string()
                    } else {
                        s.join(", ")
                    }
                };
                let choice = match (self.cur.is_empty(), self.tor.is_empty(), self.effort_choice) {
                    (_, _, Some(k)) => k,
                    (false, true, None) => EffortKind::CurrentA,
                    (true, false, None) => EffortKind::TorqueNm,
                    (false, false, None) => {
                        return Err(TraceError::AmbiguousEffort { source_name: name })
                    }
                    (true, true, None) => {
                        return Err(TraceError::MissingChannel {
                            source_name: name,
                            channel: "current_a or torque_nm".into(),
                            found: seen(),
                        })
                    }
                };
                let ch = match choice {
                    EffortKind::CurrentA => &self.cur,
                    EffortKind::TorqueNm => &self.tor,
                };
                if ch.is_empty() {
                    return Err(TraceError::MissingChannel {
                        source_name: name,
                        channel: choice.column().into(),
                        found: seen(),
                    });
                }
                if self.pos.is_empty() {
                    return Err(TraceError::MissingChannel {
                        source_name: name,
                        channel: "position_mm".into(),
                        found: seen(),
                    });
                }
                let ch = match choice {
                    EffortKind::CurrentA => self.cur,
                    EffortKind::TorqueNm => self.tor,
                };
                (ch, choice, Layout::Long)
            }
        };
        let report = ReadReport {
            ignored_rows: self.ignored_rows,
            ignored_channels: self.ignored_names,
            lines: self.lines,
            layout: Some(layout),
            unterminated_last_line: self.cut_last_line.then_some(self.lines),
            ..ReadReport::default()
        };
        Ok((
            Trace {
                position_m: self.pos,
                effort,
                effort_kind,
                facts: self.facts,
            },
            report,
            csv_layout,
        ))
    }
}

/// The key and value of a `# fact KEY = VALUE` comment line (see
/// [`feedscope::trace::RecordingFacts`]); `None` for any other comment.
fn fact_line(line: &[u8]) -> Option<(String, String)> {
    let text = std::str::from_utf8(line).ok()?;
    let rest = text.strip_prefix('#')?.trim_start().strip_prefix("fact ")?;
    let (key, value) = rest.split_once('=')?;
    Some((key.trim().to_string(), value.trim().to_string()))
}

/// Put the file-global line number into an error raised with a piece-local one.
fn relocate(e: TraceError, line_abs: u64) -> TraceError {
    match e {
        TraceError::FieldCount {
            source_name,
            expected,
            found,
            ..
        } => TraceError::FieldCount {
            source_name,
            line: line_abs,
            expected,
            found,
        },
        TraceError::NotANumber {
            source_name,
            column,
            text,
            ..
        } => TraceError::NotANumber {
            source_name,
            line: line_abs,
            column,
            text,
        },
        TraceError::NonFinite {
            source_name,
            column,
            text,
            ..
        } => TraceError::NonFinite {
            source_name,
            line: line_abs,
            column,
            text,
        },
        TraceError::TimeNotIncreasing {
            source_name,
            channel,
            time_s,
            previous_time_s,
            ..
        } => TraceError::TimeNotIncreasing {
            source_name,
            channel,
            line: line_abs,
            time_s,
            previous_time_s,
        },
        TraceError::BadChannelName {
            source_name,
            name,
            reason,
            ..
        } => TraceError::BadChannelName {
            source_name,
            line: line_abs,
            name,
            reason,
        },
        TraceError::Implausible {
            source_name,
            row,
            channel,
            value,
            limit,
            unit,
            ..
        } => TraceError::Implausible {
            source_name,
            line: Some(line_abs),
            row,
            channel,
            value,
            limit,
            unit,
        },
        other => other,
    }
}

#[inline]
fn trim_line(mut l: &[u8]) -> &[u8] {
    while let [rest @ .., b'\r' | b' ' | b'\t'] = l {
        l = rest;
    }
    while let [b' ' | b'\t', rest @ ..] = l {
        l = rest;
    }
    l
}

#[inline]
fn trim_field(mut f: &[u8]) -> &[u8] {
    while let [b' ' | b'\t' | b'"', rest @ ..] = f {
        f = rest;
    }
    while let [rest @ .., b' ' | b'\t' | b'"'] = f {
        f = rest;
    }
    f
}

/// Parse a decimal number. Plain `[-+]digits[.digits]` with at most 19 significant digits and
/// at most 22 decimals takes the exact fast path (Clinger: mantissa and power of ten are both
/// exact doubles, so one correctly rounded division); anything else goes to the standard
/// library's correctly rounded parser.
#[inline]
pub(crate) fn parse_f64(f: &[u8]) -> Option<f64> {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let (neg, digits) = match f.first() {
        Some(b'-') => (true, &f[1..]),
        Some(b'+') => (false, &f[1..]),
        _ => (false, f),
    };
    let mut mant: u64 = 0;
    let mut n_digits = 0u32;
    let mut frac_digits = 0u32;
    let mut seen_dot = false;
    let mut any = false;
    for &c in digits {
        match c {
            b'0'..=b'9' => {
                any = true;
                if mant == 0 && c == b'0' {
                    // leading zeros do not count as significant digits
                } else {
                    n_digits += 1;
                }
                mant = mant.wrapping_mul(10).wrapping_add((c - b'0') as u64);
                if seen_dot {
                    frac_digits += 1;
                }
            }
            b'.' if !seen_dot => seen_dot = true,
            _ => return slow_parse(f),
        }
    }
    if !any {
        return slow_parse(f);
    }
    if n_digits > 15 || frac_digits > 22 {
        // 2^53 ≈ 9.007e15: beyond 15 digits the mantissa may not be exact.
        return slow_parse(f);
    }
    let v = mant as f64 / POW10[frac_digits as usize];
    Some(if neg { -v } else { v })
}

#[cold]
fn slow_parse(f: &[u8]) -> Option<f64> {
    std::str::from_utf8(f).ok()?.parse::<f64>().ok()
}

/// Parse one piece of complete lines. Errors carry the piece-local line (1-based).
fn parse_piece(
    body: &[u8],
    term: u8,
    header: &Header,
    name: &str,
) -> Result<Piece, (u64, TraceError)> {
    let mut p = Piece::default();
    let avg_line = 28;
    let est = body.len() / avg_line;
    let mut line_no: u64 = 0;
    let num = |field: &[u8], column: &str, line: u64| -> Result<f64, (u64, TraceError)> {
        let f = trim_field(field);
        match parse_f64(f) {
            Some(v) if v.is_finite() => Ok(v),
            Some(_) => Err((
                line,
                TraceError::NonFinite {
                    source_name: name.to_string(),
                    line: 0,
                    column: column.into(),
                    text: shorten(f),
                },
            )),
            None => Err((
                line,
                TraceError::NotANumber {
                    source_name: name.to_string(),
                    line: 0,
                    column: column.into(),
                    text: shorten(f),
                },
            )),
        }
    };
    let not_inc = |channel: &str, line: u64, t: f64, prev: f64| {
        (
            line,
            TraceError::TimeNotIncreasing {
                source_name: name.to_string(),
                channel: channel.into(),
                line: 0,
                time_s: t,
                previous_time_s: prev,
            },
        )
    };
    let field_count = |line: u64, expected: usize, found: usize| {
        (
            line,
            TraceError::FieldCount {
                source_name: name.to_string(),
                line: 0,
                expected,
                found,
            },
        )
    };
    match header {
        Header::Long { time_scale } => {
            p.pos.time_s.reserve(est / 2);
            p.pos.value.reserve(est / 2);
            p.cur.time_s.reserve(est / 2);
            p.cur.value.reserve(est / 2);
            for raw in body.split(|&b| b == term) {
                line_no += 1;
                let line = trim_line(raw);
                if line.is_empty() || line[0] == b'#' {
                    continue;
                }
                let c1 = memchr::memchr(b',', line);
                let c2 = c1.and_then(|a| memchr::memchr(b',', &line[a + 1..]).map(|b| a + 1 + b));
                let (Some(a), Some(b)) = (c1, c2) else {
                    let found = 1 + line.iter().filter(|&&c| c == b',').count();
                    return Err(field_count(line_no, 3, found));
                };
                let value_field = &line[b + 1..];
                if memchr::memchr(b',', value_field).is_some() {
                    let found = 1 + line.iter().filter(|&&c| c == b',').count();
                    return Err(field_count(line_no, 3, found));
                }
                let chan = trim_field(&line[a + 1..b]);
                let (slot, scale) = match chan {
                    b"position_mm" => (Slot::Position, 1e-3),
                    b"current_a" => (Slot::Current, 1.0),
                    b"torque_nm" => (Slot::Torque, 1.0),
                    b"position_m" => (Slot::Position, 1.0),
                    other => {
                        if other.is_empty() {
                            return Err((
                                line_no,
                                TraceError::NotANumber {
                                    source_name: name.to_string(),
                                    line: 0,
                                    column: "channel".into(),
                                    text: "(empty channel name)".into(),
                                },
                            ));
                        }
                        // Known names never get here, so the common rows pay nothing.
                        if let Some(reason) = name_problem(other) {
                            return Err((
                                line_no,
                                TraceError::BadChannelName {
                                    source_name: name.to_string(),
                                    line: 0,
                                    name: show_name(other),
                                    reason,
                                },
                            ));
                        }
                        p.ignored_rows += 1;
                        // Borrowed (no allocation) for the usual UTF-8 name.
                        let n = String::from_utf8_lossy(other);
                        if p.ignored_names.len() < 16 && !p.ignored_names.iter().any(|k| *k == n) {
                            p.ignored_names.push(n.into_owned());
                        }
                        continue;
                    }
                };
                let t = num(&line[..a], "time", line_no)? * time_scale;
                let v = num(value_field, "value", line_no)? * scale;
                let (ch, idx, cname) = match slot {
                    Slot::Position => (&mut p.pos, 0, "position"),
                    Slot::Current => (&mut p.cur, 1, "current_a"),
                    Slot::Torque => (&mut p.tor, 2, "torque_nm"),
                };
                if let Some(e) = limits::check(name, cname, v, Some(0), None) {
                    return Err((line_no, e));
                }
                if let Some(&prev) = ch.time_s.last() {
                    if t <= prev {
                        return Err(not_inc(cname, line_no, t, prev));
                    }
                } else {
                    p.first_line[idx] = line_no;
                }
                ch.time_s.push(t);
                ch.value.push(v);
            }
        }
        Header::Wide {
            fields,
            time,
            time_scale,
            position,
            position_scale,
            effort,
            effort_kind,
            names,
        } => {
            p.pos.time_s.reserve(est);
            p.pos.value.reserve(est);
            let (eff_ch, eff_idx, eff_name) = match effort_kind {
                EffortKind::CurrentA => (1usize, 1usize, "current_a"),
                EffortKind::TorqueNm => (2, 2, "torque_nm"),
            };
            let mut cells: Vec<&[u8]> = Vec::with_capacity(*fields);
            for raw in body.split(|&b| b == term) {
                line_no += 1;
                let line = trim_line(raw);
                if line.is_empty() || line[0] == b'#' {
                    continue;
                }
                cells.clear();
                cells.extend(line.split(|&b| b == b','));
                if cells.len() != *fields {
                    return Err(field_count(line_no, *fields, cells.len()));
                }
                let t = num(cells[*time], &names[*time], line_no)? * time_scale;
                for (col, scale, slot, cname) in [
                    (*position, *position_scale, 0usize, "position"),
                    (*effort, 1.0, eff_ch, eff_name),
                ] {
                    let cell = trim_field(cells[col]);
                    if cell.is_empty() {
                        continue; // no sample of this channel at this time
                    }
                    let v = num(cell, &names[col], line_no)? * scale;
                    if let Some(e) = limits::check(name, cname, v, Some(0), None) {
                        return Err((line_no, e));
                    }
                    let (ch, idx) = if slot == 0 {
                        (&mut p.pos, 0)
                    } else if slot == 1 {
                        (&mut p.cur, eff_idx)
                    } else {
                        (&mut p.tor, eff_idx)
                    };
                    if let Some(&prev) = ch.time_s.last() {
                        if t <= prev {
                            return Err(not_inc(cname, line_no, t, prev));
                        }
                    } else {
                        p.first_line[idx] = line_no;
                    }
                    ch.time_s.push(t);
                    ch.value.push(v);
                }
            }
        }
    }
    // `split` yields one empty tail after a final terminator; it is not a line.
    if body.last() == Some(&term) {
        line_no -= 1;
    }
    p.lines = line_no;
    Ok(p)
}

/// Why a first line is not a trace header when it is another format met in practice, with
/// what to do: an MTConnect SHDR log or a UMich mill CSV (both convert with `feedscope
/// import`), or a semicolon-separated CSV as spreadsheets write it where the decimal mark is a
/// comma. `None` for anything else (the generic header checks then explain).
fn foreign_header(line: &str) -> Option<String> {
    let b = line.as_bytes();
    // `2022-08-08T13:51:34.7167146Z|avail|AVAILABLE`: an ISO date, a `T`, fields split by `|`.
    let iso_date = b.len() > 11
        && b[..4].iter().all(u8::is_ascii_digit)
        && b[4] == b'-'
        && b[7] == b'-'
        && b[10] == b'T';
    if iso_date && line.contains('|') {
        return Some(
            "this is an MTConnect SHDR log (`timestamp|key|value|…` lines), not a trace; \
             convert it with `feedscope import shdr LOG --devices Devices.xml --axis AXIS \
             --torque-per-load-nm N -o trace.csv`"
                .into(),
        );
    }
    let lower = line.to_ascii_lowercase();
    if lower.contains("_actualposition") && lower.contains("_currentfeedback") {
        return Some(
            "this is a UMich SMART CNC mill CSV (`X1_ActualPosition`, …, no time column), not \
             a trace; convert it with `feedscope import umich FILE --axis X -o trace.csv`"
                .into(),
        );
    }
    let semicolon_names = line
        .split(';')
        .map(|n| n.trim().trim_matches('"').to_ascii_lowercase())
        .any(|n| n == "time_s" || n == "time_ms");
    if semicolon_names || (line.contains(';') && !line.contains(',')) {
        return Some(
            "fields are separated by `;` (a semicolon CSV, as spreadsheets write it where the \
             decimal mark is a comma); a trace separates fields with `,` and writes decimals \
             with `.` (`time_s,channel,value` then `0.036,current_a,0.842`): export it again \
             that way, turning decimal commas (`0,036`) into points"
                .into(),
        );
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::{parse_trace, parse_trace_with, DroppedSample};

    fn parse(s: &str) -> Result<(Trace, ReadReport), TraceError> {
        parse_trace(s.as_bytes(), "t.csv", &ReadOptions::default())
    }

    /// [`read_file`] of the CSV file at `path` with blocks of `block_bytes`.
    fn read_file_in_blocks(
        path: &Path,
        opts: &ReadOptions,
        glitch: &GlitchParams,
        block_bytes: usize,
    ) -> Result<(Trace, ReadReport), TraceError> {
        let name = path.display().to_string();
        read_file(
            File::open(path).unwrap(),
            path,
            &name,
            opts,
            glitch,
            block_bytes,
        )
    }

    #[test]
    fn fast_float_matches_std() {
        for s in [
            "0",
            "1",
            "-1",
            "3.14159",
            "0.000001",
            "123456.789012",
            "-0.5",
            "+2.5",
            "1e-3",
            "1.5E3",
            "123456789012345678",
            "0.1",
            "0.2",
            "0.3",
            "9007199254740993",
            ".5",
            "5.",
        ] {
            let a = parse_f64(s.as_bytes()).unwrap();
            let b: f64 = s.parse().unwrap();
            assert_eq!(a.to_bits(), b.to_bits(), "{s}");
        }
        assert!(parse_f64(b"abc").is_none());
        assert!(parse_f64(b"").is_none());
        assert!(parse_f64(b"-").is_none());
        assert!(parse_f64(b"1.2.3").is_none());
    }

    #[test]
    fn long_layout_async_channels() {
        let (t, r) = parse(
            "\u{feff}# comment\ntime_s,channel,value\n0.0,position_mm,0\n0.01,current_a,1.0\n\
             0.07,position_mm,0.1\n0.08,current_a,1.1\n0.14,position_mm,0.2\n0.15,current_a,1.2\n\
             0.21,position_mm,0.3\n0.22,current_a,1.3\n0.23,speed,5\n",
        )
        .unwrap();
        assert_eq!(t.position_m.len(), 4);
        assert!((t.position_m.value[3] - 0.3e-3).abs() < 1e-18);
        assert_eq!(t.effort_kind, EffortKind::CurrentA);
        assert_eq!(r.ignored_rows, 1);
        assert_eq!(r.lines, 11);
    }

    /// A synchronous simulation (both channels on one clock, some samples dropped) is written
    /// in the wide layout with the effort's column name.
    #[test]
    fn synchronous_simulation_writes_the_wide_layout() {
        use feedscope::sim::{simulate, SamplingMode, SimConfig, StrokeConfig};
        let mut c = SimConfig::default();
        c.motion.strokes = vec![
            StrokeConfig {
                to_mm: 20.0,
                feed_mm_min: 600.0,
                dwell_s: 0.2,
            },
            StrokeConfig {
                to_mm: 0.0,
                feed_mm_min: 600.0,
                dwell_s: 0.0,
            },
        ];
        c.motion.lead_in_s = 0.2;
        c.motion.lead_out_s = 0.2;
        c.sampling.mode = SamplingMode::Synchronous;
        c.sampling.synchronous_rate_hz = 1000.0;
        c.sampling.synchronous_dropout_probability = 0.01;
        let out = simulate(&c, &mut |_| {}).unwrap();
        let mut buf = Vec::new();
        write_csv(&out.trace, &mut buf, Layout::Wide).unwrap();
        assert!(String::from_utf8(buf)
            .unwrap()
            .starts_with("time_s,position_mm,current_a\n"));
        // Asynchronous channels have no wide layout.
        let mut t = out.trace;
        t.effort.time_s[0] -= 1e-4;
        let e = write_csv(&t, Vec::new(), Layout::Wide).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
    }

    #[test]
    fn wide_layout_crlf_and_ms() {
        let (t, _) =
            parse("time_ms,position_mm,torque_nm\r\n0,0,1\r\n1,1,2\r\n2,2,3\r\n3,3,4\r\n").unwrap();
        assert_eq!(t.effort_kind, EffortKind::TorqueNm);
        assert!((t.position_m.time_s[3] - 0.003).abs() < 1e-15);
    }

    #[test]
    fn bare_cr_line_ends() {
        let (t, _) = parse("time_s,position_mm,current_a\r0,0,1\r1,1,2\r2,2,3\r3,3,4\r").unwrap();
        assert_eq!(t.position_m.len(), 4);
    }

    #[test]
    fn wide_empty_cells_are_async() {
        let (t, _) = parse(
            "time_s,position_mm,current_a\n0,0,\n0.5,,1\n1,1,\n1.5,,2\n2,2,\n2.5,,3\n3,3,\n3.5,,4\n",
        )
        .unwrap();
        assert_eq!(t.position_m.len(), 4);
        assert_eq!(t.effort.len(), 4);
    }

    #[test]
    fn error_lines_are_global() {
        let mut s = String::from("time_s,channel,value\n");
        for k in 0..100 {
            s.push_str(&format!("{k},position_mm,{k}\n"));
        }
        s.push_str("100,position_mm,abc\n");
        match parse(&s).unwrap_err() {
            TraceError::NotANumber { line, .. } => assert_eq!(line, 102),
            e => panic!("{e}"),
        }
    }

    #[test]
    fn small_blocks_match_in_memory_parse() {
        // Long lines (longer than a block), every line ending and a BOM, read through blocks
        // of a few hundred bytes: the same trace and the same error lines as one parse.
        let mut body = String::from("\u{feff}# a comment\ntime_s,channel,value\n");
        body.push_str(&format!("# {}\n", "x".repeat(5000)));
        for k in 0..3000 {
            body.push_str(&format!(
                "{}.25,position_mm,{}\n{}.5,current_a,{}\n",
                k,
                k % 89,
                k,
                k % 7
            ));
        }
        let dir = tempfile::tempdir().unwrap();
        for (label, text) in [
            ("lf", body.clone()),
            ("crlf", body.replace('\n', "\r\n")),
            ("cr", body.replace('\n', "\r")),
        ] {
            let path = dir.path().join(format!("{label}.csv"));
            std::fs::write(&path, &text).unwrap();
            let want = parse_trace(
                text.as_bytes(),
                &path.display().to_string(),
                &ReadOptions::default(),
            )
            .unwrap();
            for block in [97, 300, 4096, 1 << 20] {
                let got = read_file_in_blocks(
                    &path,
                    &ReadOptions::default(),
                    &GlitchParams::default(),
                    block,
                )
                .unwrap();
                assert_eq!(got.0, want.0, "{label} {block}");
                assert_eq!(got.1.lines, want.1.lines, "{label} {block}");
            }
            // An error deep in the file names the same line whatever the block size.
            let bad = text.replace("2500.25,position_mm", "2499.25,position_mm");
            std::fs::write(&path, &bad).unwrap();
            for block in [97, 4096] {
                match read_file_in_blocks(
                    &path,
                    &ReadOptions::default(),
                    &GlitchParams::default(),
                    block,
                )
                .unwrap_err()
                {
                    TraceError::TimeNotIncreasing { line, .. } => {
                        assert_eq!(line, 4 + 2 * 2500, "{label} {block}")
                    }
                    e => panic!("{e}"),
                }
            }
        }
    }

    #[test]
    fn large_input_parallel_matches_serial() {
        let mut s = String::from("time_s,channel,value\n");
        for k in 0..200_000 {
            s.push_str(&format!(
                "{}.5,position_mm,{}\n{}.7,current_a,{}\n",
                k,
                k % 97,
                k,
                k % 13
            ));
        }
        let one = parse_trace(
            s.as_bytes(),
            "a",
            &ReadOptions {
                effort: None,
                threads: 1,
            },
        )
        .unwrap();
        let four = parse_trace(
            s.as_bytes(),
            "a",
            &ReadOptions {
                effort: None,
                threads: 4,
            },
        )
        .unwrap();
        assert_eq!(one.0, four.0);
        assert_eq!(one.1.lines, four.1.lines);
        assert_eq!(one.1.lines, 400_001);
        // a repeated time deep in the file is caught at its line, across piece boundaries
        let bad = s.replace("150000.5,position_mm", "149999.5,position_mm");
        match parse_trace(
            bad.as_bytes(),
            "a",
            &ReadOptions {
                effort: None,
                threads: 4,
            },
        )
        .unwrap_err()
        {
            TraceError::TimeNotIncreasing { line, .. } => assert_eq!(line, 2 + 2 * 150_000),
            e => panic!("{e}"),
        }
    }

    /// A long-layout stroke: 0 → 20 mm at 600 mm/min, position every 10 ms and current every
    /// 10 ms (offset 5 ms), dwell 0.5 s at both ends; `z` maps (sample index, position mm) to
    /// the value written. Returns the text and the line of each position sample.
    fn long_stroke(z: impl Fn(usize, f64) -> String) -> (String, Vec<u64>) {
        let mut s = String::from("# a comment\ntime_s,channel,value\n");
        let mut lines = Vec::new();
        let mut line = 2u64;
        for k in 0..300 {
            let t = k as f64 * 0.01;
            let mm = (10.0 * (t - 0.5)).clamp(0.0, 20.0);
            line += 1;
            lines.push(line);
            s.push_str(&format!("{t:.6},position_mm,{}\n", z(k, mm)));
            line += 1;
            s.push_str(&format!("{:.6},current_a,1.0\n", t + 0.005));
        }
        (s, lines)
    }

    #[test]
    fn absurd_position_is_dropped_with_its_line() {
        let (s, lines) = long_stroke(|k, mm| {
            if k == 150 {
                "1e308".into()
            } else {
                format!("{mm:.4}")
            }
        });
        let (t, r) = parse(&s).unwrap();
        assert_eq!(t.position_m.len(), 299);
        assert_eq!(t.effort.len(), 300);
        assert!(t.position_m.value.iter().all(|&z| z <= 0.02 + 1e-12));
        assert_eq!(
            r.dropped_position,
            [DroppedSample {
                time_s: 1.5,
                position_m: 1e305,
                line: Some(lines[150]),
                row: None,
            }]
        );
        assert_eq!(r.max_axis_speed_m_s, Some(200.0 / 60.0));
        let w = r.glitch_warning().unwrap();
        assert!(
            w.contains("dropped 1 position sample ")
                && w.contains("t = 1.5 s (line 303)")
                && w.contains("200000 mm/min"),
            "{w}"
        );
        // the same lines through small blocks, CRLF and bare CR
        let dir = tempfile::tempdir().unwrap();
        for (label, text) in [
            ("lf", s.clone()),
            ("crlf", s.replace('\n', "\r\n")),
            ("cr", s.replace('\n', "\r")),
            ("bom", format!("\u{feff}{s}")),
        ] {
            let path = dir.path().join(format!("{label}.csv"));
            std::fs::write(&path, &text).unwrap();
            for block in [97, 1 << 20] {
                let (_, r2) = read_file_in_blocks(
                    &path,
                    &ReadOptions::default(),
                    &GlitchParams::default(),
                    block,
                )
                .unwrap();
                assert_eq!(r2.dropped_position, r.dropped_position, "{label} {block}");
            }
        }
    }

    #[test]
    fn positions_outside_the_declared_travel_are_refused_with_their_line() {
        // the stroke runs 0 → 20 mm; a travel of [0, 19] mm has a margin of 1.19 mm
        let (s, lines) = long_stroke(|_, mm| format!("{mm:.4}"));
        let travel = |lo: f64, hi: f64| GlitchParams {
            travel_m: Some((lo * 1e-3, hi * 1e-3)),
            ..GlitchParams::default()
        };
        let opts = ReadOptions::default();
        assert!(parse_trace_with(s.as_bytes(), "t.csv", &opts, &travel(0.0, 19.0)).is_ok());
        let e = parse_trace_with(s.as_bytes(), "t.csv", &opts, &travel(0.0, 18.0)).unwrap_err();
        let TraceError::OutsideTravel {
            line,
            position_mm,
            margin_mm,
            ..
        } = &e
        else {
            panic!("{e}")
        };
        // the first sample beyond 18 + 1.18 mm: 19.2 mm at k = 242
        assert_eq!((*line, *position_mm), (Some(lines[242]), 19.2), "{e}");
        assert!((margin_mm - 1.18).abs() < 1e-9);
        assert_eq!(e.kind(), feedscope::ErrorKind::BadInput);
        let msg = e.to_string();
        assert!(
            msg.contains("t.csv:") && msg.contains("outside the axis travel [0, 18] mm"),
            "{msg}"
        );
        // a dropped glitch before it does not shift the line named
        let (g, glines) = long_stroke(|k, mm| {
            if k == 100 {
                "1e308".into()
            } else {
                format!("{mm:.4}")
            }
        });
        let e = parse_trace_with(g.as_bytes(), "t.csv", &opts, &travel(0.0, 18.0)).unwrap_err();
        assert!(
            matches!(e, TraceError::OutsideTravel { line: Some(l), .. } if l == glines[242]),
            "{e}"
        );
        // without a declared travel nothing is checked
        assert!(parse_trace_with(s.as_bytes(), "t.csv", &opts, &GlitchParams::default()).is_ok());
    }

    #[test]
    fn a_cut_last_line_is_reported_with_its_number() {
        let (s, _) = long_stroke(|_, mm| format!("{mm:.4}"));
        let (_, r) = parse(&s).unwrap();
        assert_eq!(r.unterminated_last_line, None);
        assert!(r.warning().is_none());
        // cut inside the last number: the line ends without a terminator
        let cut = &s[..s.len() - 2];
        let (t, r) = parse(cut).unwrap();
        assert_eq!(t.effort.len(), 300);
        assert_eq!(r.unterminated_last_line, Some(602));
        let w = r.warning().unwrap();
        assert!(w.contains("(line 602) has no line end"), "{w}");
        // a trailing comment or blank text without a line end is not data
        for tail in ["# end", "   "] {
            let (_, r) = parse(&format!("{s}{tail}")).unwrap();
            assert_eq!(r.unterminated_last_line, None, "{tail:?}");
        }
        // the same through small blocks and CRLF / bare CR line ends
        let dir = tempfile::tempdir().unwrap();
        for (label, text) in [
            ("lf", cut.to_string()),
            ("crlf", cut.replace('\n', "\r\n")),
            ("cr", cut.replace('\n', "\r")),
        ] {
            let path = dir.path().join(format!("{label}.csv"));
            std::fs::write(&path, &text).unwrap();
            for block in [97, 1 << 20] {
                let (_, r2) = read_file_in_blocks(
                    &path,
                    &ReadOptions::default(),
                    &GlitchParams::default(),
                    block,
                )
                .unwrap();
                assert_eq!(r2.unterminated_last_line, Some(602), "{label} {block}");
            }
        }
    }

    #[test]
    fn several_glitches_are_listed_and_counted() {
        let bad = [20, 100, 101, 180, 220, 250, 299];
        let (s, lines) = long_stroke(|k, mm| {
            if bad.contains(&k) {
                format!("{:.4}", mm + 900.0)
            } else {
                format!("{mm:.4}")
            }
        });
        let (t, r) = parse(&s).unwrap();
        assert_eq!(t.position_m.len(), 300 - bad.len());
        let got: Vec<Option<u64>> = r.dropped_position.iter().map(|d| d.line).collect();
        let want: Vec<Option<u64>> = bad.iter().map(|&k| Some(lines[k])).collect();
        assert_eq!(got, want);
        let w = r.glitch_warning().unwrap();
        assert!(w.starts_with("dropped 7 position samples"), "{w}");
        assert!(w.ends_with(" and 2 more"), "{w}");
    }

    #[test]
    fn wide_layout_glitch_names_its_line() {
        let mut s = String::from("time_s,position_mm,current_a\n");
        for k in 0..500 {
            let t = k as f64 * 0.002;
            let mm = if k == 321 { 5.0 } else { 0.1 * t };
            s.push_str(&format!("{t:.3},{mm:.4},0.5\n"));
        }
        // 5 mm in 2 ms: a glitch for a 15 m/min axis, motion for the default limit
        let axis = GlitchParams::from_rapid_rate(Some(15_000.0));
        let (t, r) =
            parse_trace_with(s.as_bytes(), "w.csv", &ReadOptions::default(), &axis).unwrap();
        assert_eq!(t.position_m.len(), 499);
        assert_eq!(r.dropped_position.len(), 1);
        assert_eq!(r.dropped_position[0].line, Some(323));
        let (t, r) = parse(&s).unwrap();
        assert_eq!(t.position_m.len(), 500);
        assert!(r.dropped_position.is_empty() && r.glitch_warning().is_none());
    }

    #[test]
    fn non_returning_jump_is_refused_with_its_line() {
        // 500 mm in 10 ms; at 100 Hz the default limit lets through 3.33 m/s × 3 samples = 100 mm
        let (s, lines) =
            long_stroke(|k, mm| format!("{:.4}", if k >= 200 { mm + 500.0 } else { mm }));
        match parse(&s).unwrap_err() {
            e @ TraceError::PositionJump { .. } => {
                let TraceError::PositionJump {
                    line,
                    row,
                    time_s,
                    previous_time_s,
                    jump_mm,
                    speed_mm_min,
                    ..
                } = e
                else {
                    unreachable!()
                };
                assert_eq!((line, row), (Some(lines[200]), None));
                assert!((time_s - 2.0).abs() < 1e-12 && (previous_time_s - 1.99).abs() < 1e-12);
                assert!((jump_mm - 500.1).abs() < 1e-9, "{jump_mm}");
                assert!((speed_mm_min - 500.1 / 0.01 * 60.0).abs() < 1e-3);
                let msg = e.to_string();
                assert!(
                    msg.starts_with("t.csv:403: the position jumps by 500.1 mm")
                        && msg.contains("3000600 mm/min")
                        && msg.contains("200000 mm/min"),
                    "{msg}"
                );
            }
            e => panic!("{e}"),
        }
    }

    #[test]
    fn glitch_that_was_the_only_motion_is_no_motion() {
        let (s, _) = long_stroke(|k, _| if k == 7 { "1e308".into() } else { "3.0".into() });
        assert!(matches!(
            parse(&s).unwrap_err(),
            TraceError::NoMotion { .. }
        ));
    }

    #[test]
    fn bad_channel_names_name_their_line() {
        let (good, _) = long_stroke(|_, mm| format!("{mm:.4}"));
        let with_row = |row: &str| {
            let mut s = good.clone();
            s.push_str(row);
            s.push('\n');
            s
        };
        let long = format!("3.1,{},1", "x".repeat(1_000_000));
        for (row, reason) in [
            (long.as_str(), "1000000 bytes long"),
            ("3.1,spe\u{1}ed,1", "U+0001"),
            ("3.1,speed\u{1b}[31m,1", "U+001B"),
            ("3.1,a\tb,1", "U+0009"),
            ("3.1,pos\u{85},1", "U+0085"),
        ] {
            match parse(&with_row(row)).unwrap_err() {
                TraceError::BadChannelName {
                    line,
                    name,
                    reason: r,
                    ..
                } => {
                    assert_eq!(line, 603, "{row:.40}");
                    assert!(r.contains(reason), "{r}");
                    assert!(name.chars().count() <= 41 && !name.chars().any(char::is_control));
                }
                e => panic!("{e}"),
            }
        }
        // 64 bytes is fine, and is ignored like any other unknown channel
        let (_, r) = parse(&with_row(&format!("3.1,{},1", "y".repeat(64)))).unwrap();
        assert_eq!(r.ignored_rows, 1);
        // across pieces and blocks: the global line
        let mut big = String::from("time_s,channel,value\n");
        for k in 0..100_000 {
            big.push_str(&format!("{k}.5,position_mm,{}\n{k}.7,current_a,1\n", k % 7));
        }
        big.push_str("100000.1,v\u{7f},1\n");
        let opts = ReadOptions {
            threads: 4,
            ..ReadOptions::default()
        };
        match parse_trace(big.as_bytes(), "b", &opts).unwrap_err() {
            TraceError::BadChannelName { line, .. } => assert_eq!(line, 200_002),
            e => panic!("{e}"),
        }
    }

    #[test]
    fn bad_header_names_are_refused() {
        let rows = "0,0,1\n1,1,2\n2,2,3\n3,3,4\n";
        for (header, needle) in [
            (
                format!("time_s,position_mm,current_a,{}", "c".repeat(65)),
                "65 bytes",
            ),
            (
                "time_s,position_mm,current_a,note\u{7}".to_string(),
                "U+0007",
            ),
            (format!("time_s,{}", "z".repeat(1_000_000)), "1000000 bytes"),
        ] {
            let s = format!("# c\n{header}\n{rows}");
            match parse(&s).unwrap_err() {
                TraceError::BadHeader {
                    line,
                    reason,
                    found,
                    ..
                } => {
                    assert_eq!(line, 2);
                    assert!(reason.contains(needle), "{reason}");
                    assert!(found.chars().count() <= 61 && !found.chars().any(char::is_control));
                }
                e => panic!("{e}"),
            }
        }
    }
}
