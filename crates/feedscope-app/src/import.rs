//! A real controller export made a feedscope trace CSV (docs/import.md): an MTConnect SHDR log
//! with its device model, the UMich mill CSV, a SINUMERIK Operate servo trace, a TwinCAT Scope
//! export. One axis per request, in the long layout (`time_s,channel,value`) with `#` lines
//! that say where the data came from and what time 0 is.
//!
//! [`ImportRequest::run`] converts and writes the file (whole or not at all) and returns an
//! [`ImportReport`]; [`ImportSource::list`] says what a file holds, for choosing the axis.
//!
//! Both have a plain-text view shared by the front ends ([`Listing::text`], what
//! `feedscope import ... --list` prints, and [`ImportReport::text`], the summary after a
//! conversion), so that a listing reads the same from the command line, Python or a server.
use std::fmt::Write as _;
use std::path::PathBuf;

use feedscope_io::import::devices::{Category, DeviceModel};
use feedscope_io::import::shdr::{read_shdr, KeySeries, ShdrConvertParams, ShdrLog};
use feedscope_io::import::sinumerik::{
    list_sinumerik, read_sinumerik, SinumerikListing, SinumerikParams,
};
use feedscope_io::import::twincat::{list_twincat, read_twincat, TwincatListing, TwincatParams};
use feedscope_io::import::umich::{read_umich, UmichParams, UmichTable};
use feedscope_io::import::{check_informative, write_trace_csv, ChannelReport, Imported};
use serde::{Deserialize, Serialize};

use crate::output::{io_error, AtomicFile};
use crate::{AppError, FrontEnd};

/// Where the trace comes from, with the options of its format (serialised with the format as
/// its key: `{"shdr": {"log": ..., "devices": ..., "axis": "Z1", ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ImportSource {
    /// An MTConnect SHDR adapter log and its device model (Devices.xml).
    Shdr {
        /// The SHDR log.
        log: PathBuf,
        /// The device model.
        devices: PathBuf,
        /// Device of the model (name, id or uuid); default: the one whose data items match the
        /// most keys of the log.
        #[serde(default)]
        device: Option<String>,
        /// Axis: its component name, id or nativeName (required to convert).
        #[serde(default)]
        axis: Option<String>,
        /// Keys, load scale and time origin.
        #[serde(default)]
        params: ShdrConvertParams,
    },
    /// The UMich SMART CNC mill CSV (10 Hz rows, no timestamps).
    Umich {
        /// The experiment CSV.
        file: PathBuf,
        /// Axis `X`, `Y` or `Z` (required to convert).
        #[serde(default)]
        axis: Option<String>,
        /// Row rate and current column.
        #[serde(default)]
        params: UmichParams,
    },
    /// A SINUMERIK Operate servo trace (XML).
    Sinumerik {
        /// The trace file.
        file: PathBuf,
        /// Axis, signals and units.
        #[serde(default)]
        params: SinumerikParams,
    },
    /// A TwinCAT 3 Scope export (CSV or TXT).
    Twincat {
        /// The export.
        file: PathBuf,
        /// Channels and units.
        #[serde(default)]
        params: TwincatParams,
    },
}

/// What a file holds, as [`ImportSource::list`] read it.
#[derive(Debug)]
pub enum Listing {
    /// The log's devices, axes and data items with their counts and spans.
    Shdr {
        /// The log.
        log: ShdrLog,
        /// Its device model.
        model: DeviceModel,
    },
    /// The table's axes and columns.
    Umich {
        /// The table.
        table: UmichTable,
        /// The row rate the spans are given at (Hz).
        rate_hz: f64,
    },
    /// The trace's frames, axes and signals.
    Sinumerik(SinumerikListing),
    /// The export's channels.
    Twincat(TwincatListing),
}

