//! Reading and writing trace Parquet files: the same columns and the same two layouts as CSV
//! (see the [module doc](super)), with the same validation.
//!
//! Reading streams record batches of [`BATCH_ROWS`] rows with only the needed columns projected,
//! and converts each batch straight into the `Vec<f64>` of its channel (units to SI as the CSV
//! reader does: mm → m, ms → s). Memory stays at the parsed samples plus one batch and the
//! decoder's current row group. Errors name the file and, for bad values, the 1-based data row.

use std::fs::File;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

use arrow_array::cast::AsArray;
use arrow_array::types::{Float32Type, Float64Type, Int32Type, Int64Type, Int8Type};
use arrow_array::{Array, ArrayRef, DictionaryArray, Float64Array, Int8Array, RecordBatch};
use arrow_array::{StringArray, StringViewArray};
use arrow_schema::{DataType, Field, Schema};
use feedscope::trace::{Channel, EffortKind, GlitchParams, RecordingFacts, Trace};
use parquet::arrow::arrow_reader::{ArrowReaderMetadata, ParquetRecordBatchReaderBuilder};
use parquet::arrow::{ArrowWriter, ProjectionMask};
use parquet::basic::Compression;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::reader::ChunkReader;
use parquet::schema::types::ColumnPath;

use super::format::Layout;
use super::read::{
    choose_effort, name_problem, screen_and_check, show_name, EffortChoice, Origin, ReadOptions,
    ReadReport, TraceError,
};

/// Rows per record batch, read and written: large enough that per-batch work is noise, small
/// enough (64 Ki rows ≈ 1.5 MB of decoded columns) to stay in cache-friendly sizes.
const BATCH_ROWS: usize = 1 << 16;

/// Where each needed column sits in the projected batches, and how to scale it.
#[derive(Debug, Clone)]
enum Plan {
    Wide {
        time: Col,
        position: Col,
        effort: Col,
        effort_kind: EffortKind,
    },
    Long {
        time: Col,
        channel: usize,
        value: Col,
    },
}

/// A numeric column: its index in the projected batch, its name in the file, its scale to SI.
#[derive(Debug, Clone)]
struct Col {
    index: usize,
    name: String,
    scale: f64,
}

/// Channel codes of long-layout rows: the three channels, then rows to skip or refuse.
const POS_MM: u8 = 0;
const POS_M: u8 = 1;
const CUR: u8 = 2;
const TOR: u8 = 3;
const IGNORED: u8 = 4;
const NULL_CHANNEL: u8 = 5;
const EMPTY_CHANNEL: u8 = 6;
/// An unknown name that is too long or holds a control character (refused).
const BAD_NAME: u8 = 7;

fn channel_code(name: &str) -> u8 {
    match name {
        "position_mm" => POS_MM,
        "position_m" => POS_M,
        "current_a" => CUR,
        "torque_nm" => TOR,
        "" => EMPTY_CHANNEL,
        _ => IGNORED,
    }
}

fn is_numeric(t: &DataType) -> bool {
    matches!(
        t,
        DataType::Float64 | DataType::Float32 | DataType::Int32 | DataType::Int64
    )
}

thread_local! {
    static GUARDED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// True while this thread decodes a Parquet trace under a guard that turns a decoder panic
/// into [`TraceError::Parquet`]. A panic hook can use it to skip printing such a panic: the
/// user then sees only the error naming the damaged file.
pub fn decoding_untrusted_parquet() -> bool {
    GUARDED.get()
}

fn is_string(t: &DataType) -> bool {
    matches!(t, DataType::Utf8 | DataType::LargeUtf8 | DataType::Utf8View)
}

/// Read an open Parquet file (its magic already checked), then end with the checks of every
/// reader; `path` is opened again only to find the rows of dropped samples.
pub(super) fn read_file(
    file: File,
    path: &Path,
    name: &str,
    opts: &ReadOptions,
    glitch: &GlitchParams,
) -> Result<(Trace, ReadReport), TraceError> {
    // Row groups are decoded in parallel, each from its own handle: clones of one `File` share
    // its offset, so concurrent reads through them would race.
    let read = read_parquet(file, || File::open(path), name, opts)?;
    // Rows of dropped samples come from a second decode, only when something was dropped.
    let locate = |wanted: &[usize]| match File::open(path) {
        Ok(f) => position_rows(f, name, opts, wanted),
        Err(_) => vec![None; wanted.len()],
    };
    screen_and_check(name, read, glitch, Origin::Row, locate)
}

/// Parse a Parquet trace held in memory (its magic already checked), then end with the checks
/// of every reader.
pub(super) fn parse_bytes(
    bytes: &[u8],
    source_name: &str,
    opts: &ReadOptions,
    glitch: &GlitchParams,
) -> Result<(Trace, ReadReport), TraceError> {
    let buf = bytes::Bytes::copy_from_slice(bytes);
    let read = read_parquet(buf.clone(), || Ok(buf.clone()), source_name, opts)?;
    let locate = |wanted: &[usize]| position_rows(buf.clone(), source_name, opts, wanted);
    screen_and_check(source_name, read, glitch, Origin::Row, locate)
}

/// Read a trace from an open Parquet file or a buffer (its magic already checked), without the
/// final checks (the caller's, as for CSV).
///
/// The decoder (parquet 60) still panics on some corrupt pages instead of returning an error
/// (e.g. an over-long varint in a page's run-length data: "Num of bytes exceed
/// MAX_VLQ_BYTE_LEN"; upstream treats each such panic as a bug). A damaged file is bad input,
/// not a programmer's mistake, so such a panic is caught here and becomes
/// [`TraceError::Parquet`]. While the decoder runs, [`decoding_untrusted_parquet`] is true on
/// this thread, so a program's panic hook can stay silent for a panic that is about to become
/// that error.
///
/// `reopen` gives a further handle on the same bytes for each row group decoded on another
/// thread.
fn read_parquet<R: ChunkReader + 'static>(
    file: R,
    reopen: impl Fn() -> std::io::Result<R> + Sync,
    name: &str,
    opts: &ReadOptions,
) -> Result<(Trace, ReadReport), TraceError> {
    guarded(name, || decode(file, &reopen, name, opts))
}

/// Run a decoding closure with a decoder panic turned into [`TraceError::Parquet`] (see
/// [`read_parquet`]).
fn guarded<T>(name: &str, f: impl FnOnce() -> Result<T, TraceError>) -> Result<T, TraceError> {
    // Nothing outlives the closure but its result, so no broken state can be observed after
    // an unwind.
    GUARDED.set(true);
    let decoded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    GUARDED.set(false);
    decoded.unwrap_or_else(|payload| {
        let what = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown failure".into());
        Err(TraceError::Parquet {
            source_name: name.to_string(),
            reason: format!("the decoder failed on corrupt data ({what})"),
        })
    })
}

/// 1-based data rows of the position samples with the given indices (ascending; counted from
/// 0 in file order) in a Parquet file that [`read_parquet`] read without error: a second
/// decode of the time and position (wide) or channel (long) columns only. `None` for an index
/// that is not found or when the file cannot be decoded again.
fn position_rows<R: ChunkReader + 'static>(
    file: R,
    name: &str,
    opts: &ReadOptions,
    wanted: &[usize],
) -> Vec<Option<u64>> {
    guarded(name, || find_rows(file, name, opts, wanted))
        .unwrap_or_else(|_| vec![None; wanted.len()])
}

fn find_rows<R: ChunkReader + 'static>(
    file: R,
    name: &str,
    opts: &ReadOptions,
    wanted: &[usize],
) -> Result<Vec<Option<u64>>, TraceError> {
    let corrupt = |e: parquet::errors::ParquetError| TraceError::Parquet {
        source_name: name.to_string(),
        reason: e.to_string(),
    };
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(corrupt)?;
    let (plan, roots) = plan(builder.schema(), name, opts)?;
    let mask = ProjectionMask::roots(builder.parquet_schema(), roots);
    let reader = builder
        .with_projection(mask)
        .with_batch_size(BATCH_ROWS)
        .build()
        .map_err(corrupt)?;
    let mut state = State::new(name, &plan, 0);
    let mut out = vec![None; wanted.len()];
    let (mut count, mut w, mut base) = (0usize, 0usize, 0u64);
    for batch in reader {
        if w == wanted.len() {
            break;
        }
        let batch = batch.map_err(|e| TraceError::Parquet {
            source_name: name.to_string(),
            reason: e.to_string(),
        })?;
        let n = batch.num_rows();
        let mut holds = |i: usize| {
            while w < wanted.len() && wanted[w] == count {
                out[w] = Some(base + i as u64 + 1);
                w += 1;
            }
            count += 1;
        };
        match &plan {
            Plan::Wide { position, .. } => {
                let nulls = batch.column(position.index).nulls();
                for i in 0..n {
                    if !nulls.is_some_and(|b| b.is_null(i)) {
                        holds(i);
                    }
                }
            }
            Plan::Long { channel, .. } => {
                state.channel_codes(batch.column(*channel))?;
                for (i, &c) in state.codes.iter().enumerate() {
                    if c == POS_MM || c == POS_M {
                        holds(i);
                    }
                }
            }
        }
        base += n as u64;
    }
    Ok(out)
}

