//! `feedscope watch`: follow one axis of a running control, recognise the planned tests it
//! runs and store each in the history as `history add` does (docs/live.md).
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use clap::builder::{EnumValueParser, TypedValueParser};
use clap::Subcommand;
use feedscope::trace::GlitchParams;
use feedscope_io::trace::{parse_trace_with, write_csv, Layout, ReadOptions};
use feedscope_live::mtconnect::agent::{AgentParams, AgentSource};
use feedscope_live::mtconnect::shdr::{ShdrParams, ShdrSource};
use feedscope_live::mtconnect::AxisSelection;
use feedscope_live::opcua::{EffortUnit, OpcUaConfig, OpcUaSource};
use feedscope_live::watch::{feed_for_order_m_s, Outcome, Recognizer, RecognizerParams};
use feedscope_live::{Event, GapReason, Source};
use feedscope_store::time::format_rfc3339;
use feedscope_store::{AddOutcome, TestKind};

use super::history::{analyse_and_store, KindArg};
use crate::store::Open as _;
use crate::store::StoreSpec;
use feedscope_app::history::TestMeta;
use feedscope_app::AppError;

/// Watch a running control: recognise the planned tests and store each in the history.
///
/// Follows one axis over MTConnect (an agent's REST API or an adapter's SHDR stream) or OPC UA
/// (a subscription to the nodes a source file names), splits
/// the motion into episodes at standstill, and stores every episode that is the test
/// `feedscope plan` writes (--kind) exactly as `history add` would. An episode with a data
/// gap, or cut short by Ctrl-C, is discarded with a message, never stored.
///
/// Exit codes: 0 stopped (Ctrl-C, or --once after the first stored test); 1 the source
/// failed for good; 2 bad input (axis file, device model, items, flags; a value that is no
/// number with --stop-on-bad-value).
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub source: WatchSource,
}

#[derive(Debug, Subcommand)]
pub enum WatchSource {
    /// An MTConnect agent (REST: /probe, /current, /sample).
    Mtconnect(MtconnectArgs),
    /// An MTConnect adapter's SHDR stream over TCP (needs the adapter's Devices.xml).
    Shdr(ShdrArgs),
    /// An OPC UA server (SINUMERIK, a CNC companion-spec server): subscribes to the nodes a
    /// TOML source file names (docs/opcua.md; examples/opcua/).
    Opcua(OpcUaArgs),
}

#[derive(Debug, clap::Args)]
pub struct OpcUaArgs {
    /// Source file (TOML): endpoint, security, the position and effort nodes with their units,
    /// the sampling interval (docs/opcua.md).
    #[arg(long)]
    pub source: PathBuf,
    #[command(flatten)]
    pub watch: WatchArgs,
}

/// The items of the axis, as `feedscope import shdr` chooses them.
#[derive(Debug, clap::Args)]
pub struct ItemArgs {
    /// Device name, id or uuid [default: the only device].
    #[arg(long)]
    pub device: Option<String>,
    /// Axis name, id or native name in the device model (e.g. X, Z1).
    #[arg(long)]
    pub axis: String,
    /// Position data item (name or id) [default: the axis's POSITION ACTUAL, machine
    /// coordinates].
    #[arg(long)]
    pub position_key: Option<String>,
    /// Load data item (name or id) [default: the axis's only LOAD].
    #[arg(long)]
    pub load_key: Option<String>,
    /// Motor torque at 100 % load (N·m); required, feedscope never guesses a drive's rating.
    #[arg(long)]
    pub torque_per_load_nm: f64,
}

#[derive(Debug, clap::Args)]
pub struct MtconnectArgs {
    /// Agent base URL, e.g. http://HOST:5000.
    #[arg(long)]
    pub agent: String,
    /// Observations asked per /sample request.
    #[arg(long, default_value_t = 1000)]
    pub count: u64,
    /// Wait between polls when the agent has nothing new (ms).
    #[arg(long, default_value_t = 250)]
    pub poll_ms: u64,
    #[command(flatten)]
    pub items: ItemArgs,
    #[command(flatten)]
    pub watch: WatchArgs,
}

#[derive(Debug, clap::Args)]
pub struct ShdrArgs {
    /// Adapter address HOST:PORT (port 7878 when left out).
    #[arg(long)]
    pub adapter: String,
    /// The adapter's device model (Devices.xml).
    #[arg(long)]
    pub devices: PathBuf,
    #[command(flatten)]
    pub items: ItemArgs,
    #[command(flatten)]
    pub watch: WatchArgs,
}

