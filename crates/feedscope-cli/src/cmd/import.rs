//! `feedscope import`: real controller exports (MTConnect SHDR logs, UMich mill CSV,
//! SINUMERIK Operate servo traces, TwinCAT Scope exports) into feedscope trace CSV.
use crate::output::out;
use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Result;
use clap::ValueEnum;
use feedscope_app::import::{ImportReport, ImportRequest, ImportSource, Listing};
use feedscope_io::import::devices::{Category, DeviceModel};
use feedscope_io::import::shdr::{ShdrConvertParams, ShdrLog, TimeOrigin};
use feedscope_io::import::sinumerik::{SinumerikListing, SinumerikParams};
use feedscope_io::import::twincat::{TwincatListing, TwincatParams};
use feedscope_io::import::umich::{CurrentColumn, UmichParams, UmichTable};
use feedscope_io::import::units::{EffortUnit, PositionUnit};
use feedscope_io::import::ChannelReport;

use crate::front::Cli;

/// Convert a real controller export into a feedscope trace CSV.
///
/// Four sources: `shdr`, an MTConnect adapter log with its device model (Devices.xml);
/// `umich`, the UMich SMART CNC mill CSV; `sinumerik`, a SINUMERIK Operate servo trace (XML);
/// `twincat`, a TwinCAT 3 Scope CSV export. One axis is converted per run into the long layout
/// (`time_s,channel,value`) with `#` comment lines on top saying where the data came from and
/// what time 0 is. `--list` prints the axes and data items found, with sample counts and time
/// spans, instead of converting. The output file is written only when the whole conversion
/// succeeded. See docs/import.md.
///
/// Exit codes: 0 success; 2 bad input (unreadable or malformed file, with its line; unknown
/// axis or channel, listing those that exist; missing columns; a load without
/// --torque-per-load-nm; bad options).
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub source: Source,
}

#[derive(Debug, clap::Subcommand)]
pub enum Source {
    /// MTConnect SHDR adapter log (`timestamp|key|value|…`) with its Devices.xml.
    ///
    /// Position is the axis's POSITION ACTUAL sample (machine coordinates when there are
    /// several), effort its LOAD sample in percent, turned into torque with
    /// --torque-per-load-nm. Times are seconds from the first data line of the log (or from
    /// the trace's first sample with --time-origin trace); the absolute time 0 is written in a
    /// `#` line. Samples stay where the log has them: no forward fill of the change-only values.
    Shdr(ShdrArgs),
    /// UMich SMART CNC mill CSV (Kaggle "CNC Mill Tool Wear"): 10 Hz rows, no timestamps.
    ///
    /// Position `A_ActualPosition` (mm) and current `A_CurrentFeedback` (A) of axis A; row k
    /// is at k / --rate-hz seconds. Lines may end in LF, CRLF or a bare CR.
    Umich(UmichArgs),
    /// SINUMERIK Operate servo trace (XML, saved from Diagnostics > Trace).
    ///
    /// Position is the axis's actual position (measuring system 1 first: measPos1,
    /// nckServoDataActPos1stEnc…), effort its actual current i(q) (nckServoDataActCurr…, A) or
    /// else a torque signal (N·m). The axis is the number in the signals' brackets (7 for
    /// `[u1, 7]`); with several axes recorded, --axis is required. Units come from the
    /// description or the flags, else from unitsType (posn: mm, current: A). Values the control
    /// left out because they repeat (change-only records) are put back on the signal's
    /// interval, up to its datapointCount; values ≥ 9.2e18 (the control's invalid mark) are
    /// dropped and counted. Times are seconds from the frame's startTime, written in a `#` line.
    Sinumerik(SinumerikArgs),
    /// TwinCAT 3 Scope export (CSV or TXT, Scope View > Export).
    ///
    /// The separator (tab, space, colon, semicolon, comma) is read from the first line, the
    /// decimal mark from the data. Position and effort are the only channels with a length
    /// unit and with a current or torque unit (or named …ActPos… and …Torque…/…Current…), or
    /// --position and --effort. Values are taken as exported (TwinCAT applies ScaleFactor and
    /// Offset when it exports). Times are the time column (ms) / 1000 from the start of the
    /// export, whose FILETIME is written in a `#` line.
    Twincat(TwincatArgs),
}