fn decode<R: ChunkReader + 'static>(
    file: R,
    reopen: &(impl Fn() -> std::io::Result<R> + Sync),
    name: &str,
    opts: &ReadOptions,
) -> Result<(Trace, ReadReport), TraceError> {
    let corrupt = |e: parquet::errors::ParquetError| TraceError::Parquet {
        source_name: name.to_string(),
        reason: e.to_string(),
    };
    let bad_batch = |e: arrow_schema::ArrowError| TraceError::Parquet {
        source_name: name.to_string(),
        reason: e.to_string(),
    };
    // The footer is parsed once and shared with every row group's reader: parsing it again
    // for each of G row groups made the read O(G²) (6,000 row groups took over 20 s).
    let meta = ArrowReaderMetadata::load(&file, Default::default()).map_err(corrupt)?;
    let total_rows = usize::try_from(meta.metadata().file_metadata().num_rows()).unwrap_or(0);
    let mut facts = RecordingFacts::default();
    for kv in meta
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .into_iter()
        .flatten()
    {
        if let Some(key) = kv.key.strip_prefix(FACT_PREFIX) {
            let value = kv.value.as_deref().unwrap_or("");
            facts
                .set(key, value)
                .map_err(|reason| TraceError::Parquet {
                    source_name: name.to_string(),
                    reason: format!("key-value metadata `{}`: {reason}", kv.key),
                })?;
        }
    }
    let schema = meta.schema().clone();
    let (plan, roots) = plan(&schema, name, opts)?;
    check_projected_pages(meta.metadata(), &roots, name, &file)?;
    // The footer's row count is a claim: reserve for no more rows than the file has bytes (a
    // trace's rows take several bytes each), so a forged count cannot reserve terabytes.
    let reserve_rows = total_rows.min(usize::try_from(file.len()).unwrap_or(usize::MAX));
    let builder = ParquetRecordBatchReaderBuilder::new_with_metadata(file, meta.clone());
    let mask = ProjectionMask::roots(builder.parquet_schema(), roots);
    // The first data row of each row group, from the footer.
    let groups: Vec<(usize, u64)> = builder
        .metadata()
        .row_groups()
        .iter()
        .enumerate()
        .scan(0u64, |row, (g, rg)| {
            let first = *row;
            *row += u64::try_from(rg.num_rows()).unwrap_or(0);
            Some((g, first))
        })
        .collect();
    let mut state = State::new(name, &plan, reserve_rows);
    if groups.len() < 2 || rayon::current_num_threads() < 2 {
        let reader = builder
            .with_projection(mask)
            .with_batch_size(BATCH_ROWS)
            .build()
            .map_err(corrupt)?;
        for batch in reader {
            let batch = batch.map_err(bad_batch)?;
            state.batch(&batch, &plan)?;
        }
    } else {
        drop(builder);
        let spare: std::sync::Mutex<Vec<[Channel; 3]>> = std::sync::Mutex::new(Vec::new());
        // Row groups decode and check in parallel, a wave of one per thread at a time; each
        // wave is then appended in file order, so memory holds the trace and one wave of row
        // groups, and the first error in file order is the one reported.
        let one_group = |&(g, first_row): &(usize, u64)| -> Result<State<'_>, TraceError> {
            guarded(name, || {
                let handle = reopen().map_err(|e| TraceError::Parquet {
                    source_name: name.to_string(),
                    reason: format!("reopening the file for row group {g}: {e}"),
                })?;
                let reader =
                    ParquetRecordBatchReaderBuilder::new_with_metadata(handle, meta.clone())
                        .with_projection(mask.clone())
                        .with_row_groups(vec![g])
                        .with_batch_size(BATCH_ROWS)
                        .build()
                        .map_err(corrupt)?;
                let mut part = State::new(name, &plan, 0);
                // Channels of a joined part, emptied: their pages are already the process's,
                // where new ones would be zeroed by the kernel first (a sixth of the time).
                if let Some([p, c, t]) = spare.lock().ok().and_then(|mut s| s.pop()) {
                    (part.pos, part.cur, part.tor) = (p, c, t);
                }
                part.rows = first_row;
                for batch in reader {
                    let batch = batch.map_err(bad_batch)?;
                    part.batch(&batch, &plan)?;
                }
                Ok(part)
            })
        };
        // The join runs beside the decoding of the next wave: a bounded queue of one wave
        // keeps memory at the trace and two waves of row groups.
        let wave = rayon::current_num_threads();
        let (tx, rx) = std::sync::mpsc::sync_channel(wave);
        let spare_ref = &spare;
        std::thread::scope(|sc| -> Result<(), TraceError> {
            sc.spawn(move || {
                use rayon::prelude::*;
                for chunk in groups.chunks(wave) {
                    let parts: Vec<Result<State<'_>, TraceError>> =
                        chunk.par_iter().map(one_group).collect();
                    for part in parts {
                        let failed = part.is_err();
                        // A closed queue: the join stopped on an error, nothing more is read.
                        if tx.send(part).is_err() || failed {
                            return;
                        }
                    }
                }
            });
            for part in rx {
                let mut part = part?;
                state.append(&mut part)?;
                if let Ok(mut s) = spare_ref.lock() {
                    s.push([part.pos, part.cur, part.tor]);
                }
            }
            Ok(())
        })?;
    }
    let (mut trace, report) = state.finish(&plan, opts)?;
    trace.facts = facts;
    // An integer effort column holds whole amperes (or N·m): its resolution is a fact the
    // estimate must know (it states it and widens its standard errors), not a silent loss.
    let effort_col = match &plan {
        Plan::Wide { effort, .. } => &effort.name,
        Plan::Long { value, .. } => &value.name,
    };
    if schema
        .field_with_name(effort_col)
        .is_ok_and(|f| matches!(f.data_type(), DataType::Int32 | DataType::Int64))
    {
        let q = trace.facts.effort_quantum.unwrap_or(0.0).max(1.0);
        trace.facts.effort_quantum = Some(q);
    }
    Ok((trace, report))
}

/// Check the page headers of the projected root columns before any is decoded
/// ([`super::parquet_pages`]).
fn check_projected_pages(
    meta: &parquet::file::metadata::ParquetMetaData,
    roots: &[usize],
    name: &str,
    file: &impl ChunkReader,
) -> Result<(), TraceError> {
    let schema = meta.file_metadata().schema_descr();
    let leaves: Vec<usize> = (0..schema.num_columns())
        .filter(|&l| roots.contains(&schema.get_column_root_idx(l)))
        .collect();
    super::parquet_pages::check_pages(file, meta, &leaves, name)
}

/// Prefix of the key-value metadata that carry [`RecordingFacts`] (`feedscope.fact.KEY`).
pub const FACT_PREFIX: &str = "feedscope.fact.";

/// Find the columns, check their types, and choose the layout and the effort channel (the same
/// rules as the CSV header). Returns the plan and the root columns to project.
fn plan(schema: &Schema, name: &str, opts: &ReadOptions) -> Result<(Plan, Vec<usize>), TraceError> {
    for f in schema.fields() {
        if let Some(reason) = name_problem(f.name().as_bytes()) {
            return Err(TraceError::BadColumn {
                source_name: name.to_string(),
                column: show_name(f.name().as_bytes()),
                reason: format!("the column name {reason}"),
            });
        }
    }
    let names: Vec<String> = schema
        .fields()
        .iter()
        .map(|f| f.name().trim().to_ascii_lowercase())
        .collect();
    let listed = || {
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        }
    };
    let find = |wanted: &[&str]| names.iter().position(|n| wanted.contains(&n.as_str()));
    if let Some(reason) = super::read::duplicate_columns(&names) {
        return Err(TraceError::BadColumn {
            source_name: name.to_string(),
            column: names.join(", "),
            reason,
        });
    }
    let numeric = |index: usize, scale: f64| -> Result<(usize, Col), TraceError> {
        let field = &schema.fields()[index];
        if !is_numeric(field.data_type()) {
            return Err(TraceError::BadColumn {
                source_name: name.to_string(),
                column: field.name().clone(),
                reason: format!(
                    "type {} is not numeric (expected Float64, Float32, Int32 or Int64)",
                    field.data_type()
                ),
            });
        }
        Ok((
            index,
            Col {
                index,
                name: field.name().clone(),
                scale,
            },
        ))
    };
    let time = find(&["time_s", "time_ms"]).ok_or_else(|| TraceError::BadColumn {
        source_name: name.to_string(),
        column: "time_s".into(),
        reason: format!(
            "missing: neither `time_s` nor `time_ms` among the columns ({})",
            listed()
        ),
    })?;
    let time_scale = if names[time] == "time_ms" { 1e-3 } else { 1.0 };
    let position = find(&["position_mm", "position_m"]);
    let channel = find(&["channel"]);
    let value = find(&["value"]);
    let mut picked: Vec<(usize, Col)>;
    let plan = match (position, channel, value) {
        (None, Some(channel), Some(value)) => {
            let field = &schema.fields()[channel];
            let ok = match field.data_type() {
                DataType::Dictionary(_, v) => is_string(v),
                t => is_string(t),
            };
            if !ok {
                return Err(TraceError::BadColumn {
                    source_name: name.to_string(),
                    column: field.name().clone(),
                    reason: format!(
                        "type {} is not a string (expected Utf8, LargeUtf8 or a dictionary of \
                         them)",
                        field.data_type()
                    ),
                });
            }
            picked = vec![numeric(time, time_scale)?, numeric(value, 1.0)?];
            picked.push((
                channel,
                Col {
                    index: channel,
                    name: field.name().clone(),
                    scale: 1.0,
                },
            ));
            Plan::Long {
                time: picked[0].1.clone(),
                channel,
                value: picked[1].1.clone(),
            }
        }
        (None, _, _) => {
            return Err(TraceError::MissingChannel {
                source_name: name.to_string(),
                channel: "position_mm".into(),
                found: format!(
                    "{} (a wide file needs a `position_mm` or `position_m` column, a long file \
                     `channel` and `value` columns)",
                    listed()
                ),
            })
        }
        (Some(position), _, _) => {
            let position_scale = if names[position] == "position_mm" {
                1e-3
            } else {
                1.0
            };
            let cur = find(&["current_a"]);
            let tor = find(&["torque_nm"]);
            let (effort, effort_kind) = match choose_effort(cur, tor, opts.effort) {
                Ok(picked) => picked,
                Err(EffortChoice::Ambiguous) => {
                    return Err(TraceError::AmbiguousEffort {
                        source_name: name.to_string(),
                    })
                }
                Err(EffortChoice::Missing(k)) => {
                    return Err(TraceError::MissingChannel {
                        source_name: name.to_string(),
                        channel: k.column().into(),
                        found: listed(),
                    })
                }
                Err(EffortChoice::Neither) => {
                    return Err(TraceError::MissingChannel {
                        source_name: name.to_string(),
                        channel: "current_a or torque_nm".into(),
                        found: listed(),
                    })
                }
            };
            picked = vec![
                numeric(time, time_scale)?,
                numeric(position, position_scale)?,
                numeric(effort, 1.0)?,
            ];
            Plan::Wide {
                time: picked[0].1.clone(),
                position: picked[1].1.clone(),
                effort: picked[2].1.clone(),
                effort_kind,
            }
        }
    };
    // The projected batch holds the picked columns in file order; renumber to match.
    let mut roots: Vec<usize> = picked.iter().map(|(i, _)| *i).collect();
    roots.sort_unstable();
    roots.dedup();
    let at = |i: usize| roots.iter().position(|&r| r == i).unwrap_or(i);
    let plan = match plan {
        Plan::Wide {
            mut time,
            mut position,
            mut effort,
            effort_kind,
        } => {
            time.index = at(time.index);
            position.index = at(position.index);
            effort.index = at(effort.index);
            Plan::Wide {
                time,
                position,
                effort,
                effort_kind,
            }
        }
        Plan::Long {
            mut time,
            channel,
            mut value,
        } => {
            time.index = at(time.index);
            value.index = at(value.index);
            Plan::Long {
                time,
                channel: at(channel),
                value,
            }
        }
    };
    Ok((plan, roots))
}

