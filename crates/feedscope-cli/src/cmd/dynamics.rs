//! `feedscope dynamics`: natural frequencies of the feed drive against feed rate and nut
//! position, bearing unloading and torque-ripple resonance risks ([`feedscope_app::dynamics`]
//! does the work and names the files it writes; see docs/dynamics.md).
//!
//! Exit codes (mapped in `cmd::run`): 0 ok; 2 bad input: an unreadable or invalid drive file,
//! naming the key; 1 anything else (e.g. the output directory cannot be written). The drive
//! file is validated before any output is written.

use std::io::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use feedscope_app::dynamics::DynamicsRequest;

use crate::front::Cli;

/// Output format of the summary on stdout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// A few human-readable lines.
    Text,
    /// One JSON object.
    Json,
}

/// Natural frequency of the ball-screw feed system vs feed rate and table position, and
/// where the motor's torque ripple makes it resonate.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Drive file (TOML, units in the keys); see examples/drive.toml and docs/dynamics.md.
    #[arg(long, value_name = "FILE")]
    pub config: PathBuf,
    /// Directory for the JSON, CSV and SVG outputs (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Summary format on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

/// Run the subcommand.
pub fn run(args: Args) -> Result<()> {
    let request = DynamicsRequest {
        config: args.config,
        out: args.out,
    };
    let done = request.run(&Cli::default())?;
    for f in &done.files {
        eprintln!("wrote {}", f.display());
    }
    let text = match args.format {
        Format::Text => done.summary_text(),
        Format::Json => {
            let mut s = serde_json::to_string_pretty(&done.summary())?;
            s.push('\n');
            s
        }
    };
    let mut stdout = std::io::stdout().lock();
    match stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
    {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other.context("cannot write to stdout"),
    }
}
