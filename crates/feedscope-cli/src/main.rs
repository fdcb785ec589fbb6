//! The `feedscope` command-line tool.
use clap::Parser;
mod cmd;
mod output;
mod plot;

fn main() -> std::process::ExitCode {
    let cli = cmd::Cli::parse();
    cmd::run(cli)
}