/// The values of a numeric column as `f64`: borrowed for Float64, converted into `scratch`
/// otherwise. `None` for any other type (excluded by [`plan`]).
fn f64_values<'a>(col: &'a dyn Array, scratch: &'a mut Vec<f64>) -> Option<&'a [f64]> {
    if let Some(a) = col.as_primitive_opt::<Float64Type>() {
        return Some(a.values());
    }
    scratch.clear();
    if let Some(a) = col.as_primitive_opt::<Float32Type>() {
        scratch.extend(a.values().iter().map(|&v| f64::from(v)));
    } else if let Some(a) = col.as_primitive_opt::<Int32Type>() {
        scratch.extend(a.values().iter().map(|&v| f64::from(v)));
    } else if let Some(a) = col.as_primitive_opt::<Int64Type>() {
        // Exact up to 2^53; a time stamp or position beyond that is not a trace.
        scratch.extend(a.values().iter().map(|&v| v as f64));
    } else {
        return None;
    }
    Some(scratch)
}

/// The channels being filled and the counters of the report.
struct State<'n> {
    name: &'n str,
    pos: Channel,
    cur: Channel,
    tor: Channel,
    /// The data row of the first sample of `pos`, `cur` and `tor` (for a row group decoded
    /// apart, whose first time is checked against the previous group's last when joined).
    first_rows: [Option<u64>; 3],
    rows: u64,
    ignored_rows: u64,
    ignored_names: Vec<String>,
    scratch: [Vec<f64>; 3],
    codes: Vec<u8>,
}

impl<'n> State<'n> {
    fn new(name: &'n str, plan: &Plan, total_rows: usize) -> Self {
        let mut s = Self {
            name,
            pos: Channel::default(),
            cur: Channel::default(),
            tor: Channel::default(),
            first_rows: [None; 3],
            rows: 0,
            ignored_rows: 0,
            ignored_names: Vec::new(),
            scratch: Default::default(),
            codes: Vec::new(),
        };
        // The row count is in the footer: reserve once instead of growing by doubling. Wide
        // files have at most one sample per channel per row; long files usually split evenly.
        let (p, e) = match plan {
            Plan::Wide { .. } => (total_rows, total_rows),
            Plan::Long { .. } => (total_rows / 2, total_rows / 2),
        };
        let eff = match plan {
            Plan::Wide {
                effort_kind: EffortKind::TorqueNm,
                ..
            } => &mut s.tor,
            _ => &mut s.cur,
        };
        eff.time_s.reserve(e);
        eff.value.reserve(e);
        s.pos.time_s.reserve(p);
        s.pos.value.reserve(p);
        s
    }

    /// Append a row group decoded apart (its rows follow this state's): the times of each
    /// channel must still increase across the join.
    /// The part's channels are left empty (their capacity kept for reuse).
    fn append(&mut self, part: &mut State<'_>) -> Result<(), TraceError> {
        let labels = ["position", "current_a", "torque_nm"];
        for (k, (mine, theirs)) in [
            (&mut self.pos, &mut part.pos),
            (&mut self.cur, &mut part.cur),
            (&mut self.tor, &mut part.tor),
        ]
        .into_iter()
        .enumerate()
        {
            if let (Some(&prev), Some(&t)) = (mine.time_s.last(), theirs.time_s.first()) {
                if t <= prev {
                    return Err(TraceError::TimeNotIncreasingInRow {
                        source_name: self.name.to_string(),
                        channel: labels[k].into(),
                        row: part.first_rows[k].unwrap_or(part.rows),
                        time_s: t,
                        previous_time_s: prev,
                    });
                }
            }
            if self.first_rows[k].is_none() {
                self.first_rows[k] = part.first_rows[k];
            }
            mine.time_s.extend_from_slice(&theirs.time_s);
            mine.value.extend_from_slice(&theirs.value);
            theirs.time_s.clear();
            theirs.value.clear();
        }
        self.rows = part.rows;
        // The rows were counted by the part; its names join the list as if read here.
        self.ignore_rows(part.ignored_rows);
        for n in &part.ignored_names {
            self.ignore(n, 0);
        }
        Ok(())
    }

    fn unreadable(&self, col: &str) -> TraceError {
        TraceError::BadColumn {
            source_name: self.name.to_string(),
            column: col.to_string(),
            reason: "the decoded column has an unexpected type".into(),
        }
    }

    fn batch(&mut self, batch: &RecordBatch, plan: &Plan) -> Result<(), TraceError> {
        match plan {
            Plan::Wide {
                time,
                position,
                effort,
                effort_kind,
            } => self.wide(batch, time, position, effort, *effort_kind)?,
            Plan::Long {
                time,
                channel,
                value,
            } => self.long(batch, time, *channel, value)?,
        }
        self.rows += batch.num_rows() as u64;
        Ok(())
    }

    fn wide(
        &mut self,
        batch: &RecordBatch,
        time: &Col,
        position: &Col,
        effort: &Col,
        effort_kind: EffortKind,
    ) -> Result<(), TraceError> {
        let [s_t, s_p, s_e] = &mut self.scratch;
        let (tc, pc, ec) = (
            batch.column(time.index),
            batch.column(position.index),
            batch.column(effort.index),
        );
        let (Some(tv), Some(pv), Some(ev)) = (
            f64_values(tc.as_ref(), s_t),
            f64_values(pc.as_ref(), s_p),
            f64_values(ec.as_ref(), s_e),
        ) else {
            return Err(self.unreadable(&time.name));
        };
        let (tn, pn, en) = (tc.nulls(), pc.nulls(), ec.nulls());
        let base = self.rows;
        let name = self.name;
        let (eff, k_eff) = match effort_kind {
            EffortKind::CurrentA => (&mut self.cur, 1),
            EffortKind::TorqueNm => (&mut self.tor, 2),
        };
        let pos = &mut self.pos;
        let first_rows = &mut self.first_rows;
        for i in 0..tv.len() {
            let row = base + i as u64 + 1;
            if tn.is_some_and(|b| b.is_null(i)) {
                return Err(bad_cell(name, row, &time.name, NULL_TIME));
            }
            let t = finite(name, row, &time.name, tv[i])? * time.scale;
            for (k, ch, v_raw, null, col, label) in [
                (0, &mut *pos, pv[i], pn, position, "position"),
                (k_eff, &mut *eff, ev[i], en, effort, effort_kind.column()),
            ] {
                if null.is_some_and(|b| b.is_null(i)) {
                    continue; // no sample of this channel at this time
                }
                let v = finite(name, row, &col.name, v_raw)? * col.scale;
                push_sample(ch, t, v, name, row, label)?;
                first_rows[k].get_or_insert(row);
            }
        }
        Ok(())
    }

    fn long(
        &mut self,
        batch: &RecordBatch,
        time: &Col,
        channel: usize,
        value: &Col,
    ) -> Result<(), TraceError> {
        let n = batch.num_rows();
        self.channel_codes(batch.column(channel))?;
        let [s_t, s_v, _] = &mut self.scratch;
        let (tc, vc) = (batch.column(time.index), batch.column(value.index));
        let (Some(tv), Some(vv)) = (f64_values(tc.as_ref(), s_t), f64_values(vc.as_ref(), s_v))
        else {
            return Err(self.unreadable(&time.name));
        };
        let (tn, vn) = (tc.nulls(), vc.nulls());
        let base = self.rows;
        let name = self.name;
        for i in 0..n {
            let code = self.codes[i];
            let row = base + i as u64 + 1;
            let (k, ch, scale, label) = match code {
                POS_MM => (0, &mut self.pos, 1e-3, "position"),
                POS_M => (0, &mut self.pos, 1.0, "position"),
                CUR => (1, &mut self.cur, 1.0, "current_a"),
                TOR => (2, &mut self.tor, 1.0, "torque_nm"),
                IGNORED => continue,
                NULL_CHANNEL => return Err(bad_cell(name, row, "channel", "is null")),
                _ => return Err(bad_cell(name, row, "channel", "is empty (no channel name)")),
            };
            if tn.is_some_and(|b| b.is_null(i)) {
                return Err(bad_cell(name, row, &time.name, NULL_TIME));
            }
            if vn.is_some_and(|b| b.is_null(i)) {
                return Err(bad_cell(
                    name,
                    row,
                    &value.name,
                    "is null (every sample row of the long layout needs a value)",
                ));
            }
            let t = finite(name, row, &time.name, tv[i])? * time.scale;
            let v = finite(name, row, &value.name, vv[i])? * scale;
            push_sample(ch, t, v, name, row, label)?;
            self.first_rows[k].get_or_insert(row);
        }
        Ok(())
    }

