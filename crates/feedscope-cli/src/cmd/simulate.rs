//! `feedscope simulate`: traces of a simulated drive whose friction is known; the twin's config,
//! the run and the four output files are [`feedscope_app::simulate`]'s.
//!
//! Writes `DIR/trace.csv` (or the `--trace` name; Parquet when it ends in `.parquet`),
//! `DIR/axis.toml`, `DIR/truth.json` and `DIR/truth.csv`. All four are
//! written under temporary names and renamed at the end, so an error leaves no partial output.
//! Exit codes: 0 ok, 1 I/O failure, 2 bad input (config, arguments) or a diverging servo.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use feedscope::sim::SimConfig;
use feedscope::ErrorKind;
use feedscope_app::simulate::{SimulateRequest, TraceLayout};
use feedscope_app::FrontEnd;
use feedscope_io::trace::Layout;

use crate::front::flag;

/// Simulate a feed drive with known friction and write its trace and truth.
///
/// Files written under --out DIR: trace.csv (time_s and position_mm / current_a or torque_nm,
/// the controller's view), axis.toml (the axis, for `feedscope estimate DIR/trace.csv --axis
/// DIR/axis.toml`), truth.json (friction model and commanded strokes), truth.csv
/// (time_s,position_mm,velocity_mm_s,accel_mm_s2,friction_n of the true state). With --trace
/// NAME.parquet the trace is written as Parquet instead (columns time_s, position_m,
/// current_a or torque_nm; or time_s, channel, value), at full precision. Config keys carry
/// their units (feed_mm_min, interval_ms, ...); see --print-default-config. The motion is
/// [[motion.stroke]] entries or an NC program (motion.program = inline G-code, or
/// motion.program_file, relative to the config file).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Simulator config (TOML); without it the default lathe Z axis, 0 → 410 → 0 mm at
    /// 100 mm/min, is simulated.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,

    /// Output directory (created if missing).
    #[arg(
        long,
        value_name = "DIR",
        required_unless_present = "print_default_config"
    )]
    out: Option<PathBuf>,

    /// File name of the trace under --out DIR; a name ending in .parquet writes Parquet
    /// (same layouts, SI units at full precision) instead of CSV.
    #[arg(long, value_name = "NAME", default_value = "trace.csv")]
    trace: String,

    /// Layout of the trace file: long (time_s,channel,value) or wide (time_s,position_mm,
    /// current_a; needs sampling.mode = "synchronous").
    #[arg(long, value_enum, default_value_t = LayoutArg::Long)]
    layout: LayoutArg,

    /// Seed of the random draws (jitter, dropouts, noise); overrides `seed` of the config.
    #[arg(long, value_name = "N")]
    seed: Option<u64>,

    /// Print the default config (TOML, all keys with units) to stdout and exit.
    #[arg(long)]
    print_default_config: bool,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum LayoutArg {
    Long,
    Wide,
}

/// The command line while simulating: its own bar (`simulating [bar] 42% eta 3s`), fields
/// spelled as flags.
struct Simulating(indicatif::ProgressBar);

impl FrontEnd for Simulating {
    fn progress(&self, _what: &str, done: usize, total: usize) {
        if done >= total {
            self.0.finish_and_clear();
        } else {
            self.0.set_position(done as u64);
        }
    }

    fn name(&self, field: &str) -> String {
        flag(field)
    }

    fn spell(&self, field: &str, value: &str) -> String {
        format!("{} {value}", flag(field))
    }
}

impl Drop for Simulating {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

/// Run the subcommand; errors are printed to stderr with their causes: exit code 2 for what
/// the request's checks and the simulation find, 1 for outputs that cannot be written.
pub fn run(args: Args) -> ExitCode {
    match execute(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let code = if error_kind(&e) == ErrorKind::BadInput {
                2
            } else {
                1
            };
            eprintln!("error: {e:#}");
            ExitCode::from(code)
        }
    }
}

/// The kind of the use case's error itself (not of a cause below it, which may say otherwise:
/// a missing program file under a bad config is the config's).
fn error_kind(e: &anyhow::Error) -> ErrorKind {
    e.downcast_ref::<feedscope_app::AppError>()
        .map_or(ErrorKind::Internal, feedscope_app::AppError::kind)
}

fn execute(args: Args) -> anyhow::Result<()> {
    if args.print_default_config {
        let text = SimConfig::default().to_toml_string()?;
        let mut out = std::io::stdout().lock();
        return match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
            Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
                Err(anyhow::Error::new(e).context("writing to stdout"))
            }
            _ => Ok(()),
        };
    }
    let request = SimulateRequest {
        config: args.config,
        out: args.out.unwrap_or_default(),
        trace: args.trace,
        layout: match args.layout {
            LayoutArg::Long => TraceLayout::Long,
            LayoutArg::Wide => TraceLayout::Wide,
        },
        seed: args.seed,
    };
    let bar = indicatif::ProgressBar::new(1000);
    bar.set_style(
        indicatif::ProgressStyle::with_template("simulating {bar:40} {percent:>3}% eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let done = request.run(&Simulating(bar))?;
    let trace = &done.output.trace;
    eprintln!(
        "wrote {} position and {} {} samples over {:.1} s to {}",
        trace.position_m.len(),
        trace.effort.len(),
        trace.effort_kind.column(),
        done.output.truth.duration_s,
        done.dir.display()
    );
    Ok(())
}

/// The outputs of a simulation under `dir`, the trace as `trace.csv`
/// ([`feedscope_app::simulate::write_outputs`]).
pub(crate) fn write_outputs(
    dir: &Path,
    out: &feedscope::sim::SimOutput,
    layout: Layout,
) -> anyhow::Result<()> {
    Ok(feedscope_app::simulate::write_outputs(
        dir,
        out,
        layout,
        "trace.csv",
    )?)
}