/// What to look for and where to store it (shared by every source).
#[derive(Debug, clap::Args)]
pub struct WatchArgs {
    /// Axis parameters (TOML or JSON), as for `history add`.
    #[arg(long)]
    pub axis_file: PathBuf,
    /// Machine name in the history.
    #[arg(long, default_value = "machine")]
    pub machine: String,
    /// Axis name in the history [default: the axis file's `name`, else its file stem].
    #[arg(long)]
    pub axis_name: Option<String>,
    /// Which test to recognise.
    #[arg(long, value_parser = EnumValueParser::<KindArg>::new().map(TestKind::from))]
    pub kind: TestKind,
    /// Only motion while the control's program name contains this.
    #[arg(long)]
    pub program: Option<String>,
    /// Stop after the first stored test.
    #[arg(long)]
    pub once: bool,
    /// Database file [env: FEEDSCOPE_DB] [default: feedscope.db].
    #[arg(long, conflicts_with = "store")]
    pub db: Option<PathBuf>,
    /// History store: a postgres://USER@HOST/DB URL or an SQLite file [env: FEEDSCOPE_STORE]
    /// (docs/history.md).
    #[arg(long)]
    pub store: Option<String>,
    /// Standstill that ends a motion episode (s).
    #[arg(long, default_value_t = 2.0)]
    pub standstill_s: f64,
    /// Position changes up to this are no motion (mm).
    #[arg(long, default_value_t = 0.001)]
    pub position_quantum_mm: f64,
    /// Width of the position intervals of the mean-friction indicators (mm).
    #[arg(long, default_value_t = feedscope::study::StrokeStudyParams::default().interval_mm)]
    pub interval_mm: f64,
    /// Also say which feed resolves this screw order at the observed sample interval.
    #[arg(long)]
    pub want_order: Option<f64>,
    /// Stop (exit 2) when the position or effort node delivers a value that is no number
    /// (e.g. a String) [default: discard the test around it, say so, and go on watching].
    #[arg(long)]
    pub stop_on_bad_value: bool,
}

fn selection(i: &ItemArgs) -> AxisSelection {
    AxisSelection {
        device: i.device.clone(),
        axis: i.axis.clone(),
        position_key: i.position_key.clone(),
        load_key: i.load_key.clone(),
        torque_per_load_nm: Some(i.torque_per_load_nm),
    }
}

fn live_err(e: feedscope_live::LiveError) -> anyhow::Error {
    match e {
        feedscope_live::LiveError::Config { .. } => AppError::bad_input(e.to_string()).into(),
        e => anyhow::Error::new(e),
    }
}

pub fn run(args: Args) -> Result<()> {
    match args.source {
        WatchSource::Mtconnect(a) => {
            let w = check(&a.watch, &a.items)?;
            let params = AgentParams {
                url: a.agent.clone(),
                count: a.count.max(1),
                poll: Duration::from_millis(a.poll_ms),
                ..AgentParams::default()
            };
            let src = AgentSource::connect(params, &selection(&a.items)).map_err(live_err)?;
            let effort = EffortHints {
                quantum: Some(a.items.torque_per_load_nm / 100.0),
                signed: Some(false),
            };
            watch(Box::new(src), &a.watch, w, effort)
        }
        WatchSource::Shdr(a) => {
            let w = check(&a.watch, &a.items)?;
            let model = feedscope_io::import::devices::DeviceModel::read(&a.devices)?;
            let params = ShdrParams {
                adapter: a.adapter.clone(),
                ..ShdrParams::default()
            };
            let src = ShdrSource::new(params, model, &selection(&a.items)).map_err(live_err)?;
            let effort = EffortHints {
                // SHDR and agent load: whole percent of the torque at 100 %, a magnitude.
                quantum: Some(a.items.torque_per_load_nm / 100.0),
                signed: Some(false),
            };
            watch(Box::new(src), &a.watch, w, effort)
        }
        WatchSource::Opcua(a) => {
            let w = check_watch(&a.watch)?;
            let config = OpcUaConfig::from_file(&a.source).map_err(live_err)?;
            for warning in config.warnings() {
                eprintln!("warning: {}: {warning}", a.source.display());
            }
            let effort = match config.effort.unit {
                // A load reading is a magnitude; its resolution is not known in advance.
                EffortUnit::Percent { .. } => EffortHints {
                    quantum: None,
                    signed: Some(false),
                },
                _ => EffortHints::default(),
            };
            let src = OpcUaSource::connect(config).map_err(live_err)?;
            watch(Box::new(src), &a.watch, w, effort)
        }
    }
}

/// What the source says about its effort channel, for the analysis of each test.
#[derive(Debug, Default, Clone, Copy)]
struct EffortHints {
    /// Resolution of the effort in SI units, when the protocol fixes it.
    quantum: Option<f64>,
    /// `Some(false)` for a magnitude (a drive load), `None` to judge from the data.
    signed: Option<bool>,
}

