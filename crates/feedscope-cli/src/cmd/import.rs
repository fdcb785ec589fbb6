//! `feedscope import`: real controller exports (MTConnect SHDR logs, UMich mill CSV,
//! SINUMERIK Operate servo traces, TwinCAT Scope exports) into feedscope trace CSV.
use crate::output::out;
use std::path::PathBuf;

use anyhow::Result;
use clap::ValueEnum;
use feedscope_app::import::{ImportRequest, ImportSource};
use feedscope_io::import::shdr::{ShdrConvertParams, TimeOrigin};
use feedscope_io::import::sinumerik::SinumerikParams;
use feedscope_io::import::twincat::TwincatParams;
use feedscope_io::import::umich::{CurrentColumn, UmichParams};
use feedscope_io::import::units::{EffortUnit, PositionUnit};

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
        out!("{}", source.list(&front)?.text(&front));
        return Ok(());
    }
    let request = ImportRequest {
        source,
        output: output.expect("clap requires --output without --list"),
        keep_empty_channels,
    };
    let done = request.run(&front)?;
    out!("{}", done.text());
    for n in &done.notes {
        eprintln!("note: {n}");
    }
    for w in &done.import.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}