impl ImportSource {
    /// The options that do not need a file read, naming the field.
    ///
    /// # Errors
    /// An invalid-parameter error: a load scale (`torque_per_load_nm`) or a row rate
    /// (`rate_hz`) that is not a positive finite number.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        match self {
            ImportSource::Shdr { params, .. } => {
                if let Some(x) = params.torque_per_load_nm {
                    if !(x.is_finite() && x > 0.0) {
                        return Err(AppError::invalid(
                            "torque_per_load_nm",
                            format!(
                                "{} {x} must be a positive torque",
                                front.name("torque_per_load_nm")
                            ),
                        ));
                    }
                }
            }
            ImportSource::Umich { params, .. } => {
                if !(params.rate_hz.is_finite() && params.rate_hz > 0.0) {
                    return Err(AppError::invalid(
                        "rate_hz",
                        format!(
                            "{} {} must be a positive rate",
                            front.name("rate_hz"),
                            params.rate_hz
                        ),
                    ));
                }
            }
            ImportSource::Sinumerik { .. } | ImportSource::Twincat { .. } => {}
        }
        Ok(())
    }

    /// What the file holds (axes, data items or signals, counts, spans).
    ///
    /// # Errors
    /// As [`validate`](Self::validate); the file's errors, with its line.
    pub fn list(&self, front: &dyn FrontEnd) -> Result<Listing, AppError> {
        self.validate(front)?;
        let e = AppError::from_error;
        Ok(match self {
            ImportSource::Shdr {
                log,
                devices,
                device,
                ..
            } => {
                let model = DeviceModel::read(devices).map_err(e)?;
                let log = read_shdr(log, &model, device.as_deref()).map_err(e)?;
                Listing::Shdr { log, model }
            }
            ImportSource::Umich { file, params, .. } => Listing::Umich {
                table: read_umich(file).map_err(e)?,
                rate_hz: params.rate_hz,
            },
            ImportSource::Sinumerik { file, .. } => {
                Listing::Sinumerik(list_sinumerik(file).map_err(e)?)
            }
            ImportSource::Twincat { file, .. } => Listing::Twincat(list_twincat(file).map_err(e)?),
        })
    }

    /// The converted trace with its report, and notes of the format (TwinCAT's header).
    fn convert(&self, front: &dyn FrontEnd) -> Result<(Imported, Vec<String>), AppError> {
        self.validate(front)?;
        let e = AppError::from_error;
        let axis_needed = |axis: &Option<String>| {
            axis.clone().ok_or_else(|| {
                AppError::invalid(
                    "axis",
                    format!(
                        "{} is required to convert (list the file to see its axes)",
                        front.name("axis")
                    ),
                )
            })
        };
        Ok(match self {
            ImportSource::Shdr {
                log,
                devices,
                device,
                axis,
                params,
            } => {
                let axis = axis_needed(axis)?;
                let model = DeviceModel::read(devices).map_err(e)?;
                let log = read_shdr(log, &model, device.as_deref()).map_err(e)?;
                (log.to_trace(&model, &axis, params).map_err(e)?, vec![])
            }
            ImportSource::Umich { file, axis, params } => {
                let axis = axis_needed(axis)?;
                let table = read_umich(file).map_err(e)?;
                (table.to_trace(&axis, params).map_err(e)?, vec![])
            }
            ImportSource::Sinumerik { file, params } => {
                (read_sinumerik(file, params).map_err(e)?.imported, vec![])
            }
            ImportSource::Twincat { file, params } => {
                let imp = read_twincat(file, params).map_err(e)?;
                (imp.imported, imp.listing.header.notes)
            }
        })
    }
}

/// Convert one axis of a controller export into a trace CSV.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImportRequest {
    /// The export and its format's options.
    pub source: ImportSource,
    /// The trace CSV to write (whole or not at all).
    pub output: PathBuf,
    /// Write the trace even when its effort is constant (zero in every row: a control that
    /// does not report the axis's current) or its position never moves.
    #[serde(default)]
    pub keep_empty_channels: bool,
}

/// What an import wrote (`feedscope import` prints it; a server returns it).
#[derive(Debug, Clone, Serialize)]
pub struct ImportReport {
    /// The trace CSV written.
    pub output: PathBuf,
    /// Its effort column (`current_a` or `torque_nm`).
    pub effort_column: &'static str,
    /// Sources, counts, time zero and the warnings (each with its code).
    pub import: feedscope_io::import::ImportReport,
    /// What the format's header says that a user should know (TwinCAT).
    pub notes: Vec<String>,
}

impl ImportRequest {
    /// Read, convert, check and write.
    ///
    /// # Errors
    /// As [`ImportSource::validate`]; the file's errors (with its line; an unknown axis or
    /// channel listing those that exist); a channel without information unless
    /// `keep_empty_channels`; I/O errors writing `output` (nothing is left there).
    pub fn run(&self, front: &dyn FrontEnd) -> Result<ImportReport, AppError> {
        let (imported, notes) = self.source.convert(front)?;
        if !self.keep_empty_channels {
            check_informative(&imported).map_err(AppError::from_error)?;
        }
        let mut f = AtomicFile::create(&self.output)?;
        write_trace_csv(&imported, &mut *f.writer())
            .map_err(|e| io_error(format!("writing {}", self.output.display()), e))?;
        f.commit()?;
        Ok(ImportReport {
            output: self.output.clone(),
            effort_column: imported.trace.effort_kind.column(),
            import: imported.report,
            notes,
        })
    }
}