/// Validate the flags and read the axis file before any connection.
fn check(w: &WatchArgs, i: &ItemArgs) -> Result<feedscope::axis::AxisParams> {
    if !(i.torque_per_load_nm.is_finite() && i.torque_per_load_nm > 0.0) {
        return Err(AppError::bad_input("--torque-per-load-nm must be a positive torque").into());
    }
    check_watch(w)
}

/// Validate the flags every source shares and read the axis file.
fn check_watch(w: &WatchArgs) -> Result<feedscope::axis::AxisParams> {
    if !(w.standstill_s.is_finite() && w.standstill_s > 0.0) {
        return Err(AppError::bad_input("--standstill-s must be a positive time").into());
    }
    if !(w.position_quantum_mm.is_finite() && w.position_quantum_mm >= 0.0) {
        return Err(AppError::bad_input("--position-quantum-mm must be ≥ 0").into());
    }
    if !(w.interval_mm.is_finite() && w.interval_mm > 0.0) {
        return Err(AppError::bad_input("--interval-mm must be a positive length").into());
    }
    if w.want_order.is_some_and(|k| !(k.is_finite() && k > 0.0)) {
        return Err(AppError::bad_input("--want-order must be a positive order").into());
    }
    Ok(match w.kind {
        TestKind::Triangle => feedscope_io::axis::load_for_identification(&w.axis_file)?,
        _ => feedscope_io::axis::load(&w.axis_file)?,
    })
}

fn watch(
    mut src: Box<dyn Source>,
    w: &WatchArgs,
    axis: feedscope::axis::AxisParams,
    effort: EffortHints,
) -> Result<()> {
    let spec = crate::store::resolve(w.db.as_deref(), w.store.as_deref())?;
    let mut store = spec.open()?;
    let axis_name =
        feedscope_app::history::axis_label(w.axis_name.as_deref(), &axis, Some(&w.axis_file));
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst))
            .context("installing the Ctrl-C handler")?;
    }
    let mut rec = Recognizer::new(RecognizerParams {
        kind: match w.kind {
            TestKind::Triangle => feedscope::plan::TestKind::Triangle,
            _ => feedscope::plan::TestKind::Strokes,
        },
        standstill_s: w.standstill_s,
        position_quantum_m: w.position_quantum_mm * 1e-3,
        program: w.program.clone(),
        effort_quantum: effort.quantum,
        effort_signed: effort.signed,
        ..RecognizerParams::default()
    });
    eprintln!(
        "watching {} for {} tests of machine {:?} axis {:?} (store {}); Ctrl-C stops",
        src.describe(),
        w.kind.as_str(),
        w.machine,
        axis_name,
        spec.describe()
    );
    let lead_m = axis.lead_m();
    let mut connected = true;
    let mut bad_value: Option<String> = None;
    let mut last_event = Instant::now();
    let mut stored = 0usize;
    loop {
        if stop.load(Ordering::SeqCst) {
            if let Some(Outcome::Discarded { reason, .. }) = rec.shutdown() {
                eprintln!("{reason}");
            }
            eprintln!("stopped; {stored} test(s) stored");
            return Ok(());
        }
        let deadline = Instant::now() + Duration::from_millis(200);
        let outcome = match src.next_event(deadline).map_err(anyhow::Error::new)? {
            Some(ev) => {
                last_event = Instant::now();
                match &ev {
                    Event::Notice {
                        message,
                        connected: c,
                    } => {
                        connected = *c;
                        eprintln!("{message}");
                    }
                    Event::Gap { reason, .. } => {
                        eprintln!("gap: {reason}");
                        match reason {
                            GapReason::ConnectionLost { .. } => connected = false,
                            GapReason::Reconnected { .. } => connected = true,
                            GapReason::BadValue { .. } if w.stop_on_bad_value => {
                                bad_value = Some(reason.to_string());
                            }
                            _ => {}
                        }
                    }
                    _ => {}
                }
                rec.push(&ev)
            }
            // Control time goes on while the axis stands still and a change-only stream says
            // nothing: the wall clock since the last event stands in for it, unless the source
            // is disconnected (the data of that time may still come), and only as far as the
            // source vouches that nothing is missing (a server that went silent may yet be
            // found lost).
            None if connected => {
                let now = Instant::now();
                let upto = src
                    .confirmed_until()
                    .map_or(now, |c| c.min(now))
                    .max(last_event);
                rec.now_s()
                    .and_then(|t| rec.tick(t + (upto - last_event).as_secs_f64()))
            }
            None => None,
        };
        if let Some(why) = bad_value.take() {
            if let Some(Outcome::Discarded {
                start_time_s,
                reason,
            }) = &outcome
            {
                eprintln!(
                    "motion at {} discarded: {reason}",
                    format_rfc3339(*start_time_s)
                );
            }
            return Err(AppError::bad_input(format!(
                "{why} (--stop-on-bad-value); {stored} test(s) stored"
            ))
            .into());
        }
        let Some(outcome) = outcome else { continue };
        match outcome {
            Outcome::NotATest {
                start_time_s,
                reason,
            } => eprintln!(
                "motion at {}: not a {} test ({reason})",
                format_rfc3339(start_time_s),
                w.kind.as_str()
            ),
            Outcome::Discarded {
                start_time_s,
                reason,
            } => eprintln!(
                "motion at {} discarded: {reason}",
                format_rfc3339(start_time_s)
            ),
            Outcome::Test(t) => {
                let finished = Instant::now();
                match store_test(&mut *store, &spec, &t, &axis, &axis_name, w) {
                    Ok(line) => {
                        let ms = finished.elapsed().as_secs_f64() * 1e3;
                        crate::output::outln!("{line}");
                        let k = t.resolvable_order(lead_m);
                        crate::output::outln!(
                            "  sample interval {:.3} s: screw orders up to {k:.1} resolvable at \
                             {:.1} mm/min (lead {} mm){}",
                            t.sample_interval_s,
                            t.feeds_m_s.last().copied().unwrap_or(f64::NAN) * 6e4,
                            axis.lead_mm,
                            match w.want_order {
                                Some(o) => format!(
                                    "; order {o} needs a feed ≤ {:.1} mm/min",
                                    feed_for_order_m_s(lead_m, o, t.sample_interval_s) * 6e4
                                ),
                                None => String::new(),
                            }
                        );
                        eprintln!(
                            "analysed and stored {ms:.0} ms after the test's last sample arrived"
                        );
                        stored += 1;
                        if w.once {
                            return Ok(());
                        }
                    }
                    Err(e) => eprintln!(
                        "test at {} not stored: {e:#}",
                        format_rfc3339(t.start_time_s)
                    ),
                }
            }
        }
    }
}

