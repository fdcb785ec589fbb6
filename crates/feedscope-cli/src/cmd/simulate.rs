//! `feedscope simulate`: traces of a simulated drive whose friction is known.
//!
//! Writes `DIR/trace.csv` (or the `--trace` name; Parquet when it ends in `.parquet`),
//! `DIR/axis.toml`, `DIR/truth.json` and `DIR/truth.csv`. All four are
//! written under temporary names and renamed at the end, so an error leaves no partial output.
//! Exit codes: 0 ok, 1 I/O failure, 2 bad input (config, arguments) or a diverging servo.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use feedscope::sim::{simulate, SamplingMode, SimConfig};
use feedscope_io::trace::{write_csv, write_parquet, Layout};

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

/// Why the command failed: bad input (exit 2) or anything else (exit 1).
enum Failure {
    BadInput(anyhow::Error),
    Other(anyhow::Error),
}

/// Run the subcommand; errors are printed to stderr with their context.
pub fn run(args: Args) -> ExitCode {
    match execute(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::BadInput(e)) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
        Err(Failure::Other(e)) => {
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}

fn execute(args: Args) -> Result<(), Failure> {
    if args.print_default_config {
        let text = SimConfig::default()
            .to_toml_string()
            .map_err(|e| Failure::Other(e.into()))?;
        let mut out = std::io::stdout().lock();
        return match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
            Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure::Other(
                anyhow::Error::new(e).context("writing to stdout"),
            )),
            _ => Ok(()),
        };
    }

    // Parse and validate everything before any output exists.
    let (cfg, layout, dir) = prepare(&args).map_err(Failure::BadInput)?;
    let trace_name = args.trace.as_str();

    let bar = indicatif::ProgressBar::new(1000);
    bar.set_style(
        indicatif::ProgressStyle::with_template("simulating {bar:40} {percent:>3}% eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let result = simulate(&cfg, &mut |f| bar.set_position((f * 1000.0) as u64));
    bar.finish_and_clear();
    let out = result
        .context("simulation failed")
        .map_err(Failure::BadInput)?;

    write_outputs_as(&dir, &out, layout, trace_name).map_err(Failure::Other)?;
    eprintln!(
        "wrote {} position and {} {} samples over {:.1} s to {}",
        out.trace.position_m.len(),
        out.trace.effort.len(),
        out.trace.effort_kind.column(),
        out.truth.duration_s,
        dir.display()
    );
    Ok(())
}

fn prepare(args: &Args) -> anyhow::Result<(SimConfig, Layout, PathBuf)> {
    let mut cfg = match &args.config {
        Some(path) => {
            let text = feedscope_io::bounded::read_to_string(
                path,
                feedscope_io::bounded::MAX_CONFIG_BYTES,
            )
            .with_context(|| format!("reading config {}", path.display()))?;
            // A relative motion.program_file is read relative to the config file.
            let dir = path.parent().unwrap_or(Path::new("."));
            feedscope_io::sim::config_from_toml_str_in_dir(&text, dir)
                .with_context(|| format!("config {}", path.display()))?
        }
        None => SimConfig::default(),
    };
    if let Some(seed) = args.seed {
        cfg.seed = seed;
    }
    cfg.validate().context("config")?;
    let layout = match args.layout {
        LayoutArg::Long => Layout::Long,
        LayoutArg::Wide => {
            if cfg.sampling.mode != SamplingMode::Synchronous {
                bail!(
                    "--layout wide needs both channels on the same timestamps: set \
                     sampling.mode = \"synchronous\" in the config, or use --layout long"
                );
            }
            Layout::Wide
        }
    };
    let plain = Path::new(&args.trace)
        .file_name()
        .is_some_and(|n| n == args.trace.as_str());
    if !plain || args.trace.starts_with('.') {
        bail!(
            "--trace {}: expected a plain file name (written under --out DIR)",
            args.trace
        );
    }
    if ["axis.toml", "truth.json", "truth.csv"].contains(&args.trace.as_str()) {
        bail!(
            "--trace {}: that name is taken by another output",
            args.trace
        );
    }
    let Some(dir) = args.out.clone() else {
        bail!("--out DIR is required");
    };
    if dir.exists() && !dir.is_dir() {
        bail!("--out {} exists and is not a directory", dir.display());
    }
    Ok((cfg, layout, dir))
}

fn tmp_name(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!(".{name}.{}.tmp", std::process::id()))
}

/// Write the four files (the trace as `trace.csv`) under temporary names, then rename them; on
/// error remove what was written (and the directory if this call created it).
pub(crate) fn write_outputs(
    dir: &Path,
    out: &feedscope::sim::SimOutput,
    layout: Layout,
) -> anyhow::Result<()> {
    write_outputs_as(dir, out, layout, "trace.csv")
}

/// [`write_outputs`] with the trace named `trace_name`: Parquet when it ends in `.parquet`.
pub(crate) fn write_outputs_as(
    dir: &Path,
    out: &feedscope::sim::SimOutput,
    layout: Layout,
    trace_name: &str,
) -> anyhow::Result<()> {
    let files = [trace_name, "axis.toml", "truth.json", "truth.csv"];
    let parquet = Path::new(trace_name)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"));
    let created = !dir.exists();
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let result = (|| -> anyhow::Result<()> {
        let create = |name: &str| {
            let p = tmp_name(dir, name);
            feedscope_app::output::register(&p);
            std::fs::File::create(&p).with_context(|| format!("creating {}", p.display()))
        };
        if parquet {
            write_parquet(&out.trace, create(trace_name)?, layout)
        } else {
            write_csv(&out.trace, create(trace_name)?, layout)
        }
        .with_context(|| format!("writing {trace_name}"))?;
        let axis = toml::to_string_pretty(&out.truth.axis).context("serializing the axis")?;
        create("axis.toml")?
            .write_all(axis.as_bytes())
            .context("writing axis.toml")?;
        let json = serde_json::to_string_pretty(&out.truth).context("serializing the truth")?;
        create("truth.json")?
            .write_all(json.as_bytes())
            .context("writing truth.json")?;
        out.truth
            .write_states_csv(create("truth.csv")?)
            .context("writing truth.csv")?;
        for name in files {
            std::fs::rename(tmp_name(dir, name), dir.join(name))
                .with_context(|| format!("renaming to {}", dir.join(name).display()))?;
        }
        Ok(())
    })();
    for name in files {
        if result.is_err() {
            let _ = std::fs::remove_file(tmp_name(dir, name));
        }
        feedscope_app::output::unregister(&tmp_name(dir, name));
    }
    if result.is_err() && created {
        let _ = std::fs::remove_dir(dir);
    }
    result
}