    /// Fill `self.codes` with one channel code per row, counting ignored rows and names.
    fn channel_codes(&mut self, col: &ArrayRef) -> Result<(), TraceError> {
        let n = col.len();
        self.codes.clear();
        self.codes.reserve(n);
        if let Some(d) = col.as_any_dictionary_opt() {
            // Decide once per dictionary entry, then map the keys.
            let values = d.values();
            let mut entry: Vec<u8> = Vec::with_capacity(values.len());
            let mut names: Vec<String> = Vec::with_capacity(values.len());
            for_each_string(values.as_ref(), |s| {
                entry.push(s.map_or(NULL_CHANNEL, channel_code));
                names.push(s.unwrap_or_default().to_string());
            })
            .ok_or_else(|| self.unreadable("channel"))?;
            if entry.is_empty() {
                // No entries: every key is null (`normalized_keys` would panic).
                self.codes.resize(n, NULL_CHANNEL);
                return Ok(());
            }
            // Unknown names are checked once per entry; a bad one is an error at the first row
            // that uses it.
            for (code, n) in entry.iter_mut().zip(&names) {
                if *code == IGNORED && name_problem(n.as_bytes()).is_some() {
                    *code = BAD_NAME;
                }
            }
            let mut used = vec![0u64; entry.len()];
            let keys = d.normalized_keys();
            let nulls = d.nulls();
            for (i, &k) in keys.iter().enumerate() {
                let code = if nulls.is_some_and(|b| b.is_null(i)) {
                    NULL_CHANNEL
                } else {
                    entry[k]
                };
                if code == IGNORED {
                    used[k] += 1;
                } else if code == BAD_NAME {
                    return Err(self.bad_name(i, names[k].as_bytes()));
                }
                self.codes.push(code);
            }
            for (k, &u) in used.iter().enumerate() {
                if u > 0 {
                    self.ignore(&names[k], u);
                }
            }
            return Ok(());
        }
        // Names listed (as the report keeps at most 16) with their rows; rows of other unknown
        // names are only counted, so the search stays short whatever the file holds.
        let mut ignored: Vec<(String, u64)> = Vec::new();
        let mut unlisted = 0u64;
        let mut bad: Option<(usize, Vec<u8>)> = None;
        let codes = &mut self.codes;
        for_each_string(col.as_ref(), |s| {
            let code = s.map_or(NULL_CHANNEL, channel_code);
            if code == IGNORED {
                let s = s.unwrap_or_default();
                let listed = ignored.len();
                match ignored.iter_mut().find(|(n, _)| n == s) {
                    Some((_, c)) => *c += 1,
                    // Checked once per distinct name while the list has room, else per row.
                    None if name_problem(s.as_bytes()).is_some() => {
                        if bad.is_none() {
                            bad = Some((codes.len(), s.as_bytes().to_vec()));
                        }
                    }
                    None if listed < 16 => ignored.push((s.to_string(), 1)),
                    None => unlisted += 1,
                }
            }
            codes.push(code);
        })
        .ok_or_else(|| self.unreadable("channel"))?;
        if let Some((i, n)) = bad {
            return Err(self.bad_name(i, &n));
        }
        for (name, count) in ignored {
            self.ignore(&name, count);
        }
        self.ignored_rows += unlisted;
        Ok(())
    }

    /// A channel name that is too long or holds a control character, at row `i` of the batch.
    fn bad_name(&self, i: usize, n: &[u8]) -> TraceError {
        let reason = name_problem(n).unwrap_or_default();
        let row = self.rows + i as u64 + 1;
        bad_cell(
            self.name,
            row,
            "channel",
            &format!("name `{}` {reason}", show_name(n)),
        )
    }

    fn ignore_rows(&mut self, rows: u64) {
        self.ignored_rows += rows;
    }

    fn ignore(&mut self, name: &str, rows: u64) {
        self.ignored_rows += rows;
        if self.ignored_names.len() < 16 && !self.ignored_names.iter().any(|n| n == name) {
            self.ignored_names.push(name.to_string());
        }
    }

    fn finish(self, plan: &Plan, opts: &ReadOptions) -> Result<(Trace, ReadReport), TraceError> {
        let name = self.name;
        let (effort, effort_kind, layout) = match plan {
            Plan::Wide { effort_kind, .. } => {
                let ch = match effort_kind {
                    EffortKind::CurrentA => self.cur,
                    EffortKind::TorqueNm => self.tor,
                };
                (ch, *effort_kind, Layout::Wide)
            }
            Plan::Long { .. } => {
                // The effort choice of the CSV reader's long layout.
                let seen = || {
                    let mut s: Vec<String> = [
                        (&self.pos, "position"),
                        (&self.cur, "current_a"),
                        (&self.tor, "torque_nm"),
                    ]
                    .iter()
                    .filter(|(c, _)| !c.is_empty())
                    .map(|(_, n)| n.to_string())
                    .collect();
                    s.extend(self.ignored_names.iter().cloned());
                    if s.is_empty() {
                        "none".to_string()
                    } else {
                        s.join(", ")
                    }
                };
                let missing = |channel: &str| TraceError::MissingChannel {
                    source_name: name.to_string(),
                    channel: channel.into(),
                    found: seen(),
                };
                let choice = match (self.cur.is_empty(), self.tor.is_empty(), opts.effort) {
                    (_, _, Some(k)) => k,
                    (false, true, None) => EffortKind::CurrentA,
                    (true, false, None) => EffortKind::TorqueNm,
                    (false, false, None) => {
                        return Err(TraceError::AmbiguousEffort {
                            source_name: name.to_string(),
                        })
                    }
                    (true, true, None) => return Err(missing("current_a or torque_nm")),
                };
                let empty = match choice {
                    EffortKind::CurrentA => self.cur.is_empty(),
                    EffortKind::TorqueNm => self.tor.is_empty(),
                };
                if empty {
                    return Err(missing(choice.column()));
                }
                if self.pos.is_empty() {
                    return Err(missing("position_mm"));
                }
                let ch = match choice {
                    EffortKind::CurrentA => self.cur,
                    EffortKind::TorqueNm => self.tor,
                };
                (ch, choice, Layout::Long)
            }
        };
        // The final checks are the caller's (`screen_and_check`), as for CSV.
        Ok((
            Trace {
                position_m: self.pos,
                effort,
                effort_kind,
                facts: Default::default(),
            },
            ReadReport {
                ignored_rows: self.ignored_rows,
                ignored_channels: self.ignored_names,
                lines: self.rows,
                layout: Some(layout),
                ..ReadReport::default()
            },
        ))
    }
}

const NULL_TIME: &str = "is null (every row needs a time)";

/// `v` when finite, else the error naming the row and column.
fn finite(name: &str, row: u64, column: &str, v: f64) -> Result<f64, TraceError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(TraceError::NonFiniteInRow {
            source_name: name.to_string(),
            row,
            column: column.to_string(),
            value: v,
        })
    }
}

/// Append a sample (SI units) to a channel whose time must strictly increase.
fn push_sample(
    ch: &mut Channel,
    t: f64,
    v: f64,
    name: &str,
    row: u64,
    label: &str,
) -> Result<(), TraceError> {
    if let Some(e) = super::limits::check(name, label, v, None, Some(row)) {
        return Err(e);
    }
    if let Some(&prev) = ch.time_s.last() {
        if t <= prev {
            return Err(TraceError::TimeNotIncreasingInRow {
                source_name: name.to_string(),
                channel: label.into(),
                row,
                time_s: t,
                previous_time_s: prev,
            });
        }
    }
    ch.time_s.push(t);
    ch.value.push(v);
    Ok(())
}

fn bad_cell(name: &str, row: u64, column: &str, reason: &str) -> TraceError {
    TraceError::BadCell {
        source_name: name.to_string(),
        row,
        column: column.to_string(),
        reason: reason.to_string(),
    }
}

/// Call `f` with each string of a Utf8, LargeUtf8 or Utf8View array (`None` for a null);
/// `None` when the array is of another type.
fn for_each_string(col: &dyn Array, mut f: impl FnMut(Option<&str>)) -> Option<()> {
    if let Some(a) = col.as_string_opt::<i32>() {
        a.iter().for_each(&mut f);
    } else if let Some(a) = col.as_string_opt::<i64>() {
        a.iter().for_each(&mut f);
    } else if let Some(a) = col.as_any().downcast_ref::<StringViewArray>() {
        a.iter().for_each(&mut f);
    } else {
        return None;
    }
    Some(())
}