impl ImportReport {
    /// What was written, in plain text: the file and its columns, each channel's samples,
    /// span, median interval and source (with its repeated, unavailable and reordered samples
    /// when there are any), how the effort was obtained and what time 0 is. What
    /// `feedscope import` prints on stdout; notes and warnings are not part of it.
    pub fn text(&self) -> String {
        let r = &self.import;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "wrote {} (long layout: position_mm, {})",
            self.output.display(),
            self.effort_column
        );
        channel_line(&mut s, "position_mm", &r.position);
        channel_line(&mut s, self.effort_column, &r.effort);
        let _ = writeln!(s, "  effort: {}", r.effort_rule);
        match &r.time_zero {
            Some(t) => {
                let _ = writeln!(s, "  time zero: {t} ({})", r.time_zero_rule);
            }
            None => {
                let _ = writeln!(s, "  time zero: {}", r.time_zero_rule);
            }
        }
        s
    }
}

/// One converted channel of [`ImportReport::text`]: a line, and a second one for the samples
/// the conversion had to repair.
fn channel_line(s: &mut String, column: &str, c: &ChannelReport) {
    let _ = writeln!(
        s,
        "  {column:<12} {:>7} samples  {:.3} to {:.3} s  median interval {:.3} s  from {}",
        c.samples, c.span_s.0, c.span_s.1, c.median_interval_s, c.source_key
    );
    if c.repeated_times + c.unavailable + c.reordered > 0 {
        let _ = writeln!(
            s,
            "  {:<12} {} repeated timestamps (last value kept), {} UNAVAILABLE (gaps), {} \
             reordered",
            "", c.repeated_times, c.unavailable, c.reordered
        );
    }
}

impl Listing {
    /// What the file holds, in plain text, one format's view each: for an SHDR log its
    /// recordings, device, axes and data items with observation counts and spans (seconds
    /// from the log's first data line); for the UMich CSV its axes with the range of each
    /// column; for a SINUMERIK trace its frames, axes (with the signals converted by default)
    /// and signals with written, restored and invalid counts; for a TwinCAT export its
    /// channels with units, sample times, counts, spans and ranges, and which options to set
    /// when no channel is the default (named as `front` spells them). What
    /// `feedscope import ... --list` prints.
    pub fn text(&self, front: &dyn FrontEnd) -> String {
        match self {
            Listing::Shdr { log, model } => shdr_text(log, model),
            Listing::Umich { table, rate_hz } => umich_text(table, *rate_hz),
            Listing::Sinumerik(l) => sinumerik_text(l),
            Listing::Twincat(l) => twincat_text(l, front),
        }
    }
}

/// Seconds of a key's first and last observation from the log's first line.
fn key_span(log: &ShdrLog, s: &KeySeries) -> String {
    match (s.first, s.last) {
        (Some(a), Some(b)) => format!(
            "{:.3} to {:.3} s",
            a.seconds_since(&log.first_line_time),
            b.seconds_since(&log.first_line_time)
        ),
        _ => "-".into(),
    }
}

