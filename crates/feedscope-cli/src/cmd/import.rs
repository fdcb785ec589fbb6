//! `feedscope import`: real controller exports (MTConnect SHDR logs, UMich mill CSV) into
//! feedscope trace CSV.
use crate::output::out;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::ValueEnum;
use feedscope_io::import::devices::{Category, DeviceModel};
use feedscope_io::import::shdr::{read_shdr, ShdrConvertParams, ShdrLog, TimeOrigin};
use feedscope_io::import::umich::{read_umich, CurrentColumn, UmichParams, UmichTable};
use feedscope_io::import::{check_informative, write_trace_csv, ChannelReport, Imported};

use super::BadInput;
use crate::output::AtomicFile;

/// Convert a real controller export into a feedscope trace CSV.
///
/// Two sources: `shdr`, an MTConnect adapter log with its device model (Devices.xml), and
/// `umich`, the UMich SMART CNC mill CSV. One axis is converted per run into the long layout
/// (`time_s,channel,value`) with `#` comment lines on top saying where the data came from and
/// what time 0 is. `--list` prints the axes and data items found, with sample counts and time
/// spans, instead of converting. The output file is written only when the whole conversion
/// succeeded. See docs/import.md.
///
/// Exit codes: 0 success; 2 bad input (unreadable or malformed file, with its line; unknown
/// axis, listing the axes; missing columns; a load without --torque-per-load-nm; bad options).
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

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum CurrentArg {
    /// A_CurrentFeedback.
    Feedback,
    /// A_OutputCurrent.
    Output,
}

pub fn run(args: Args) -> Result<()> {
    match args.source {
        Source::Shdr(a) => run_shdr(a),
        Source::Umich(a) => run_umich(a),
    }
}

fn run_shdr(a: ShdrArgs) -> Result<()> {
    // Options first, before any file is read.
    if let Some(x) = a.torque_per_load_nm {
        if !(x.is_finite() && x > 0.0) {
            return Err(BadInput(format!(
                "--torque-per-load-nm {x} must be a positive torque"
            ))
            .into());
        }
    }
    let model = DeviceModel::read(&a.devices)?;
    let log = read_shdr(&a.log, &model, a.device.as_deref())?;
    if a.list {
        out!("{}", list_shdr(&log, &model));
        return Ok(());
    }
    let axis = a
        .axis
        .as_deref()
        .expect("clap requires --axis without --list");
    let out = a
        .output
        .as_deref()
        .expect("clap requires --output without --list");
    let params = ShdrConvertParams {
        position_key: a.position_key.clone(),
        load_key: a.load_key.clone(),
        torque_per_load_nm: a.torque_per_load_nm,
        time_origin: match a.time_origin {
            OriginArg::File => TimeOrigin::FirstLine,
            OriginArg::Trace => TimeOrigin::FirstSample,
        },
    };
    let imported = log.to_trace(&model, axis, &params)?;
    if !a.keep_empty_channels {
        check_informative(&imported)?;
    }
    write_output(&imported, out)?;
    out!("{}", summary(&imported, out));
    warn(&imported);
    Ok(())
}

fn run_umich(a: UmichArgs) -> Result<()> {
    if !(a.rate_hz.is_finite() && a.rate_hz > 0.0) {
        return Err(BadInput(format!("--rate-hz {} must be a positive rate", a.rate_hz)).into());
    }
    let table = read_umich(&a.file)?;
    if a.list {
        out!("{}", list_umich(&table, a.rate_hz));
        return Ok(());
    }
    let axis = a
        .axis
        .as_deref()
        .expect("clap requires --axis without --list");
    let out = a
        .output
        .as_deref()
        .expect("clap requires --output without --list");
    let params = UmichParams {
        rate_hz: a.rate_hz,
        current: match a.current {
            CurrentArg::Feedback => CurrentColumn::Feedback,
            CurrentArg::Output => CurrentColumn::Output,
        },
    };
    let imported = table.to_trace(axis, &params)?;
    if !a.keep_empty_channels {
        check_informative(&imported)?;
    }
    write_output(&imported, out)?;
    out!("{}", summary(&imported, out));
    warn(&imported);
    Ok(())
}

/// Write the trace under a temporary name and rename it into place: an error leaves nothing.
fn write_output(imported: &Imported, out: &Path) -> Result<()> {
    let mut f = AtomicFile::create(out)?;
    write_trace_csv(imported, &mut *f.writer())
        .with_context(|| format!("writing {}", out.display()))?;
    f.commit()
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

fn summary(imp: &Imported, out: &Path) -> String {
    let r = &imp.report;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "wrote {} (long layout: position_mm, {})",
        out.display(),
        imp.trace.effort_kind.column()
    );
    channel_line(&mut s, "position_mm", &r.position);
    channel_line(&mut s, imp.trace.effort_kind.column(), &r.effort);
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

fn warn(imp: &Imported) {
    for w in &imp.report.warnings {
        eprintln!("warning: {w}");
    }
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