#[derive(Debug, clap::Args)]
pub struct ShdrArgs {
    /// The SHDR log.
    pub log: PathBuf,
    /// The MTConnect device model (Devices.xml).
    #[arg(long)]
    pub devices: PathBuf,
    /// Device of the model (name, id or uuid) [default: the one whose data items match the
    /// most keys of the log].
    #[arg(long)]
    pub device: Option<String>,
    /// Axis to convert: its component name, id or nativeName in Devices.xml, e.g. `Z1`.
    #[arg(long, required_unless_present = "list")]
    pub axis: Option<String>,
    /// Motor torque at 100 % load (N·m), e.g. the motor's rated torque. Required to convert:
    /// SHDR load is a percentage and feedscope will not guess a drive's rating.
    #[arg(long)]
    pub torque_per_load_nm: Option<f64>,
    /// Position data item key [default: the axis's POSITION ACTUAL, machine coordinates].
    #[arg(long)]
    pub position_key: Option<String>,
    /// Load data item key [default: the axis's LOAD].
    #[arg(long)]
    pub load_key: Option<String>,
    /// Time 0 of the trace.
    #[arg(long, value_enum, default_value_t = OriginArg::File)]
    pub time_origin: OriginArg,
    /// Output trace CSV.
    #[arg(short, long, required_unless_present = "list")]
    pub output: Option<PathBuf>,
    /// List the axes and data items of the log instead of converting.
    #[arg(long, conflicts_with = "output")]
    pub list: bool,
    /// Write the trace even when its effort is constant (e.g. zero in every row) or its
    /// position never moves; without it that is an error (exit 2).
    #[arg(long)]
    pub keep_empty_channels: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum OriginArg {
    /// The first data line of the log (shared by every axis of the log).
    File,
    /// The first sample of the converted axis (logs that open with an old state dump).
    Trace,
}

#[derive(Debug, clap::Args)]
pub struct UmichArgs {
    /// The experiment CSV.
    pub file: PathBuf,
    /// Axis: `X`, `Y` or `Z` (or `X1`…).
    #[arg(long, required_unless_present = "list")]
    pub axis: Option<String>,
    /// Row rate (Hz): the files have no timestamps, row k is at k / rate.
    #[arg(long, default_value_t = 10.0)]
    pub rate_hz: f64,
    /// Current column: `feedback` (A_CurrentFeedback, the torque current) or `output`
    /// (A_OutputCurrent, near 328 A at all times in these files).
    #[arg(long, value_enum, default_value_t = CurrentArg::Feedback)]
    pub current: CurrentArg,
    /// Output trace CSV.
    #[arg(short, long, required_unless_present = "list")]
    pub output: Option<PathBuf>,
    /// List the axes and columns instead of converting.
    #[arg(long, conflicts_with = "output")]
    pub list: bool,
    /// Write the trace even when its current is constant (e.g. zero in every row) or its
    /// position never moves; without it that is an error (exit 2).
    #[arg(long)]
    pub keep_empty_channels: bool,
}

#[derive(Debug, clap::Args)]
pub struct SinumerikArgs {
    /// The trace file (XML).
    pub file: PathBuf,
    /// Machine axis number in the signals' brackets (`7` for `[u1, 7]`, or `u1,7`); required
    /// when the trace records several axes.
    #[arg(long)]
    pub axis: Option<String>,
    /// Position signal: its id (`f8`), key (`s12`), NCK path or variable name (`measPos2`)
    /// [default: the axis's actual position, measuring system 1 first].
    #[arg(long)]
    pub position_signal: Option<String>,
    /// Effort signal, named the same way [default: the axis's actual current, else a torque].
    #[arg(long)]
    pub effort_signal: Option<String>,
    /// Unit of the position values [default: from the description, else mm for unitsType
    /// posn; an inch machine needs `inch`].
    #[arg(long, value_enum)]
    pub position_unit: Option<PositionUnitArg>,
    /// Unit of the effort values [default: from the description, else A for unitsType current,
    /// N·m for a torque].
    #[arg(long, value_enum)]
    pub effort_unit: Option<EffortUnitArg>,
    /// Output trace CSV.
    #[arg(short, long, required_unless_present = "list")]
    pub output: Option<PathBuf>,
    /// List the frames, axes and signals (with counts of written, restored and invalid values
    /// and time spans) instead of converting.
    #[arg(long, conflicts_with = "output")]
    pub list: bool,
    /// Write the trace even when its effort is constant or its position never moves; without
    /// it that is an error (exit 2).
    #[arg(long)]
    pub keep_empty_channels: bool,
}

#[derive(Debug, clap::Args)]
pub struct TwincatArgs {
    /// The Scope export (CSV or TXT).
    pub file: PathBuf,
    /// Position channel: its Name or SymbolName [default: the only channel with a length unit,
    /// or named …ActPos…].
    #[arg(long)]
    pub position: Option<String>,
    /// Effort channel [default: the only channel with a current or torque unit, or named
    /// …Torque… or …Current…].
    #[arg(long)]
    pub effort: Option<String>,
    /// Unit of the position values [default: the channel's Unit row].
    #[arg(long, value_enum)]
    pub position_unit: Option<PositionUnitArg>,
    /// Unit of the effort values [default: the channel's Unit row].
    #[arg(long, value_enum)]
    pub effort_unit: Option<EffortUnitArg>,
    /// Output trace CSV.
    #[arg(short, long, required_unless_present = "list")]
    pub output: Option<PathBuf>,
    /// List the channels (units, sample times, sample counts, time spans, ranges) instead of
    /// converting.
    #[arg(long, conflicts_with = "output")]
    pub list: bool,
    /// Write the trace even when its effort is constant or its position never moves; without
    /// it that is an error (exit 2).
    #[arg(long)]
    pub keep_empty_channels: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum PositionUnitArg {
    /// Millimetre.
    Mm,
    /// Micrometre.
    Um,
    /// Metre.
    M,
    /// Inch.
    Inch,
}

impl From<PositionUnitArg> for PositionUnit {
    fn from(a: PositionUnitArg) -> Self {
        match a {
            PositionUnitArg::Mm => Self::Millimetre,
            PositionUnitArg::Um => Self::Micrometre,
            PositionUnitArg::M => Self::Metre,
            PositionUnitArg::Inch => Self::Inch,
        }
    }
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum EffortUnitArg {
    /// Ampere (current_a).
    A,
    /// Milliampere (current_a).
    Ma,
    /// Newton-metre (torque_nm).
    Nm,
}

impl From<EffortUnitArg> for EffortUnit {
    fn from(a: EffortUnitArg) -> Self {
        match a {
            EffortUnitArg::A => Self::Ampere,
            EffortUnitArg::Ma => Self::Milliampere,
            EffortUnitArg::Nm => Self::NewtonMetre,
        }
    }
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum CurrentArg {
    /// A_CurrentFeedback.
    Feedback,
    /// A_OutputCurrent.
    Output,
}

pub fn run(args: Args) -> Result<()> {
    let front = Cli::default();
    let (source, output, list, keep_empty_channels) = match args.source {
        Source::Shdr(a) => (
            ImportSource::Shdr {
                log: a.log,
                devices: a.devices,
                device: a.device,
                axis: a.axis,
                params: ShdrConvertParams {
                    position_key: a.position_key,
                    load_key: a.load_key,
                    torque_per_load_nm: a.torque_per_load_nm,
                    time_origin: match a.time_origin {
                        OriginArg::File => TimeOrigin::FirstLine,
                        OriginArg::Trace => TimeOrigin::FirstSample,
                    },
                },
            },
            a.output,
            a.list,
            a.keep_empty_channels,
        ),
        Source::Umich(a) => (
            ImportSource::Umich {
                file: a.file,
                axis: a.axis,
                params: UmichParams {
                    rate_hz: a.rate_hz,
                    current: match a.current {
                        CurrentArg::Feedback => CurrentColumn::Feedback,
                        CurrentArg::Output => CurrentColumn::Output,
                    },
                },
            },
            a.output,
            a.list,
            a.keep_empty_channels,
        ),
        Source::Sinumerik(a) => (
            ImportSource::Sinumerik {
                file: a.file,
                params: SinumerikParams {
                    axis: a.axis,
                    position_signal: a.position_signal,
                    effort_signal: a.effort_signal,
                    position_unit: a.position_unit.map(Into::into),
                    effort_unit: a.effort_unit.map(Into::into),
                },
            },
            a.output,
            a.list,
            a.keep_empty_channels,
        ),
        Source::Twincat(a) => (
            ImportSource::Twincat {
                file: a.file,
                params: TwincatParams {
                    position: a.position,
                    effort: a.effort,
                    position_unit: a.position_unit.map(Into::into),
                    effort_unit: a.effort_unit.map(Into::into),
                },
            },
            a.output,
            a.list,
            a.keep_empty_channels,
        ),
    };
    if list {
        let text = match source.list(&front)? {
            Listing::Shdr { log, model } => list_shdr(&log, &model),
            Listing::Umich { table, rate_hz } => list_umich(&table, rate_hz),
            Listing::Sinumerik(l) => list_sinumerik_text(&l),
            Listing::Twincat(l) => list_twincat_text(&l),
        };
        out!("{text}");
        return Ok(());
    }
    let request = ImportRequest {
        source,
        output: output.expect("clap requires --output without --list"),
        keep_empty_channels,
    };
    let done = request.run(&front)?;
    out!("{}", summary(&done));
    for n in &done.notes {
        eprintln!("note: {n}");
    }
    for w in &done.import.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}

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

fn summary(done: &ImportReport) -> String {
    let r = &done.import;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "wrote {} (long layout: position_mm, {})",
        done.output.display(),
        done.effort_column
    );
    channel_line(&mut s, "position_mm", &r.position);
    channel_line(&mut s, done.effort_column, &r.effort);
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

/// Seconds of a key's first and last observation from the log's first line.
fn span(log: &ShdrLog, s: &feedscope_io::import::shdr::KeySeries) -> String {
    match (s.first, s.last) {
        (Some(a), Some(b)) => format!(
            "{:.3} to {:.3} s",
            a.seconds_since(&log.first_line_time),
            b.seconds_since(&log.first_line_time)
        ),
        _ => "-".into(),
    }
}

fn list_shdr(log: &ShdrLog, model: &DeviceModel) -> String {
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
            Some(ks) => (ks.observations, ks.unavailable, span(log, ks)),
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

fn list_umich(t: &UmichTable, rate_hz: f64) -> String {
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

fn span_text(s: Option<(f64, f64)>) -> String {
    match s {
        Some((a, b)) => format!("{a:.3} to {b:.3} s"),
        None => "no sample".into(),
    }
}

fn list_sinumerik_text(l: &SinumerikListing) -> String {
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

fn list_twincat_text(l: &TwincatListing) -> String {
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
            "no default {}: name the channel(s) with --position / --effort",
            match (dp, de) {
                (None, None) => "position or effort",
                (None, _) => "position",
                _ => "effort",
            }
        );
    }
    for n in &h.notes {
        let _ = writeln!(s, "note: {n}");
    }
    s
}