fn shdr_text(log: &ShdrLog, model: &DeviceModel) -> String {
    let dev = log.device(model);
    let mut s = String::new();
    let last = log.series.values().filter_map(|k| k.last).max();
    let _ = writeln!(
        s,
        "SHDR log {}: {} data lines, {} asset lines skipped, line endings {}",
        log.source_name,
        log.data_lines,
        log.asset_lines,
        log.endings.describe()
    );
    let _ = writeln!(
        s,
        "time zero {} (first data line); last observation at {}",
        log.first_line_time,
        last.map_or("-".into(), |t| format!(
            "{:.3} s",
            t.seconds_since(&log.first_line_time)
        ))
    );
    let _ = writeln!(
        s,
        "recordings (stretches running forward in time): {}",
        log.segments.len()
    );
    for g in &log.segments {
        let _ = writeln!(
            s,
            "  from line {:>6}: {} to {} ({:.3} to {:.3} s, {} data lines)",
            g.first_line,
            g.start,
            g.end,
            g.start.seconds_since(&log.first_line_time),
            g.end.seconds_since(&log.first_line_time),
            g.lines
        );
    }
    let _ = writeln!(
        s,
        "device {} (id {}): {}",
        dev.label(),
        dev.id,
        log.device_rule
    );
    let row = |s: &mut String, k: usize| {
        let it = &dev.items[k];
        let (n, u, sp) = match log.series.get(it.key()) {
            Some(ks) => (ks.observations, ks.unavailable, key_span(log, ks)),
            None => (0, 0, "-".into()),
        };
        let _ = writeln!(
            s,
            "    {:<16} {:<9} {:<28} {:<17} {:<8} {:>6} obs {:>5} unavail  {}",
            it.key(),
            match it.category {
                Category::Sample => "SAMPLE",
                Category::Event => "EVENT",
                Category::Condition => "CONDITION",
            },
            it.type_label(),
            it.units.as_deref().unwrap_or("-"),
            it.coordinate_system.as_deref().unwrap_or("-"),
            n,
            u,
            sp
        );
    };
    let _ = writeln!(s, "axes ({}):", dev.axes.len());
    for ax in &dev.axes {
        let _ = writeln!(s, "  {} ({}, id {})", ax.label(), ax.kind, ax.id);
        for &k in &ax.items {
            row(&mut s, k);
        }
    }
    // Other items only when observed: a device model declares many items a log never sends.
    let others: Vec<usize> = (0..dev.items.len())
        .filter(|&k| dev.items[k].axis.is_none() && log.series.contains_key(dev.items[k].key()))
        .collect();
    let _ = writeln!(s, "other data items observed ({}):", others.len());
    for k in others {
        row(&mut s, k);
    }
    if log.unknown_keys.is_empty() {
        let _ = writeln!(s, "keys not in the device model: none");
    } else {
        let _ = writeln!(
            s,
            "keys not in the device model: {}",
            log.unknown_keys
                .iter()
                .map(|(k, n)| format!("{k} ({n})"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if log.other_device_observations > 0 {
        let _ = writeln!(
            s,
            "observations of other devices skipped: {}",
            log.other_device_observations
        );
    }
    s
}

/// The UMich table at `rate_hz` rows per second (the files have no timestamps).
fn umich_text(t: &UmichTable, rate_hz: f64) -> String {
    let mut s = String::new();
    let n = t.rows.len();
    let _ = writeln!(
        s,
        "UMich CSV {}: {} columns, {n} rows, line endings {}; at {rate_hz} Hz: 0.000 to {:.3} s",
        t.source_name,
        t.columns.len(),
        t.endings.describe(),
        n.saturating_sub(1) as f64 / rate_hz
    );
    let range = |col: &str| -> String {
        let Some(c) = t.columns.iter().position(|x| x == col) else {
            return "absent".into();
        };
        match t.numbers(c) {
            Ok(v) if v.is_empty() => "no rows".into(),
            Ok(v) => {
                let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                format!("{lo} to {hi}")
            }
            Err(e) => format!("unreadable ({e})"),
        }
    };
    let _ = writeln!(s, "axes ({}):", t.axes().len());
    for a in t.axes() {
        let _ = writeln!(s, "  {a}: {n} samples");
        for (suffix, unit) in [
            ("ActualPosition", "mm"),
            ("CurrentFeedback", "A"),
            ("OutputCurrent", "A"),
        ] {
            let col = format!("{a}_{suffix}");
            let _ = writeln!(s, "    {col:<20} {} {unit}", range(&col));
        }
    }
    s
}

/// `a to b` with up to 6 significant figures, `-` when absent.
fn range_text(r: Option<(f64, f64)>) -> String {
    match r {
        Some((a, b)) => format!("{} to {}", sig(a), sig(b)),
        None => "-".into(),
    }
}

/// A number with 6 significant figures, trailing zeros trimmed.
fn sig(x: f64) -> String {
    let s = format!(
        "{x:.*}",
        (5 - x.abs().max(1e-300).log10().floor() as i32).clamp(0, 9) as usize
    );
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// `a to b s` with millisecond decimals, `no sample` when absent.
fn span_text(s: Option<(f64, f64)>) -> String {
    match s {
        Some((a, b)) => format!("{a:.3} to {b:.3} s"),
        None => "no sample".into(),
    }
}

fn sinumerik_text(l: &SinumerikListing) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "SINUMERIK trace {}: version {}, session {}, {} data frame(s)",
        l.source_name,
        l.version.as_deref().unwrap_or("-"),
        l.session_name
            .as_deref()
            .map_or("-".to_string(), |n| format!("`{n}`")),
        l.frames.len()
    );
    for (k, f) in l.frames.iter().enumerate() {
        let _ = writeln!(
            s,
            "frame {}: start {}, {} records, {} (stopInc {}), drop-outs {}",
            k + 1,
            f.start.map_or("-".to_string(), |t| t.to_string()),
            f.records,
            span_text(f.span_s),
            f.stop_inc_s
                .map_or("-".to_string(), |x| format!("{x:.3} s")),
            f.drop_outs.map_or("-".to_string(), |x| x.to_string())
        );
        // The signals grouped by axis, in the frame's axis order; those without one last.
        let axes = f.axes();
        let mut groups: Vec<(Option<String>, Vec<usize>)> = axes
            .iter()
            .map(|(a, _)| {
                (
                    Some(a.clone()),
                    (0..f.signals.len())
                        .filter(|&i| f.signals[i].axis() == Some(a.as_str()))
                        .collect(),
                )
            })
            .collect();
        let loose: Vec<usize> = (0..f.signals.len())
            .filter(|&i| f.signals[i].axis().is_none())
            .collect();
        if !loose.is_empty() {
            groups.push((None, loose));
        }
        let _ = writeln!(s, "  axes ({}):", axes.len());
        for (axis, idx) in groups {
            let (dp, de) = f.default_signals(axis.as_deref());
            let name = |i: Option<usize>| i.map_or("none".to_string(), |i| f.signals[i].id.clone());
            match &axis {
                Some(a) => {
                    let _ = writeln!(
                        s,
                        "  axis {a}: position {}, effort {} (by default)",
                        name(dp),
                        name(de)
                    );
                }
                None => {
                    let _ = writeln!(s, "  signals without an axis:");
                }
            }
            for i in idx {
                let d = &f.signals[i];
                let st = &f.stats[i];
                let _ = writeln!(
                    s,
                    "    {:<4} {:<8} {}  \"{}\"",
                    d.id,
                    d.units_type.as_deref().unwrap_or("-"),
                    d.name,
                    d.description
                );
                let _ = writeln!(
                    s,
                    "         every {}, {} declared: {} written + {} restored, {} invalid = {} \
                     samples, {}, values {}",
                    d.interval_s.map_or("-".to_string(), |x| format!("{x} s")),
                    d.datapoint_count.map_or("-".to_string(), |x| x.to_string()),
                    st.written,
                    st.restored,
                    st.invalid,
                    st.samples(),
                    span_text(st.span_s),
                    range_text(st.range)
                );
            }
        }
    }
    s
}

fn twincat_text(l: &TwincatListing, front: &dyn FrontEnd) -> String {
    let h = &l.header;
    let mut s = String::new();
    let _ =
        writeln!(
        s,
        "TwinCAT Scope export {}: scope {}, separator {}, decimal mark {}, {} time columns, {} \
         data rows{}",
        h.source_name,
        h.scope_name
            .as_deref()
            .map_or("-".to_string(), |n| format!("`{n}`")),
        h.separator_name(),
        l.decimal.map_or("-".to_string(), |c| format!("'{c}'")),
        if h.shared_time() { "shared" } else { "separate" },
        l.rows,
        if l.eof_marker { ", EOF line" } else { "" }
    );
    let _ = writeln!(
        s,
        "start {}, end {} (Starttime/Endtime of export, FILETIME)",
        h.start.map_or("-".to_string(), |t| t.to_string()),
        h.end.map_or("-".to_string(), |t| t.to_string())
    );
    let (dp, de) = h.default_channels();
    let _ = writeln!(s, "channels ({}):", h.channels.len());
    for (k, c) in h.channels.iter().enumerate() {
        let n = &l.counts[k];
        let role = if dp == Some(k) {
            "  <- position (by default)"
        } else if de == Some(k) {
            "  <- effort (by default)"
        } else {
            ""
        };
        let _ = writeln!(s, "  {}{role}", c.name);
        let _ = writeln!(
            s,
            "    unit {}, sample time {} ms, {} samples, {}, values {}",
            c.get("Unit").unwrap_or("-"),
            c.sample_time_ms().map_or("-".to_string(), sig),
            n.samples,
            span_text(n.span_s),
            range_text(n.range)
        );
        let mut extra = Vec::new();
        if let Some(sym) = c.get("SymbolName").filter(|x| *x != c.name) {
            extra.push(format!("symbol {sym}"));
        }
        if let Some(t) = c.get("Data-Type") {
            extra.push(t.to_string());
        }
        if let Some(sc) = c.scaling() {
            extra.push(format!("scaled on export: {sc}"));
        }
        if !extra.is_empty() {
            let _ = writeln!(s, "    {}", extra.join(", "));
        }
    }
    if dp.is_none() || de.is_none() {
        let _ = writeln!(
            s,
            "no default {}: name the channel(s) with {} / {}",
            match (dp, de) {
                (None, None) => "position or effort",
                (None, _) => "position",
                _ => "effort",
            },
            front.name("position"),
            front.name("effort")
        );
    }
    for n in &h.notes {
        let _ = writeln!(s, "note: {n}");
    }
    s
}
