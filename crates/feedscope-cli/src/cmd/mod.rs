//! One module per subcommand.
use clap::{Parser, Subcommand};

mod dynamics;

/// feedscope: how are the ball-screw feed drives of this machine doing?
#[derive(Debug, Parser)]
#[command(name = "feedscope", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Natural frequency vs feed rate and position; torque-ripple resonance risks.
    Dynamics(dynamics::Args),
}

pub fn run(cli: Cli) -> std::process::ExitCode {
    match cli.command {
        Command::Dynamics(args) => dynamics::finish(dynamics::run(args)),
    }
}