/// Analyse and store one test as `history add` does; the line to print.
fn store_test(
    store: &mut dyn feedscope_store::Store,
    spec: &StoreSpec,
    t: &feedscope_live::watch::FinishedTest,
    axis: &feedscope::axis::AxisParams,
    axis_name: &str,
    w: &WatchArgs,
) -> Result<String> {
    // The trace goes through the CSV writer and reader, as a file given to `history add`
    // would: the same glitch screening, and its bytes identify duplicates.
    let mut bytes = Vec::new();
    write_csv(&t.trace, &mut bytes, Layout::Long)?;
    let source = format!("watch {}", format_rfc3339(t.start_time_s));
    let (trace, _) = parse_trace_with(
        &bytes,
        &source,
        &ReadOptions::default(),
        &GlitchParams::for_axis(axis),
    )?;
    let mut axis = axis.clone();
    let meta = TestMeta {
        machine: w.machine.clone(),
        axis: axis_name.to_string(),
        time_s: t.start_time_s,
        source,
        program: t.program.clone(),
        reference: false,
        compensation: None,
    };
    let (outcome, nt) = analyse_and_store(
        store,
        spec,
        &trace,
        &mut axis,
        w.kind,
        w.interval_mm,
        &bytes,
        meta,
    )?;
    let stored = match outcome {
        AddOutcome::Added(id) => format!("stored test {id}"),
        AddOutcome::Duplicate(id) => format!("duplicate of test {id}"),
    };
    let feeds: Vec<String> = t
        .feeds_m_s
        .iter()
        .map(|f| format!("{:.1}", f * 6e4))
        .collect();
    let status = trend_status(store, &w.machine, axis_name);
    Ok(format!(
        "{}  {} strokes  feed {} mm/min  {stored}  trend {status}",
        nt.time_utc,
        t.strokes,
        feeds.join("/"),
    ))
}

/// The axis's trend in one word: the worst indicator status, or why there is none yet.
fn trend_status(store: &dyn feedscope_store::Store, machine: &str, axis: &str) -> String {
    let options = feedscope_app::trend::TrendOptions::default();
    let front = crate::front::Cli::default();
    match feedscope_app::trend::axis_trend(
        store,
        machine,
        Some(axis),
        &options,
        Default::default(),
        &front,
    ) {
        Ok(t) => t.status_line(),
        Err(e) => format!("not available ({e:#})"),
    }
}
