//! One module per subcommand.
use clap::{Parser, Subcommand};

mod simulate;

/// feedscope: how are the ball-screw feed drives of this machine doing?
#[derive(Debug, Parser)]
#[command(name = "feedscope", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    // Help text from the doc comment of `simulate::Args`.
    Simulate(simulate::Args),
}

pub fn run(cli: Cli) -> std::process::ExitCode {
    match cli.command {
        Command::Simulate(args) => simulate::run(args),
    }
}