/// Write the trace as Parquet (Snappy-compressed), the Parquet counterpart of
/// [`write_csv`](super::write_csv) with the same two layouts:
/// - wide: columns `time_s`, `position_m`, and `current_a` or `torque_nm`, all Float64;
///   needs both channels on the same timestamps;
/// - long: `time_s` (Float64), `channel` (dictionary-encoded string: `position_m`,
///   `current_a` or `torque_nm`), `value` (Float64), both channels merged in time order.
///
/// Unlike CSV nothing is rounded: values are stored in SI at full `f64` precision (hence
/// `position_m`, not `position_mm`), so [`read_trace_file`](super::read_trace_file) gives
/// back exactly this trace.
///
/// # Errors
/// I/O and encoder errors; `InvalidInput` when the wide layout is asked for channels with
/// different timestamps.
pub fn write_parquet<W: Write + Send>(trace: &Trace, w: W, layout: Layout) -> std::io::Result<()> {
    let effort = trace.effort_kind.column();
    // Dictionary pages only pay for the channel names; time and value are all distinct.
    let props = WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .set_dictionary_enabled(false)
        .set_column_dictionary_enabled(ColumnPath::from("channel"), true)
        .set_key_value_metadata(Some(
            trace
                .facts
                .to_pairs()
                .into_iter()
                .map(|(k, v)| KeyValue::new(format!("{FACT_PREFIX}{k}"), v))
                .collect(),
        ))
        .build();
    let f64_col = |s: &[f64]| -> ArrayRef { Arc::new(Float64Array::from(s.to_vec())) };
    match layout {
        Layout::Wide => {
            if trace.position_m.time_s != trace.effort.time_s {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    "the wide layout needs position and effort on the same timestamps",
                ));
            }
            let schema = Arc::new(Schema::new(vec![
                Field::new("time_s", DataType::Float64, false),
                Field::new("position_m", DataType::Float64, false),
                Field::new(effort, DataType::Float64, false),
            ]));
            let mut writer = ArrowWriter::try_new(w, schema.clone(), Some(props))
                .map_err(std::io::Error::other)?;
            let n = trace.position_m.len();
            let mut k = 0;
            while k < n {
                let end = (k + BATCH_ROWS).min(n);
                let batch = RecordBatch::try_new(
                    schema.clone(),
                    vec![
                        f64_col(&trace.position_m.time_s[k..end]),
                        f64_col(&trace.position_m.value[k..end]),
                        f64_col(&trace.effort.value[k..end]),
                    ],
                )
                .map_err(std::io::Error::other)?;
                writer.write(&batch).map_err(std::io::Error::other)?;
                k = end;
            }
            writer.close().map_err(std::io::Error::other)?;
        }
        Layout::Long => {
            let dict = DataType::Dictionary(Box::new(DataType::Int8), Box::new(DataType::Utf8));
            let schema = Arc::new(Schema::new(vec![
                Field::new("time_s", DataType::Float64, false),
                Field::new("channel", dict, false),
                Field::new("value", DataType::Float64, false),
            ]));
            let names: ArrayRef = Arc::new(StringArray::from(vec!["position_m", effort]));
            let mut writer = ArrowWriter::try_new(w, schema.clone(), Some(props))
                .map_err(std::io::Error::other)?;
            let (p, e) = (&trace.position_m, &trace.effort);
            let (mut i, mut j) = (0, 0);
            let mut time = Vec::with_capacity(BATCH_ROWS);
            let mut key: Vec<i8> = Vec::with_capacity(BATCH_ROWS);
            let mut value = Vec::with_capacity(BATCH_ROWS);
            while i < p.len() || j < e.len() {
                // The merge of `write_csv`: position first on equal times.
                let take_p = j >= e.len() || (i < p.len() && p.time_s[i] <= e.time_s[j]);
                if take_p {
                    time.push(p.time_s[i]);
                    key.push(0);
                    value.push(p.value[i]);
                    i += 1;
                } else {
                    time.push(e.time_s[j]);
                    key.push(1);
                    value.push(e.value[j]);
                    j += 1;
                }
                let last = i == p.len() && j == e.len();
                if time.len() == BATCH_ROWS || last {
                    let channel = DictionaryArray::<Int8Type>::try_new(
                        Int8Array::from(std::mem::take(&mut key)),
                        names.clone(),
                    )
                    .map_err(std::io::Error::other)?;
                    let batch = RecordBatch::try_new(
                        schema.clone(),
                        vec![
                            Arc::new(Float64Array::from(std::mem::take(&mut time))),
                            Arc::new(channel),
                            Arc::new(Float64Array::from(std::mem::take(&mut value))),
                        ],
                    )
                    .map_err(std::io::Error::other)?;
                    writer.write(&batch).map_err(std::io::Error::other)?;
                    time.reserve(BATCH_ROWS);
                    key.reserve(BATCH_ROWS);
                    value.reserve(BATCH_ROWS);
                }
            }
            writer.close().map_err(std::io::Error::other)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::{parse_trace, read_trace_file};
    use arrow_array::types::Int32Type;
    use arrow_array::{Float32Array, Int32Array, Int64Array, LargeStringArray};
    use std::path::PathBuf;

    fn read(path: &Path) -> Result<(Trace, ReadReport), TraceError> {
        read_trace_file(path, &ReadOptions::default())
    }

    /// Both channels on one clock (`sync`) or 0.4 ms apart; position 0 → 60 mm → 0 with a
    /// ripple, current a ripple around ±1 A. Values are rounded to what the CSV writer keeps
    /// (6 decimals of s, mm and A) so that the CSV round trip is exact up to parsing.
    fn trace(n: usize, sync: bool) -> Trace {
        let round6 = |x: f64| (x * 1e6).round() / 1e6;
        let mut pos = Channel::default();
        let mut cur = Channel::default();
        for k in 0..n {
            let t = round6(k as f64 * 1e-3 + 0.125);
            let u = k as f64 / n as f64;
            let z_mm = 60.0 * (1.0 - (2.0 * u - 1.0).abs()) + 0.01 * (7.3 * u).sin();
            pos.time_s.push(t);
            pos.value.push(round6(z_mm) * 1e-3);
            let te = if sync { t } else { round6(t + 4e-4) };
            cur.time_s.push(te);
            cur.value.push(round6(
                (1.0 - 2.0 * (u > 0.5) as u8 as f64) + 0.1 * (31.0 * u).cos(),
            ));
        }
        Trace {
            position_m: pos,
            effort: cur,
            effort_kind: EffortKind::CurrentA,
            facts: Default::default(),
        }
    }

    fn write_parquet(path: &Path, t: &Trace, layout: Layout) {
        super::write_parquet(t, File::create(path).unwrap(), layout).unwrap();
    }

    fn write_columns(path: &Path, cols: Vec<(&str, ArrayRef)>) {
        let batch = RecordBatch::try_from_iter(cols).unwrap();
        let mut w =
            ArrowWriter::try_new(File::create(path).unwrap(), batch.schema(), None).unwrap();
        w.write(&batch).unwrap();
        w.close().unwrap();
    }

    fn f64s(v: &[f64]) -> ArrayRef {
        Arc::new(Float64Array::from(v.to_vec()))
    }

    fn opt_f64s(v: &[Option<f64>]) -> ArrayRef {
        Arc::new(Float64Array::from(v.to_vec()))
    }

    fn strs(v: &[&str]) -> ArrayRef {
        Arc::new(StringArray::from(v.to_vec()))
    }

    /// `a` and `b` agree to 1e-9 relative: the CSV keeps 6 decimals, and the trace above has
    /// no more, so only the decimal parse (≤ 1 ulp) separates them.
    fn close(a: &[f64], b: &[f64]) {
        assert_eq!(a.len(), b.len());
        for (k, (x, y)) in a.iter().zip(b).enumerate() {
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
                "sample {k}: {x} vs {y}"
            );
        }
    }

    /// A good wide file of `rows` rows in `dir`, returned with its bytes.
    fn good_file(dir: &Path, rows: usize) -> (PathBuf, Vec<u8>) {
        let p = dir.join("good.parquet");
        write_parquet(&p, &trace(rows, true), Layout::Wide);
        let bytes = std::fs::read(&p).unwrap();
        (p, bytes)
    }

    #[test]
    fn round_trip_both_layouts_against_memory_and_csv() {
        let d = tempfile::tempdir().unwrap();
        // 150 000 rows: several record batches (64 Ki rows each) and a batch boundary
        // inside each channel.
        for (sync, layouts) in [
            (true, &[Layout::Wide, Layout::Long][..]),
            (false, &[Layout::Long][..]),
        ] {
            let t = trace(150_000, sync);
            for &layout in layouts {
                let pq = d.path().join("t.parquet");
                let csv = d.path().join("t.csv");
                write_parquet(&pq, &t, layout);
                crate::trace::write_csv(&t, File::create(&csv).unwrap(), layout).unwrap();
                let (from_pq, report) = read(&pq).unwrap();
                let (from_csv, _) = read(&csv).unwrap();
                // Parquet keeps every bit.
                assert_eq!(from_pq, t, "{layout:?} sync={sync}");
                assert_eq!(report.layout, Some(layout));
                let rows = if layout == Layout::Wide {
                    150_000
                } else {
                    300_000
                };
                assert_eq!(report.lines, rows);
                assert_eq!(report.ignored_rows, 0);
                assert_eq!(from_csv.effort_kind, from_pq.effort_kind);
                for (a, b) in [
                    (&from_csv.position_m, &from_pq.position_m),
                    (&from_csv.effort, &from_pq.effort),
                ] {
                    close(&a.time_s, &b.time_s);
                    close(&a.value, &b.value);
                }
            }
        }
        // The wide layout needs one clock, as for CSV.
        let err = super::write_parquet(&trace(100, false), Vec::new(), Layout::Wide).unwrap_err();
        assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput);
    }

    /// Files as other tools write them: polars defaults to zstd, pyarrow to snappy, Spark and
    /// older writers to gzip, some to LZ4. Each codec is read bit for bit.
    #[test]
    fn every_common_codec_is_read() {
        use parquet::basic::{GzipLevel, ZstdLevel};
        let d = tempfile::tempdir().unwrap();
        let t = trace(5_000, true);
        let cols = vec![
            ("time_s", f64s(&t.position_m.time_s)),
            ("position_m", f64s(&t.position_m.value)),
            (t.effort_kind.column(), f64s(&t.effort.value)),
        ];
        let batch = RecordBatch::try_from_iter(cols).unwrap();
        for codec in [
            Compression::UNCOMPRESSED,
            Compression::SNAPPY,
            Compression::ZSTD(ZstdLevel::default()),
            Compression::GZIP(GzipLevel::default()),
            Compression::LZ4_RAW,
            Compression::LZ4,
        ] {
            let p = d.path().join("c.parquet");
            let props = WriterProperties::builder().set_compression(codec).build();
            let mut w =
                ArrowWriter::try_new(File::create(&p).unwrap(), batch.schema(), Some(props))
                    .unwrap();
            w.write(&batch).unwrap();
            w.close().unwrap();
            let (back, _) = read(&p).unwrap_or_else(|e| panic!("{codec:?}: {e}"));
            assert_eq!(back, t, "{codec:?}");
        }
    }

    #[test]
    fn simulated_trace_round_trips() {
        let cfg = feedscope::sim::SimConfig::from_toml_str(
            "seed = 7\n[motion]\nlead_in_s = 0.2\nlead_out_s = 0.2\n\
             [[motion.stroke]]\nto_mm = 5\nfeed_mm_min = 600\n",
        )
        .unwrap();
        let out = feedscope::sim::simulate(&cfg, &mut |_| {}).unwrap();
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("sim.parquet");
        write_parquet(&p, &out.trace, Layout::Long);
        assert_eq!(read(&p).unwrap().0, out.trace);
    }

    #[test]
    fn torque_round_trips() {
        let mut t = trace(1000, true);
        t.effort_kind = EffortKind::TorqueNm;
        let d = tempfile::tempdir().unwrap();
        for layout in [Layout::Wide, Layout::Long] {
            let p = d.path().join("t.parquet");
            write_parquet(&p, &t, layout);
            assert_eq!(read(&p).unwrap().0, t);
        }
    }

    #[test]
    fn wide_nulls_are_missing_samples() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("w.parquet");
        let time: Vec<f64> = (0..8).map(|k| k as f64 * 0.5).collect();
        let pos: Vec<Option<f64>> = (0..8).map(|k| (k % 2 == 0).then_some(k as f64)).collect();
        let cur: Vec<Option<f64>> = (0..8)
            .map(|k| (k % 2 == 1).then_some(k as f64 * 0.1))
            .collect();
        write_columns(
            &p,
            vec![
                ("time_s", f64s(&time)),
                ("position_mm", opt_f64s(&pos)),
                ("current_a", opt_f64s(&cur)),
            ],
        );
        let (t, r) = read(&p).unwrap();
        assert_eq!(t.position_m.time_s, [0.0, 1.0, 2.0, 3.0]);
        assert_eq!(t.effort.time_s, [0.5, 1.5, 2.5, 3.5]);
        close(&t.position_m.value, &[0.0, 2e-3, 4e-3, 6e-3]);
        close(&t.effort.value, &[0.1, 0.3, 0.5, 0.7]);
        assert_eq!(r.layout, Some(Layout::Wide));
        assert_eq!(r.lines, 8);
    }

    #[test]
    fn integer_and_float32_columns_time_ms_and_extra_columns() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("w.parquet");
        write_columns(
            &p,
            vec![
                ("comment", strs(&["a", "b", "c", "d", "e"])),
                (
                    "time_ms",
                    Arc::new(Int64Array::from(vec![0i64, 2, 4, 6, 8])),
                ),
                (
                    "Position_MM",
                    Arc::new(Float32Array::from(vec![0.0f32, 0.5, 1.0, 1.5, 2.0])),
                ),
                ("speed_mm_min", f64s(&[1.0; 5])),
                (
                    "torque_nm",
                    Arc::new(Int32Array::from(vec![3i32, -3, 4, -4, 5])),
                ),
            ],
        );
        let (t, _) = read(&p).unwrap();
        assert_eq!(t.effort_kind, EffortKind::TorqueNm);
        // ms → s and mm → m by the same multiplications as the CSV reader.
        assert_eq!(
            t.position_m.time_s,
            [0.0, 2.0 * 1e-3, 4.0 * 1e-3, 6.0 * 1e-3, 8.0 * 1e-3]
        );
        assert_eq!(
            t.position_m.value,
            [0.0, 0.5 * 1e-3, 1e-3, 1.5 * 1e-3, 2.0 * 1e-3]
        );
        assert_eq!(t.effort.value, [3.0, -3.0, 4.0, -4.0, 5.0]);
    }

    /// Long-layout columns: time 0, 0.1, …; channels cycling position_mm, current_a, speed.
    fn long_columns(rows: usize, channel: ArrayRef) -> Vec<(&'static str, ArrayRef)> {
        let time: Vec<f64> = (0..rows).map(|k| k as f64 * 0.1).collect();
        let value: Vec<f64> = (0..rows).map(|k| k as f64).collect();
        vec![
            ("time_s", f64s(&time)),
            ("channel", channel),
            ("value", f64s(&value)),
            ("note", strs(&vec!["x"; rows])),
        ]
    }

    fn cycle(rows: usize) -> Vec<&'static str> {
        (0..rows)
            .map(|k| ["position_mm", "current_a", "speed"][k % 3])
            .collect()
    }

    #[test]
    fn long_channel_as_utf8_large_utf8_or_dictionary() {
        let d = tempfile::tempdir().unwrap();
        let rows = 15;
        let names = cycle(rows);
        let dict: DictionaryArray<Int32Type> = names.iter().copied().collect();
        let mut results = Vec::new();
        for (k, channel) in [
            strs(&names),
            Arc::new(LargeStringArray::from(names.clone())) as ArrayRef,
            Arc::new(dict) as ArrayRef,
        ]
        .into_iter()
        .enumerate()
        {
            let p = d.path().join(format!("l{k}.parquet"));
            write_columns(&p, long_columns(rows, channel));
            let (t, r) = read(&p).unwrap();
            assert_eq!(r.layout, Some(Layout::Long));
            assert_eq!(r.ignored_rows, 5);
            assert_eq!(r.ignored_channels, ["speed"]);
            assert_eq!(t.position_m.len(), 5);
            // Row 4 holds the second current sample, its time written as 4.0 * 0.1: no unit
            // conversion, so the same bits come back.
            assert_eq!(t.effort.time_s[1].to_bits(), (4.0 * 0.1f64).to_bits());
            results.push(t);
        }
        assert_eq!(results[0], results[1]);
        assert_eq!(results[0], results[2]);
    }

    #[test]
    fn long_position_in_metres_and_millimetres_mix_like_csv() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("l.parquet");
        let ch = [
            "position_m",
            "current_a",
            "position_mm",
            "current_a",
            "position_m",
            "current_a",
            "position_mm",
            "current_a",
        ];
        write_columns(
            &p,
            vec![
                ("time_ms", f64s(&[0., 1., 2., 3., 4., 5., 6., 7.])),
                ("channel", strs(&ch)),
                ("value", f64s(&[0.001, 1., 2., 1., 0.003, 1., 4., 1.])),
            ],
        );
        let (t, _) = read(&p).unwrap();
        close(&t.position_m.value, &[0.001, 0.002, 0.003, 0.004]);
        close(&t.effort.time_s, &[0.001, 0.003, 0.005, 0.007]);
    }

    // ---- malformed files: each gives its error, names the file, never panics ----

    fn err(path: &Path) -> TraceError {
        let e = read(path).unwrap_err();
        assert!(
            e.to_string().contains(&path.display().to_string()),
            "the message does not name the file: {e}"
        );
        e
    }

    #[test]
    fn truncated_files() {
        let d = tempfile::tempdir().unwrap();
        let (_, bytes) = good_file(d.path(), 1000);
        let p = d.path().join("cut.parquet");
        for keep in [4, 8, bytes.len() / 2, bytes.len() - 1] {
            std::fs::write(&p, &bytes[..keep]).unwrap();
            match err(&p) {
                TraceError::Parquet { .. } => {}
                e => panic!("{keep} bytes: {e}"),
            }
        }
    }

    #[test]
    fn magic_then_garbage() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("g.parquet");
        let mut junk = b"PAR1".to_vec();
        junk.extend((0..5000u32).map(|k| (k.wrapping_mul(2_654_435_761) >> 13) as u8));
        std::fs::write(&p, &junk).unwrap();
        assert!(matches!(err(&p), TraceError::Parquet { .. }));
        // Magic at both ends, garbage footer length and metadata.
        junk.extend_from_slice(&[0xff, 0xff, 0, 0]);
        junk.extend_from_slice(b"PAR1");
        std::fs::write(&p, &junk).unwrap();
        assert!(matches!(err(&p), TraceError::Parquet { .. }));
    }

    #[test]
    fn a_page_claiming_gigabytes_is_refused_before_it_is_decoded() {
        // The fuzz finding: a 2 kB file whose dictionary page header of `channel` has, where
        // its uncompressed size should be, a field of the wrong wire type. The decoder reads a
        // field by its id whatever its type, took the 7-byte varint that follows as
        // 1,386,564,245 bytes and reserved them before it failed. The page check reads the
        // header as Thrift and refuses it before any page is decoded, naming where it is.
        let bytes =
            include_bytes!("../../../feedscope-fuzz/regressions/trace_parquet/page-claims-1.4-GB");
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("forged.parquet");
        std::fs::write(&p, bytes).unwrap();
        let e = err(&p).to_string();
        let named = "row group 0, column `channel`: the page header at byte 448 is not a page \
                     header (an unknown Thrift wire type)";
        assert!(e.contains(named), "{e}");
        let opts = ReadOptions::default();
        let from_memory =
            super::super::parse_trace_with(bytes, "forged", &opts, &GlitchParams::default());
        assert!(from_memory.is_err_and(|e| e.to_string().contains(named)));
    }

    #[test]
    fn a_page_claiming_more_than_its_rows_hold_is_refused_naming_it() {
        // A well-formed header whose uncompressed size is 1.4 GB for a page of 300 doubles.
        let d = tempfile::tempdir().unwrap();
        let (_, bytes) = good_file(d.path(), 300);
        let forged =
            super::super::parquet_pages::tests::forge_first_page(&bytes.into(), 1, 1_386_564_245);
        let p = d.path().join("forged.parquet");
        std::fs::write(&p, &forged).unwrap();
        let e = err(&p).to_string();
        assert!(
            e.contains(
                "row group 0, column `position_m`: the page at byte 1634 claims 1386564245 \
                        bytes uncompressed, more than the 300 rows of its row group can hold"
            ),
            "{e}"
        );
    }

    #[test]
    fn corrupted_bytes_give_errors_not_panics() {
        // Overwrite each byte of a small file in turn (three patterns): the read may succeed
        // (a changed digit of a value) or fail, but must not panic.
        for layout in [Layout::Wide, Layout::Long] {
            let mut bytes = Vec::new();
            super::write_parquet(&trace(200, true), &mut bytes, layout).unwrap();
            assert!(parse_trace(&bytes, "c.parquet", &ReadOptions::default()).is_ok());
            for k in 4..bytes.len() {
                for pattern in [0xff, 0x00, bytes[k] ^ 0x55] {
                    let mut b = bytes.clone();
                    if b[k] == pattern {
                        continue;
                    }
                    b[k] = pattern;
                    let _ = parse_trace(&b, "c.parquet", &ReadOptions::default());
                }
            }
        }
    }

    #[test]
    fn parquet_name_without_magic_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("t.parquet");
        std::fs::write(&p, "time_s,position_mm,current_a\n0,0,1\n").unwrap();
        match err(&p) {
            TraceError::Parquet { reason, .. } => assert!(reason.contains("PAR1"), "{reason}"),
            e => panic!("{e}"),
        }
        // A CSV that is not named .parquet is still CSV.
        let c = d.path().join("t.csv");
        crate::trace::write_csv(&trace(100, true), File::create(&c).unwrap(), Layout::Wide)
            .unwrap();
        read(&c).unwrap();
    }

    #[test]
    fn missing_columns() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("m.parquet");
        let t = f64s(&[0., 1., 2., 3.]);
        write_columns(&p, vec![("time_s", t.clone()), ("current_a", t.clone())]);
        match err(&p) {
            TraceError::MissingChannel { channel, found, .. } => {
                assert_eq!(channel, "position_mm");
                assert!(found.contains("time_s, current_a"), "{found}");
            }
            e => panic!("{e}"),
        }
        write_columns(&p, vec![("t", t.clone()), ("position_mm", t.clone())]);
        match err(&p) {
            TraceError::BadColumn { column, .. } => assert_eq!(column, "time_s"),
            e => panic!("{e}"),
        }
        write_columns(&p, vec![("time_s", t.clone()), ("position_mm", t.clone())]);
        assert!(matches!(err(&p), TraceError::MissingChannel { channel, .. }
            if channel == "current_a or torque_nm"));
        // Asked for torque, only current present.
        write_columns(
            &p,
            vec![
                ("time_s", t.clone()),
                ("position_mm", t.clone()),
                ("current_a", t),
            ],
        );
        let opts = ReadOptions {
            effort: Some(EffortKind::TorqueNm),
            threads: 0,
        };
        assert!(matches!(
            read_trace_file(&p, &opts).unwrap_err(),
            TraceError::MissingChannel { channel, .. } if channel == "torque_nm"
        ));
    }

    #[test]
    fn string_typed_numeric_column() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("s.parquet");
        write_columns(
            &p,
            vec![
                ("time_s", f64s(&[0., 1., 2., 3.])),
                ("position_mm", strs(&["0", "1", "2", "3"])),
                ("current_a", f64s(&[0., 1., 2., 3.])),
            ],
        );
        let e = err(&p);
        assert!(e.to_string().contains("`position_mm`"), "{e}");
        assert!(matches!(e, TraceError::BadColumn { column, .. } if column == "position_mm"));
        // A numeric channel column is as wrong.
        write_columns(
            &p,
            vec![
                ("time_s", f64s(&[0., 1.])),
                ("channel", f64s(&[0., 1.])),
                ("value", f64s(&[0., 1.])),
            ],
        );
        assert!(matches!(err(&p), TraceError::BadColumn { column, .. } if column == "channel"));
    }

    #[test]
    fn nan_value_names_the_row() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("n.parquet");
        let mut cur = vec![1.0; 10];
        cur[6] = f64::NAN;
        write_columns(
            &p,
            vec![
                ("time_s", f64s(&(0..10).map(f64::from).collect::<Vec<_>>())),
                (
                    "position_mm",
                    f64s(&(0..10).map(f64::from).collect::<Vec<_>>()),
                ),
                ("current_a", f64s(&cur)),
            ],
        );
        let e = err(&p);
        assert!(e.to_string().contains("row 7"), "{e}");
        assert!(
            matches!(e, TraceError::NonFiniteInRow { row: 7, column, .. } if column == "current_a")
        );
        // An infinite time in the long layout.
        let mut time: Vec<f64> = (0..12).map(|k| k as f64 * 0.1).collect();
        time[9] = f64::INFINITY;
        write_columns(
            &p,
            vec![
                ("time_s", f64s(&time)),
                ("channel", strs(&cycle(12))),
                ("value", f64s(&[0.0; 12])),
            ],
        );
        assert!(matches!(
            err(&p),
            TraceError::NonFiniteInRow { row: 10, .. }
        ));
    }

    #[test]
    fn time_backwards_names_the_row_across_batches() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("b.parquet");
        let mut t = trace(100_000, true);
        // Row 70 001 is in the second record batch.
        t.position_m.time_s[70_000] = t.position_m.time_s[69_999];
        t.effort.time_s = t.position_m.time_s.clone();
        write_parquet(&p, &t, Layout::Wide);
        let e = err(&p);
        assert!(e.to_string().contains("row 70001"), "{e}");
        assert!(!e.to_string().contains("line"), "{e}");
        assert!(matches!(
            e,
            TraceError::TimeNotIncreasingInRow { row: 70_001, channel, .. } if channel == "position"
        ));
        // Long layout: only the channel's own previous sample counts.
        write_columns(
            &p,
            vec![
                ("time_s", f64s(&[0., 0.1, 0.2, 0.15, 0.3, 0.25, 0.4])),
                (
                    "channel",
                    strs(&[
                        "position_mm",
                        "current_a",
                        "position_mm",
                        "current_a",
                        "position_mm",
                        "position_mm",
                        "current_a",
                    ]),
                ),
                ("value", f64s(&[0.0; 7])),
            ],
        );
        assert!(matches!(
            err(&p),
            TraceError::TimeNotIncreasingInRow { row: 6, channel, .. } if channel == "position"
        ));
    }

    #[test]
    fn null_time_and_channel() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("n.parquet");
        write_columns(
            &p,
            vec![
                ("time_s", opt_f64s(&[Some(0.), Some(1.), None, Some(3.)])),
                ("position_mm", f64s(&[0., 1., 2., 3.])),
                ("current_a", f64s(&[0., 1., 2., 3.])),
            ],
        );
        assert!(
            matches!(err(&p), TraceError::BadCell { row: 3, column, .. } if column == "time_s")
        );
        let channel: ArrayRef = Arc::new(StringArray::from(vec![
            Some("position_mm"),
            None,
            Some("current_a"),
        ]));
        write_columns(
            &p,
            vec![
                ("time_s", f64s(&[0., 1., 2.])),
                ("channel", channel),
                ("value", f64s(&[0., 1., 2.])),
            ],
        );
        assert!(
            matches!(err(&p), TraceError::BadCell { row: 2, column, .. } if column == "channel")
        );
    }

    #[test]
    fn zero_rows() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("z.parquet");
        write_columns(
            &p,
            vec![
                ("time_s", f64s(&[])),
                ("position_mm", f64s(&[])),
                ("current_a", f64s(&[])),
            ],
        );
        assert!(matches!(
            err(&p),
            TraceError::TooFewSamples {
                found: 0,
                needed: 4,
                ..
            }
        ));
        write_columns(
            &p,
            vec![
                ("time_s", f64s(&[])),
                ("channel", strs(&[])),
                ("value", f64s(&[])),
            ],
        );
        assert!(matches!(err(&p), TraceError::MissingChannel { found, .. } if found == "none"));
    }

    #[test]
    fn ambiguous_effort_unless_chosen() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a.parquet");
        let v = f64s(&[0., 1., 2., 3., 4.]);
        write_columns(
            &p,
            vec![
                ("time_s", v.clone()),
                ("position_mm", v.clone()),
                ("current_a", v.clone()),
                ("torque_nm", f64s(&[9.; 5])),
            ],
        );
        assert!(matches!(err(&p), TraceError::AmbiguousEffort { .. }));
        let opts = ReadOptions {
            effort: Some(EffortKind::TorqueNm),
            threads: 0,
        };
        let (t, _) = read_trace_file(&p, &opts).unwrap();
        assert_eq!(t.effort.value, [9.; 5]);
        // Long layout with both channels present.
        let ch: Vec<&str> = (0..10)
            .map(|k| ["position_mm", "current_a", "torque_nm"][k % 3])
            .collect();
        write_columns(
            &p,
            vec![
                ("time_s", f64s(&(0..10).map(f64::from).collect::<Vec<_>>())),
                ("channel", strs(&ch)),
                ("value", f64s(&(0..10).map(f64::from).collect::<Vec<_>>())),
            ],
        );
        assert!(matches!(err(&p), TraceError::AmbiguousEffort { .. }));
    }

    #[test]
    fn too_few_samples_and_no_motion() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("f.parquet");
        let v = f64s(&[0., 1., 2.]);
        write_columns(
            &p,
            vec![
                ("time_s", v.clone()),
                ("position_mm", v.clone()),
                ("current_a", v),
            ],
        );
        assert!(matches!(
            err(&p),
            TraceError::TooFewSamples { found: 3, .. }
        ));
        let v = f64s(&[0., 1., 2., 3.]);
        write_columns(
            &p,
            vec![
                ("time_s", v.clone()),
                ("position_mm", f64s(&[5.0; 4])),
                ("current_a", v),
            ],
        );
        assert!(matches!(err(&p), TraceError::NoMotion { .. }));
    }

    #[test]
    fn glitches_are_dropped_with_their_rows_across_batches() {
        let d = tempfile::tempdir().unwrap();
        // wide: position sample k is row k + 1; 70 000 rows cross the 65 536-row batches
        let mut t = trace(70_000, true);
        t.position_m.value[68_000] = 1e308;
        t.position_m.value[10] = -1e308;
        let p = d.path().join("w.parquet");
        write_parquet(&p, &t, Layout::Wide);
        let (got, r) = read(&p).unwrap();
        assert_eq!(got.position_m.len(), 70_000 - 2);
        let rows: Vec<Option<u64>> = r.dropped_position.iter().map(|s| s.row).collect();
        assert_eq!(rows, [Some(11), Some(68_001)]);
        assert!(r.dropped_position.iter().all(|s| s.line.is_none()));
        // written and read at full precision: the same bits
        assert_eq!(
            r.dropped_position[1].position_m.to_bits(),
            1e308f64.to_bits()
        );
        // the same from memory
        let (_, r2) =
            parse_trace(&std::fs::read(&p).unwrap(), "m", &ReadOptions::default()).unwrap();
        assert_eq!(r2.dropped_position, r.dropped_position);
        assert!(r.glitch_warning().unwrap().contains("(row 11)"));
        // long, dictionary-encoded: position first at each time, so sample k is row 2k + 1
        let mut t = trace(70_000, false);
        t.position_m.value[40_000] = 1e308;
        let p = d.path().join("l.parquet");
        write_parquet(&p, &t, Layout::Long);
        let (_, r) = read(&p).unwrap();
        assert_eq!(r.dropped_position.len(), 1);
        assert_eq!(r.dropped_position[0].row, Some(80_001));
        // long, plain strings: position, current, speed in turn, position sample k is row 3k + 1
        let rows = 300;
        let mut cols = long_columns(rows, strs(&cycle(rows)));
        let mut value: Vec<f64> = (0..rows).map(|k| k as f64).collect();
        value[3 * 50] = 1e308;
        cols[2] = ("value", f64s(&value));
        let p = d.path().join("s.parquet");
        write_columns(&p, cols);
        let (_, r) = read(&p).unwrap();
        assert_eq!(r.dropped_position.len(), 1);
        assert_eq!(r.dropped_position[0].row, Some(151));
    }

    #[test]
    fn non_returning_jump_names_its_row() {
        let d = tempfile::tempdir().unwrap();
        let mut t = trace(5_000, true);
        for z in &mut t.position_m.value[3_000..] {
            *z += 1.0;
        }
        let p = d.path().join("j.parquet");
        write_parquet(&p, &t, Layout::Wide);
        match read(&p).unwrap_err() {
            e @ TraceError::PositionJump { .. } => {
                let msg = e.to_string();
                assert!(
                    msg.contains("j.parquet: row 3001: the position jumps by 999.976 mm between")
                        && msg.contains("59998560 mm/min"),
                    "{msg}"
                );
            }
            e => panic!("{e}"),
        }
    }

    #[test]
    fn bad_names_are_refused() {
        let d = tempfile::tempdir().unwrap();
        let rows = 15;
        // a column name: too long, or with a control character
        for (col, needle) in [
            ("n".repeat(65), "65 bytes"),
            ("no\u{1b}te".into(), "U+001B"),
        ] {
            let p = d.path().join("c.parquet");
            let mut cols = long_columns(rows, strs(&cycle(rows)));
            cols.pop();
            let named: Vec<(&str, ArrayRef)> = cols
                .into_iter()
                .chain([(col.as_str(), strs(&vec!["x"; rows]))])
                .collect();
            write_columns(&p, named);
            match err(&p) {
                TraceError::BadColumn { column, reason, .. } => {
                    assert!(reason.contains(needle), "{reason}");
                    assert!(!column.chars().any(char::is_control), "{column}");
                }
                e => panic!("{e}"),
            }
        }
        // a channel value, plain and dictionary-encoded: the first row that holds it
        let long = "s".repeat(1_000_000);
        for bad in ["sp\u{7}eed", long.as_str()] {
            let mut names = cycle(rows);
            names[8] = bad;
            names[11] = bad;
            let dict: DictionaryArray<Int32Type> = names.iter().copied().collect();
            for (k, channel) in [strs(&names), Arc::new(dict) as ArrayRef]
                .into_iter()
                .enumerate()
            {
                let p = d.path().join(format!("v{k}.parquet"));
                write_columns(&p, long_columns(rows, channel));
                match err(&p) {
                    TraceError::BadCell {
                        row,
                        column,
                        reason,
                        ..
                    } => {
                        assert_eq!((row, column.as_str()), (9, "channel"), "{reason}");
                        assert!(
                            reason.contains("U+0007") || reason.contains("1000000 bytes"),
                            "{reason}"
                        );
                    }
                    e => panic!("{e}"),
                }
            }
        }
    }

    /// `cols` written in row groups of `group_rows` rows.
    fn write_groups(path: &Path, cols: Vec<(&str, ArrayRef)>, group_rows: usize) {
        let batch = RecordBatch::try_from_iter(cols).unwrap();
        let props = WriterProperties::builder()
            .set_max_row_group_row_count(Some(group_rows))
            .build();
        let mut w =
            ArrowWriter::try_new(File::create(path).unwrap(), batch.schema(), Some(props)).unwrap();
        w.write(&batch).unwrap();
        w.close().unwrap();
    }

    /// Read `path` on a pool of `threads` threads.
    fn read_on(path: &Path, threads: usize) -> Result<(Trace, ReadReport), TraceError> {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| read(path))
    }

    /// Long layout with unknown channels sprinkled in, in row groups of 997 rows: read on 1, 2
    /// and 5 threads (row groups decoded apart and joined), the trace and the report are
    /// the same to the bit, and the same as the bytes read from memory.
    #[test]
    fn row_groups_decoded_in_parallel_give_the_sequential_trace() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("g.parquet");
        let rows = 20_000;
        let names = [
            "position_mm",
            "current_a",
            "position_mm",
            "current_a",
            "spindle_rpm",
        ];
        let extra = ["x1", "x2", "x3", "x4", "x5", "x6", "x7", "x8", "x9", "x10"];
        let (mut t, mut c, mut v) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..rows {
            t.push(k as f64 * 1e-3);
            // Twenty distinct unknown names, more than the report lists, spread over groups.
            c.push(if k % 97 == 0 {
                extra[(k / 97) % extra.len()]
            } else if k % 89 == 0 {
                ["y1", "y2", "y3", "y4", "y5", "y6", "y7", "y8", "y9", "y10"][(k / 89) % 10]
            } else {
                names[k % names.len()]
            });
            v.push(((k as f64) * 0.37).sin());
        }
        write_groups(
            &p,
            vec![
                ("time_s", f64s(&t)),
                ("channel", strs(&c)),
                ("value", f64s(&v)),
            ],
            997,
        );
        let meta = ParquetRecordBatchReaderBuilder::try_new(File::open(&p).unwrap()).unwrap();
        assert!(meta.metadata().num_row_groups() > 20);
        let (t1, r1) = read_on(&p, 1).unwrap();
        let bits = |c: &Channel| {
            c.time_s
                .iter()
                .chain(&c.value)
                .map(|x| x.to_bits())
                .collect::<Vec<_>>()
        };
        for threads in [2, 5] {
            let (tn, rn) = read_on(&p, threads).unwrap();
            assert_eq!(
                bits(&tn.position_m),
                bits(&t1.position_m),
                "{threads} threads"
            );
            assert_eq!(bits(&tn.effort), bits(&t1.effort), "{threads} threads");
            assert_eq!(rn.ignored_rows, r1.ignored_rows);
            assert_eq!(rn.ignored_channels, r1.ignored_channels);
            assert_eq!(rn.lines, r1.lines);
        }
        assert_eq!(r1.ignored_channels.len(), 16);
        assert_eq!(r1.lines, rows as u64);
        let bytes = std::fs::read(&p).unwrap();
        let (tb, _) = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap()
            .install(|| crate::trace::parse_trace(&bytes, "g.parquet", &ReadOptions::default()))
            .unwrap();
        assert_eq!(bits(&tb.position_m), bits(&t1.position_m));
    }

    /// Errors found in row groups decoded apart name the same row as a sequential read: a
    /// time that goes back exactly across a group boundary (caught only when the groups are
    /// joined), one inside a later group, and the first of two errors in file order.
    #[test]
    fn row_group_errors_name_the_rows_a_sequential_read_names() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("e.parquet");
        let wide = |t: &[f64], pos: &[f64]| {
            let e: Vec<f64> = pos.iter().map(|x| 0.5 + x).collect();
            vec![
                ("time_s", f64s(t)),
                ("position_mm", f64s(pos)),
                ("current_a", f64s(&e)),
            ]
        };
        let n = 5000;
        let base: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
        let pos: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
        // Row 1001 (the first of the second group) goes back to row 1000's time.
        let mut t = base.clone();
        t[1000] = t[999];
        // Row 3501 is NaN in position (inside the fourth group).
        let mut p2 = pos.clone();
        p2[3500] = f64::NAN;
        for (times, posv, want) in [
            (&t, &pos, "row 1001"),
            (&base, &p2, "row 3501"),
            (&t, &p2, "row 1001"),
        ] {
            write_groups(&p, wide(times, posv), 1000);
            for threads in [1, 2, 4] {
                let e = read_on(&p, threads).unwrap_err();
                assert!(e.to_string().contains(want), "{threads} threads: {e}");
            }
        }
    }

    /// Damaged bytes in a file of several row groups, read on 3 threads (the groups decoded
    /// apart, a decoder panic caught on each worker): an error or a trace, never a panic.
    #[test]
    fn corrupted_row_groups_decoded_in_parallel_give_errors_not_panics() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("c.parquet");
        let n = 400;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
        let e: Vec<f64> = t.iter().map(|x| 1.0 + x).collect();
        write_groups(
            &p,
            vec![
                ("time_s", f64s(&t)),
                ("position_mm", f64s(&t)),
                ("current_a", f64s(&e)),
            ],
            50,
        );
        let bytes = std::fs::read(&p).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        pool.install(|| {
            assert!(parse_trace(&bytes, "c.parquet", &ReadOptions::default()).is_ok());
            for k in (4..bytes.len()).step_by(3) {
                for pattern in [0xff, bytes[k] ^ 0x55] {
                    let mut b = bytes.clone();
                    b[k] = pattern;
                    let _ = parse_trace(&b, "c.parquet", &ReadOptions::default());
                }
            }
        });
    }
}
