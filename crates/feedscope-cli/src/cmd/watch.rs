//! `feedscope watch`: follow one axis of a running control, recognise the planned tests it
//! runs and store each in the history as `history add` does (docs/live.md). The gateway and
//! its event loop are `feedscope_app::watch`; this connects the source the flags name, opens
//! the store, stops on Ctrl-C and prints what the gateway tells.
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::builder::{EnumValueParser, TypedValueParser};
use clap::Subcommand;
use feedscope_app::watch::{source_error, EffortHints, Gateway, WatchEvent, WatchRequest};
use feedscope_live::mtconnect::agent::{AgentParams, AgentSource};
use feedscope_live::mtconnect::shdr::{ShdrParams, ShdrSource};
use feedscope_live::mtconnect::AxisSelection;
use feedscope_live::opcua::{OpcUaConfig, OpcUaSource};
use feedscope_live::Source;
use feedscope_store::TestKind;

use super::history::KindArg;
use crate::front::Cli;
use crate::output::outln;
use crate::store::Open as _;

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

impl WatchArgs {
    fn request(&self) -> WatchRequest {
        WatchRequest {
            axis_file: self.axis_file.clone(),
            machine: self.machine.clone(),
            axis_name: self.axis_name.clone(),
            kind: self.kind,
            program: self.program.clone(),
            once: self.once,
            standstill_s: self.standstill_s,
            position_quantum_mm: self.position_quantum_mm,
            interval_mm: self.interval_mm,
            want_order: self.want_order,
            stop_on_bad_value: self.stop_on_bad_value,
        }
    }
}

pub fn run(args: Args) -> Result<()> {
    let front = Cli::default();
    // The flags checked and the axis file read before any connection.
    match args.source {
        WatchSource::Mtconnect(a) => {
            let effort = EffortHints::drive_load(a.items.torque_per_load_nm, &front)?;
            let gateway = a.watch.request().gateway(&front)?.with_effort(effort);
            let params = AgentParams {
                url: a.agent.clone(),
                count: a.count.max(1),
                poll: Duration::from_millis(a.poll_ms),
                ..AgentParams::default()
            };
            let src = AgentSource::connect(params, &selection(&a.items)).map_err(source_error)?;
            watch(Box::new(src), &a.watch, &gateway, &front)
        }
        WatchSource::Shdr(a) => {
            let effort = EffortHints::drive_load(a.items.torque_per_load_nm, &front)?;
            let gateway = a.watch.request().gateway(&front)?.with_effort(effort);
            let model = feedscope_io::import::devices::DeviceModel::read(&a.devices)?;
            let params = ShdrParams {
                adapter: a.adapter.clone(),
                ..ShdrParams::default()
            };
            let src = ShdrSource::new(params, model, &selection(&a.items)).map_err(source_error)?;
            watch(Box::new(src), &a.watch, &gateway, &front)
        }
        WatchSource::Opcua(a) => {
            let gateway = a.watch.request().gateway(&front)?;
            let config = OpcUaConfig::from_file(&a.source).map_err(source_error)?;
            for warning in config.warnings() {
                eprintln!("warning: {}: {warning}", a.source.display());
            }
            let gateway = gateway.with_effort(EffortHints::opcua(&config));
            let src = OpcUaSource::connect(config).map_err(source_error)?;
            watch(Box::new(src), &a.watch, &gateway, &front)
        }
    }
}

/// Open the store, install the Ctrl-C handler and run the gateway, printing what it does:
/// each stored test's lines on stdout, everything else on stderr.
fn watch(mut src: Box<dyn Source>, w: &WatchArgs, gateway: &Gateway, front: &Cli) -> Result<()> {
    let spec = crate::store::resolve(w.db.as_deref(), w.store.as_deref())?;
    let mut store = spec.open()?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst))
            .context("installing the Ctrl-C handler")?;
    }
    let mut print = |event: WatchEvent<'_>| -> Result<()> {
        match event {
            WatchEvent::Watching { .. } => eprintln!("{event}; Ctrl-C stops"),
            WatchEvent::Stored(t) => {
                outln!("{}", t.status_line());
                outln!("{}", t.resolution_line());
                eprintln!("{}", t.latency_line());
            }
            event => eprintln!("{event}"),
        }
        Ok(())
    };
    gateway.run(&mut *src, &mut *store, &spec, &stop, front, &mut print)?;
    Ok(())
}
